"""`iwz ros2` in a real run: a plain Zenoh subscriber on ``0/**`` sees odom, scan, tf and clock;
every payload decodes with rosbags' CDR deserializer to the world's state and readings of the
same tick; the graph's tokens answer a liveliness query on ``@ros2_lv/0/**``; a Twist serialized
by rosbags on the chair's cmd_vel key (with rmw_zenoh's attachment, and without) drives the chair,
silence stops it, and a malformed sample is refused while the role goes on."""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable

import pytest
import zenoh

from iw_zenoh import keys
from iw_zenoh.messages import Event, SensorReading, WorldState, decode
from iw_zenoh.ros2 import graph
from iw_zenoh.ros2 import types as t
from tests.integration.harness import OPEN_LAB, Net, start_world, subscribe, wait_alive, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(180)]

SPEC = {
    "x_m": 5.0,
    "y_m": 5.0,
    "dir_deg": 0.0,
    "max_speed_mps": 0.5,
    "height_m": 0.66,
    "acceleration_curve": 0.2,
    "lasers": [{"id": 0, "fov_deg": 180, "beams": 9, "range_m": 12}],
    "noise": {"laser_m": {"std": 0.0}, "proximity_m": {"std": 0.0}, "motion": {"enabled": False}},
}
TWIST_KEY = keys.ros2_topic(0, "/robot1/cmd_vel", t.dds_name(t.TWIST), t.type_hash(t.TWIST))


class Tap:
    """Every sample on ``0/**``, by topic (the key's second-to-last-but-one chunks), kept in order."""

    def __init__(self, session: zenoh.Session) -> None:
        self.samples: dict[str, list[tuple[bytes, bytes | None]]] = {}
        self.lock = threading.Lock()
        self.arrived = threading.Condition(self.lock)
        self._sub = session.declare_subscriber(keys.ros2_everything(0), self._on)

    def _on(self, s: zenoh.Sample) -> None:
        topic = "/" + "/".join(str(s.key_expr).split("/")[1:-2])
        att = s.attachment.to_bytes() if s.attachment is not None else None
        with self.arrived:
            self.samples.setdefault(topic, []).append((s.payload.to_bytes(), att))
            self.arrived.notify_all()

    def wait(self, pred: Callable[[], bool], timeout_s: float = 60.0) -> None:
        with self.arrived:
            assert self.arrived.wait_for(pred, timeout_s), f"timed out; topics {sorted(self.samples)}"


def _twist(v: float, w: float) -> bytes:
    st = t.store()
    v3 = st.types["geometry_msgs/msg/Vector3"]
    return bytes(st.serialize_cdr(st.types[t.TWIST](linear=v3(v, 0.0, 0.0), angular=v3(0.0, 0.0, w)), t.TWIST))


def _state(box: object, rid: int, pred: Callable[[WorldState, int], bool], timeout_s: float = 30.0) -> WorldState:
    def ok(s: WorldState) -> bool:
        return rid in s.ids and pred(s, s.ids.index(rid))

    return wait_msg(box, WorldState, ok, timeout_s=timeout_s)  # type: ignore[arg-type]


def _drive_until(net_pub: zenoh.Publisher, payload: bytes, att: bytes | None, done: Callable[[], bool]) -> None:
    """Sends a command every 0.1 s (a teleop's rate) until ``done``; 60 s at most."""
    deadline = time.monotonic() + 60
    while not done():
        assert time.monotonic() < deadline, "the chair did not move as commanded in 60 s"
        net_pub.put(payload, attachment=att) if att is not None else net_pub.put(payload)
        time.sleep(0.1)  # the command rate itself, not a synchronisation


