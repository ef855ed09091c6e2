"""The world's descriptions sealed for its iwz run: a sealed one read back off the wire holds, a
forged one (unsealed, sealed with another key, or carrying a seal copied from another) does not."""

from __future__ import annotations

import msgspec

from iw_zenoh.core.lab import Grid, Lab
from iw_zenoh.messages import RegisterRequest, RobotSpecMsg, WorldInfo, decode, encode
from iw_zenoh.nodes.world_seal import new_key, seal, sealed
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.world import WorldCore


def test_only_the_world_s_own_descriptions_hold_its_seal() -> None:
    core = WorldCore(WorldConfig(sim="t"), Lab("t", 20.0, 10.0), Grid(()))
    assert core.register(RegisterRequest(spec=RobotSpecMsg(name="a", x=3.0, y=3.0), agent="ag"), 0)[0].ok
    key, other = bytes.fromhex(new_key()), bytes.fromhex(new_key())
    info = decode(encode(seal(core.info(), key)), WorldInfo)  # as the launcher hears it
    assert sealed(info, key)
    assert not sealed(info, other)
    emptied = msgspec.structs.replace(info, robots=[], agents=[], revision=info.revision + 1)
    assert not sealed(emptied, key)  # its seal copied onto other content
    assert not sealed(msgspec.structs.replace(emptied, seal=msgspec.UNSET), key)
    assert seal(core.info(), None).seal is msgspec.UNSET  # a world started by hand seals nothing
