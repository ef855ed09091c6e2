"""Forged messages that decode but do not add up, on every key a role subscribes to: arrays of
different lengths, a robot named twice, a tick of 10^15, a robot the world does not have. No
role dies, the chairs keep driving, and each forgery is refused with an event naming its key."""

from __future__ import annotations

import json
import signal
from typing import Any

import pytest
from mcap.reader import make_reader

from iw_zenoh import keys
from iw_zenoh.messages import (
    ActionBatch,
    Actions,
    Control,
    Event,
    Hear,
    Message,
    PoseReport,
    Proposed,
    RadioBatch,
    RegisterReply,
    RegisterRequest,
    RobotSpecMsg,
    Say,
    SensorBatch,
    SensorReading,
    Tick,
    Verdict,
    WorldState,
    decode,
    encode,
)
from tests.integration.harness import Net, start_world, wait_alive, wait_msg, watch

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

FAR = 10**15  # a tick no world reaches


def _forged(msg: Message, **changes: Any) -> bytes:
    """A message encoded with some fields changed after the fact (its own checks would refuse
    building it)."""
    doc = json.loads(encode(msg))
    doc.update(changes)
    return json.dumps(doc).encode()


def _reading(rid: int, tick: int) -> SensorReading:
    return SensorReading(
        tick=tick,
        robot_id=rid,
        proximity_ids=[0],
        proximity_m=[1.0],
        proximity_legacy=[1.0],
        compass_deg=0.0,
        gps=(0, 0, 0),
    )


def _forgeries(sim: str, st: WorldState, solo: int) -> list[tuple[str, bytes]]:
    """What is published: ``(key, payload)``, every payload schema-valid."""
    n = len(st.ids)
    z = [0.0] * n
    prop = Proposed(
        tick=FAR,
        revision=st.revision,
        ids=st.ids,
        x=st.x,
        y=st.y,
        heading=st.heading,
        next_x=st.x,
        next_y=st.y,
        next_heading=st.heading,
        linear=z,
        active=[True] * n,
        rolled_left=z,
        rolled_right=z,
    )
    far_state = WorldState(**{**{f: getattr(st, f) for f in st.__struct_fields__}, "tick": FAR})
    acts = [Actions(tick=st.tick, robot_id=r, left=0.1) for r in st.ids]
    return [
        (keys.proposed(sim), _forged(prop, tick=st.tick + 1, x=st.x[:-1])),  # arrays of different lengths
        (keys.proposed(sim), encode(prop)),  # a tick far ahead
        # another revision, no distances rolled: the radio's early path raised on it and died
        (keys.proposed(sim), _forged(prop, tick=st.tick + 1, revision=st.revision + 5, rolled_left=[], rolled_right=[])),
        (keys.verdict(sim), _forged(Verdict(tick=st.tick + 1, revision=st.revision, ids=st.ids, collided=[False] * n), collided=[])),
        (keys.state(sim), _forged(st, speed=[*st.speed, 1.0])),
        (keys.state(sim), encode(far_state)),
        (keys.tick(sim), encode(Tick(tick=FAR, period_ns=100_000_000))),
        (keys.actions(sim, solo), encode(Actions(tick=FAR, robot_id=solo, left=0.15, right=-0.15))),
        (keys.actions(sim, 999), encode(Actions(tick=st.tick, robot_id=999, left=0.1))),
        (keys.agent_actions(sim, "forger"), _forged(ActionBatch(tick=st.tick, agent="forger"), actions=[json.loads(encode(acts[0]))] * 2)),
        (keys.pose_report(sim, solo), _forged(PoseReport(tick=st.tick, robot_id=solo, x=1.0, y=1.0, dir_deg=0.0), x=1e300)),
        (keys.say(sim, solo), encode(Say(tick=st.tick, robot_id=999, text="not mine"))),
        (keys.sensors(sim, solo), _forged(_reading(solo, st.tick + 1), proximity_legacy=[])),
        (keys.sensors(sim, solo), encode(_reading(solo, FAR))),
        (keys.sensor_batch(sim, (1, 1)), _forged(SensorBatch(tick=st.tick + 1, shard="1-1", readings=[_reading(r, st.tick + 1) for r in st.ids]), ids=st.ids[::-1])),
        (keys.radio(sim), _forged(RadioBatch(tick=st.tick + 1, hear=[Hear(robot_id=st.ids[0])]), hear=[{"robot_id": st.ids[0]}] * 2)),
        (keys.radio(sim), encode(RadioBatch(tick=FAR, hear=[Hear(robot_id=r) for r in st.ids]))),
        (keys.hear(sim, solo), encode(Hear(tick=FAR, robot_id=solo))),
        (keys.control(sim), _forged(Control(command="move_obstacle"), obstacle=None)),
    ]  # fmt: skip