def test_ros2_chair_publishes_the_tick_and_obeys_cmd_vel(net: Net) -> None:
    bus = net.client()
    session = bus.session
    tap = Tap(session)
    states = subscribe(bus, keys.state(net.sim), maxlen=100_000)
    readings = subscribe(bus, keys.sensors(net.sim, 1), maxlen=100_000)
    events = subscribe(bus, keys.all_events(net.sim))
    start_world(net, "collision", "sensors")
    ros2 = net.spawn("ros2", "--id", "1", "--spec-json", json.dumps(SPEC), name="ros2")
    tap.wait(lambda: all(len(tap.samples.get(k, [])) >= 5 for k in ("/robot1/odom", "/robot1/scan", "/tf", "/clock")))

    # every odom, scan and tf decodes with rosbags to the state and readings of the same tick
    st = t.store()
    by_time = {s.sim_time_ns: s for s in (decode(d[1], WorldState) for d in states.drain())}
    scans_by_time = {r.sim_time_ns: r for r in (decode(d[1], SensorReading) for d in readings.drain())}
    with tap.lock:
        odoms = [st.deserialize_cdr(p, t.ODOMETRY) for p, _ in tap.samples["/robot1/odom"]]
        scans = [st.deserialize_cdr(p, t.LASER_SCAN) for p, _ in tap.samples["/robot1/scan"]]
        tfs = [st.deserialize_cdr(p, t.TF_MESSAGE) for p, _ in tap.samples["/tf"]]
        clocks = [st.deserialize_cdr(p, t.CLOCK) for p, _ in tap.samples["/clock"]]
        atts = [a for _, a in tap.samples["/robot1/odom"]]
    matched = 0
    for o in odoms:
        ns = o.header.stamp.sec * 1_000_000_000 + o.header.stamp.nanosec
        if ns in by_time:
            s = by_time[ns]
            i = s.ids.index(1)
            assert (o.pose.pose.position.x, o.pose.pose.position.y) == (s.x[i], s.y[i])
            q = o.pose.pose.orientation
            assert math.isclose(2 * math.atan2(q.z, q.w), s.heading[i], abs_tol=1e-9)
            assert (o.header.frame_id, o.child_frame_id) == ("robot1/odom", "robot1/base_link")
            matched += 1
    assert matched >= 3
    matched = 0
    for sc in scans:
        ns = sc.header.stamp.sec * 1_000_000_000 + sc.header.stamp.nanosec
        if ns in scans_by_time and isinstance(scans_by_time[ns].lasers, list):
            want = scans_by_time[ns].lasers[0].ranges  # type: ignore[index]
            got = [None if math.isinf(r) else float(r) for r in sc.ranges]
            assert len(got) == 9
            assert all((a is None) == (b is None) for a, b in zip(got, want, strict=True))
            assert all(math.isclose(a, b, rel_tol=1e-6) for a, b in zip(got, want, strict=True) if a is not None)
            assert sc.header.frame_id == "robot1/laser0"
            matched += 1
    assert matched >= 3
    assert any(tr.child_frame_id == "robot1/base_link" for m in tfs for tr in m.transforms)
    # at the tick rate: a clock, a tf and an odom for every state between the first and last clock
    clock_ns = {c.clock.sec * 10**9 + c.clock.nanosec for c in clocks}
    tf_ns = {m.transforms[0].header.stamp.sec * 10**9 + m.transforms[0].header.stamp.nanosec for m in tfs}
    odom_ns = {o.header.stamp.sec * 10**9 + o.header.stamp.nanosec for o in odoms}
    between = {ns for ns in by_time if min(clock_ns) <= ns <= max(clock_ns) and 1 in by_time[ns].ids}
    assert len(between) >= 4
    assert between <= clock_ns
    assert between <= tf_ns
    assert between <= odom_ns
    assert [c.clock.sec * 10**9 + c.clock.nanosec for c in clocks] == sorted(
        c.clock.sec * 10**9 + c.clock.nanosec for c in clocks
    )
    seqs = [graph.Attachment.decode(a).sequence_number for a in atts if a is not None]
    assert len(seqs) == len(atts)
    assert seqs == sorted(seqs)

    # the graph: the node, its publishers and its subscription
    tokens = [str(r.ok.key_expr) for r in session.liveliness().get(keys.ros2_all_tokens(0), timeout=5) if r.ok]
    mine = [tok for tok in tokens if "/%robot1/iwz_chair" in tok]
    assert any(tok.endswith("/NN/%/%robot1/iwz_chair") for tok in mine), tokens
    for kind, topic in (("MP", "%robot1%odom"), ("MP", "%robot1%scan"), ("MS", "%robot1%cmd_vel")):
        assert any(f"/{kind}/%/%robot1/iwz_chair/{topic}/" in tok for tok in mine), (kind, topic, tokens)
    assert any("/MP/" in tok and "/%tf/tf2_msgs::msg::dds_::TFMessage_/" in tok for tok in tokens)
    assert any("/MP/" in tok and "/%clock/rosgraph_msgs::msg::dds_::Clock_/" in tok for tok in tokens)

    # cmd_vel as rmw_zenoh writes it (with its attachment) drives the chair forward...
    pub = session.declare_publisher(TWIST_KEY)
    start = _state(states, 1, lambda s, i: True)
    x0 = start.x[start.ids.index(1)]
    gid = graph.gid_of("@ros2_lv/0/test/0/1/MP/%/%/teleop/%robot1%cmd_vel")
    moved = threading.Event()

    def far(s: WorldState, i: int) -> bool:
        if s.x[i] > x0 + 0.3:
            moved.set()
        return moved.is_set()

    seq = iter(range(1, 10_000))
    states.drain()
    _drive_until(
        pub,
        _twist(0.4, 0.0),
        graph.Attachment(next(seq), time.time_ns(), gid).encode(),
        lambda: bool([d for d in states.drain() if far(decode(d[1], WorldState), 0)]),
    )
    # ...and silence stops it (0.5 s with no command, then the motors' own run-down)
    silent_at = time.monotonic()
    stopped = _state(states, 1, lambda s, i: abs(s.speed[i]) < 1e-3, timeout_s=20)
    assert time.monotonic() - silent_at < 10.0
    assert stopped.x[stopped.ids.index(1)] > x0 + 0.3
    still = _state(states, 1, lambda s, i: s.tick > stopped.tick + 10)
    assert abs(still.x[still.ids.index(1)] - stopped.x[stopped.ids.index(1)]) < 0.01

    # a plain Zenoh put with no attachment turns it
    h0 = stopped.heading[stopped.ids.index(1)]
    turned = threading.Event()

    def turning() -> bool:
        for d in states.drain():
            s = decode(d[1], WorldState)
            if 1 in s.ids and abs(s.heading[s.ids.index(1)] - h0) > 0.2:
                turned.set()
        return turned.is_set()

    _drive_until(pub, _twist(0.0, 0.5), None, turning)

    # a malformed sample is refused with a reason, and the role goes on
    pub.put(b"\x00\x01\x00\x00\x01")
    bad = wait_msg(events, Event, lambda e: e.kind == "bad-message" and "cmd_vel" in e.key, timeout_s=20)
    assert "does not decode" in bad.reason
    n = len(tap.samples["/robot1/odom"])
    tap.wait(lambda: len(tap.samples["/robot1/odom"]) > n + 3)
    assert ros2.popen.poll() is None
    wait_alive(bus, keys.all_alive(net.sim))


