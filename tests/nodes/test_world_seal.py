"""The world's descriptions sealed for its iwz run: a sealed one read back off the wire holds, a
forged one (unsealed, sealed with another key, or carrying a seal copied from another) does not,
and the launcher adopts no genuine one older than the one it keeps (a replay)."""

from __future__ import annotations

from pathlib import Path

import msgspec

from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.bus.net import free_port
from iw_zenoh.core.lab import Grid, Lab
from iw_zenoh.launch.launcher import Launcher
from iw_zenoh.messages import RegisterRequest, RobotSpecMsg, WorldInfo, decode, encode
from iw_zenoh.nodes.world_seal import new_key, seal, sealed
from iw_zenoh.scenario.file import load_scenario
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.world import WorldCore
from tests.support.scenarios import SCENARIO


def test_only_the_world_s_own_descriptions_hold_its_seal() -> None:
    core = WorldCore(WorldConfig(sim="t"), Lab("t", 20.0, 10.0), Grid(()))
    assert core.register(RegisterRequest(spec=RobotSpecMsg(name="a", x_m=3.0, y_m=3.0), agent="ag"), 0)[0].ok
    key, other = bytes.fromhex(new_key()), bytes.fromhex(new_key())
    info = decode(encode(seal(core.info(), key)), WorldInfo)  # as the launcher hears it
    assert sealed(info, key)
    assert not sealed(info, other)
    emptied = msgspec.structs.replace(info, robots=[], agents=[], revision=info.revision + 1)
    assert not sealed(emptied, key)  # its seal copied onto other content
    assert not sealed(msgspec.structs.replace(emptied, seal=msgspec.UNSET), key)
    assert seal(core.info(), None).seal is msgspec.UNSET  # a world started by hand seals nothing


def test_a_replayed_genuine_older_description_is_not_adopted(tmp_path: Path) -> None:
    """A description the world really sealed, recorded off the bus before a robot registered and
    replayed later, is not what a restarted world would resume from (it would drop the robot)."""
    (tmp_path / "lab.xml").write_text('<Lab Name="open" Width="20" Height="10"/>')
    (tmp_path / "judged.toml").write_text(SCENARIO)
    launcher = Launcher(load_scenario(tmp_path / "judged.toml"), port=free_port(), sim="judged", log_dir=tmp_path)
    key = bytes.fromhex(launcher.seal)
    core = WorldCore(WorldConfig(sim="judged"), Lab("t", 20.0, 10.0), Grid(()))
    old = encode(seal(core.info(), key))  # recorded by an eavesdropper: no robot yet
    assert core.register(RegisterRequest(spec=RobotSpecMsg(name="a", x_m=3.0, y_m=3.0), agent="ag"), 0)[0].ok
    infos = Inbox()
    infos.put((keys.info("judged"), encode(seal(core.info(), key)), 0))
    infos.put((keys.info("judged"), old, 0))  # replayed just before the world crashes
    launcher._update(Inbox(), Inbox(), infos)
    assert launcher.tally.info is not None
    assert [r.name for r in launcher.tally.info.robots] == ["a"]
    assert launcher.stale_infos == 1
    infos.put((keys.info("judged"), encode(seal(core.info(), key)), 0))  # the same revision again: kept
    launcher._update(Inbox(), Inbox(), infos)
    assert launcher.stale_infos == 1