def test_forged_inconsistent_messages_on_every_key_stop_no_role_and_each_is_refused_naming_its_key(net: Net) -> None:
    bus, events, states = watch(net)
    start_world(net, "collision", "sensors", "radio")
    recorder = net.spawn("record", "-o", str(net.tmp / "run.mcap"), "--quiet")
    net.spawn("agent", "waypoint", "--waypoints", "35,3", "--start", "3,3,0", "--name", "solo", "--batch", "off")
    net.spawn("agent", "waypoint", "--waypoints", "35,7", "--start", "3,7,0", "--name", "batcher", "--batch", "on")
    before = wait_msg(states, WorldState, lambda m: len(m.ids) == 2 and min(m.speed) > 0.05 and not m.held, 60)
    solo = min(before.ids, key=lambda r: before.y[before.ids.index(r)])  # the chair at y = 3
    # the radio (the say key's only subscriber) and the recorder (whose file must hold the forged
    # state) were started beside the chairs, not waited for: each declares its token after its
    # subscriptions, so once both are alive they hear every forgery
    wait_alive(bus, keys.alive(net.sim, "radio", "radio"))
    wait_alive(bus, keys.alive(net.sim, "recorder", "recorder"))

    forgeries = _forgeries(net.sim, before, solo)
    for key, data in forgeries:
        bus.publish(key, data)
    two_corners = {"name": "x", "x": 20.0, "y": 5.0, "bumpers": [{"id": 0, "corners": [[0, 0], [1, 1]]}]}
    request = RegisterRequest(spec=RobotSpecMsg(name="x"), agent="forger")
    [answer] = bus.query(keys.register(net.sim), _forged(request, spec=two_corners), timeout_s=10)
    refused = decode(answer, RegisterReply)
    assert not refused.ok
    assert "corners" in refused.reason

    # every key someone subscribes to is named by a refusal (tick and hear have no subscriber here)
    expected = {k for k, _ in forgeries} - {keys.tick(net.sim), keys.hear(net.sim, solo)}
    # and the reasons of the keys forged twice (the second refusal of a key may come after every
    # other key's first: waiting for the keys alone stopped before it)
    reasons = [
        (keys.sensors(net.sim, solo), "ahead of the world's tick"),
        (keys.actions(net.sim, solo), "ahead of the world's tick"),
        (keys.actions(net.sim, 999), "not in the world"),
    ]
    seen: dict[str, list[str]] = {}

    def missing() -> list[str]:
        keys_left = sorted(expected - set(seen))
        return keys_left + [f"{k}: {why}" for k, why in reasons if not any(why in r for r in seen.get(k, []))]

    while missing():
        d = events.get(timeout_s=30)
        assert d is not None, f"no refusal named {missing()}"
        ev = decode(d[1], Event)
        assert ev.kind not in ("agent-lost", "removed"), ev.reason
        if ev.kind in ("bad-message", "bad-control") and ev.key:
            assert ev.reason
            seen.setdefault(ev.key, []).append(ev.reason)

    # both chairs drive on (the forged state of tick 10^15 is no world's)
    after = wait_msg(
        states, WorldState, lambda m: before.tick + 20 < m.tick < FAR and len(m.ids) == 2 and not m.held, 60
    )
    assert after.ids == before.ids
    assert all(a > b + 0.2 for a, b in zip(after.x, before.x, strict=True)), (before.x, after.x)
    died = [p.name for p in net.procs if p.popen.poll() is not None]
    assert not died, died

    # the recorder kept every message as it came, the forged ones too, in a whole file
    for p in net.procs:
        if p not in (recorder, net.procs[0]):  # the router stays for the recorder's last messages
            p.kill(signal.SIGTERM)
    recorder.kill(signal.SIGTERM)
    assert recorder.popen.returncode == 0, recorder.output()
    with (net.tmp / "run.mcap").open("rb") as f:
        ticks = [json.loads(m.data)["tick"] for _, _, m in make_reader(f).iter_messages(topics=[keys.state(net.sim)])]
    assert FAR in ticks
    assert max(t for t in ticks if t < FAR) >= after.tick
