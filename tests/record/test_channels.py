"""The channels a recording and Foxglove live share: one declaration, one derivation."""

from __future__ import annotations

import io
import json

from mcap.reader import make_reader

from iw_zenoh import keys
from iw_zenoh.convert import lab_to_msg, spec_to_msg
from iw_zenoh.core.lab import Lab
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import WorldInfo, WorldState, encode, json_schema
from iw_zenoh.record.channels import Derivation, key_channel
from iw_zenoh.record.foxglove import SCENE_TOPIC, TF_TOPIC
from iw_zenoh.record.recording import Recorder
from iw_zenoh.record.schemas import portable

INFO = WorldInfo(
    revision=1,
    lab=lab_to_msg(Lab("l", 10.0, 10.0, ())),
    period_ns=100_000_000,
    robots=[spec_to_msg(RobotSpec("a", id=1, x_m=1.0, y_m=1.0, dir_deg=0.0))],
)
STATE = WorldState(
    tick=1,
    sim_time_ns=100_000_000,
    revision=1,
    ids=[1],
    x=[1.0],
    y=[2.0],
    heading=[0.0],
    collided=[False],
    rolled_left=[0.0],
    rolled_right=[0.0],
    speed=[0.0],
)


def test_a_key_of_a_known_kind_carries_its_message_schema_and_a_foreign_key_none() -> None:
    spec = key_channel(keys.state("s"))
    assert (spec.topic, spec.schema_name) == ("iw/s/world/state", "iw.WorldState/1")
    assert json.loads(spec.schema) == portable(json_schema(WorldState))
    assert spec.metadata == {"zenoh_key": "iw/s/world/state", "kind": "state"}
    other = key_channel("iw/s/elsewhere/thing")
    assert (other.schema_name, other.schema, other.metadata) == ("", b"", {"zenoh_key": "iw/s/elsewhere/thing"})


def test_the_derivation_draws_walls_once_then_bodies_and_transforms_each_state() -> None:
    d = Derivation()
    walls = d.derive(keys.info("s"), encode(INFO))
    assert [(c.topic, c.schema_name, c.metadata) for c, _ in walls] == [
        (SCENE_TOPIC, "foxglove.SceneUpdate", {"derived": "foxglove"})
    ]
    assert d.derive(keys.info("s"), encode(INFO)) == []  # the same revision: nothing new to draw
    drawn = d.derive(keys.state("s"), encode(STATE))
    assert [c.topic for c, _ in drawn] == [SCENE_TOPIC, TF_TOPIC]
    assert d.derive(keys.state("s"), b"{not json") == []
    assert d.derive(keys.tick("s"), b"{}") == []


def test_the_recorder_declares_exactly_the_shared_channels() -> None:
    out = io.BytesIO()
    rec = Recorder(out)
    rec.add(keys.info("s"), encode(INFO), 1)
    rec.add(keys.state("s"), encode(STATE), 2)
    rec.finish()
    out.seek(0)
    summary = make_reader(out).get_summary()
    assert summary is not None
    got = {
        c.topic: (summary.schemas[c.schema_id].name, summary.schemas[c.schema_id].data, c.metadata)
        for c in summary.channels.values()
    }
    d = Derivation()
    want = {
        spec.topic: (spec.schema_name, spec.schema, spec.metadata) for spec, _ in d.derive(keys.info("s"), encode(INFO))
    }
    want |= {
        spec.topic: (spec.schema_name, spec.schema, spec.metadata)
        for spec, _ in d.derive(keys.state("s"), encode(STATE))
    }
    for key in (keys.info("s"), keys.state("s")):
        spec = key_channel(key)
        want[key] = (spec.schema_name, spec.schema, spec.metadata)
    assert got == want