def test_in_lock_step_one_command_drives_for_half_a_simulated_second_then_the_chair_stops(net: Net) -> None:
    """Lock-step: the world waits for iwz ros2 each tick; a single cmd_vel is taken at the next
    tick and is stale 0.5 s of simulated time later (whatever the wall clock did meanwhile)."""
    bus = net.client()
    tap = Tap(bus.session)
    states = subscribe(bus, keys.state(net.sim), maxlen=100_000)
    (net.tmp / "lab.xml").write_text(OPEN_LAB)
    net.spawn("world", str(net.tmp / "lab.xml"), "--lockstep", name="world")
    net.spawn("collision", name="collision")
    net.spawn("sensors", name="sensors")
    net.spawn("ros2", "--id", "1", "--spec-json", json.dumps(SPEC), name="ros2")
    tap.wait(lambda: len(tap.samples.get("/robot1/odom", [])) >= 3)
    bus.session.declare_publisher(TWIST_KEY).put(_twist(0.4, 0.0))
    moving = _state(states, 1, lambda s, i: s.speed[i] > 0.05)
    stopped = _state(states, 1, lambda s, i: s.tick > moving.tick and abs(s.speed[i]) < 1e-3)
    driven_s = (stopped.sim_time_ns - moving.sim_time_ns) / 1e9
    assert driven_s < 0.5 + 1.5  # the command's 0.5 s, then the motors' run-down (curve 0.2)
    later = _state(states, 1, lambda s, i: s.tick > stopped.tick + 20)
    assert abs(later.x[later.ids.index(1)] - stopped.x[stopped.ids.index(1)]) < 0.01
