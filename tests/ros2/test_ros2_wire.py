"""The ROS 2 wire, checked against rmw_zenoh's layout and rosbags (implementations we did not
write): type hashes equal the golden table of reference/ros2.md, keys and tokens equal strings built
by hand from rmw_zenoh's source layout, payloads decode with rosbags to the values put in, the
attachment equals Zenoh's own serializer's bytes, and hostile commands are refused with a reason."""

from __future__ import annotations

import contextlib
import math
import struct

import pytest
import zenoh
import zenoh.ext
from hypothesis import example, given
from hypothesis import strategies as st

from iw_zenoh import keys
from iw_zenoh.core.motor import MAX_POWER, integrate_pose, powers_for_twist, wheel_speeds_mps
from iw_zenoh.errors import DecodeError
from iw_zenoh.ros2 import convert, graph
from iw_zenoh.ros2 import types as t

# reference/ros2.md's table (ROS 2 Jazzy; the first four also captured from real systems)
GOLDEN = {
    "geometry_msgs/msg/Twist": "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
    "nav_msgs/msg/Odometry": "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
    "tf2_msgs/msg/TFMessage": "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
    "sensor_msgs/msg/LaserScan": "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828",
    "rosgraph_msgs/msg/Clock": "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564",
    "geometry_msgs/msg/TwistStamped": "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64",
    "sensor_msgs/msg/Range": "RIHS01_b42b62562e93cbfe9d42b82fe5994dfa3d63d7d5c90a317981703f7388adff3a",
}


def test_every_type_we_speak_has_its_golden_hash() -> None:
    assert set(t.TYPES) == set(GOLDEN)
    for name, want in GOLDEN.items():
        assert t.type_hash(name) == want, name


def test_the_cmd_vel_key_equals_the_one_seen_on_real_systems() -> None:
    key = keys.ros2_topic(0, "/cmd_vel", t.dds_name(t.TWIST), t.type_hash(t.TWIST))
    assert key == "0/cmd_vel/geometry_msgs::msg::dds_::Twist_/" + GOLDEN[t.TWIST]
    odom = keys.ros2_topic(7, "/robot1/odom", t.dds_name(t.ODOMETRY), t.type_hash(t.ODOMETRY))
    assert odom == "7/robot1/odom/nav_msgs::msg::dds_::Odometry_/" + GOLDEN[t.ODOMETRY]
    assert zenoh.KeyExpr(keys.ros2_everything(7)).intersects(zenoh.KeyExpr(odom))
    every = keys.ros2_in_every_namespace(7, "odom", t.dds_name(t.ODOMETRY), t.type_hash(t.ODOMETRY))
    assert zenoh.KeyExpr(every).intersects(zenoh.KeyExpr(odom))
    assert not zenoh.KeyExpr(every).intersects(zenoh.KeyExpr(odom.replace("/odom/", "/scan/")))


def test_tokens_follow_rmw_zenohs_layout() -> None:
    """@ros2_lv/<domain>/<zid>/<nid>/<eid>/<kind>/<enclave>/<ns>/<node>[/<topic>/<type>/<hash>/<qos>],
    written out by hand from liveliness_utils.cpp (Entity's key parts, mangle_name, qos_to_keyexpr)."""
    node = keys.ros2_token(0, graph.node_parts("a1b2", 3, "/robot1", "iwz_chair"))
    assert node == "@ros2_lv/0/a1b2/3/3/NN/%/%robot1/iwz_chair"
    pub = keys.ros2_token(
        0,
        graph.entity_parts(
            "a1b2",
            3,
            4,
            "MP",
            "/robot1",
            "iwz_chair",
            "/robot1/odom",
            t.dds_name(t.ODOMETRY),
            t.type_hash(t.ODOMETRY),
            graph.Qos(depth=10),
        ),
    )
    assert pub == (
        "@ros2_lv/0/a1b2/3/4/MP/%/%robot1/iwz_chair/%robot1%odom/nav_msgs::msg::dds_::Odometry_/"
        + GOLDEN[t.ODOMETRY]
        + "/::,10:,:,:,,"
    )
    assert graph.Qos(depth=5, reliability=graph.BEST_EFFORT).key() == "2::,5:,:,:,,"
    assert graph.Qos(depth=1, durability=graph.TRANSIENT_LOCAL).key() == ":1:,1:,:,:,,"
    assert graph.Qos(depth=graph.DEFAULT_DEPTH).key() == "::,:,:,:,,"
    assert keys.ros2_token(0, graph.node_parts("z", 0, "/", "n")) == "@ros2_lv/0/z/0/0/NN/%/%/n"
    with pytest.raises(ValueError, match="publisher"):
        graph.entity_parts("z", 0, 1, "NN", "/", "n", "/t", "x", "y", graph.Qos())


def test_keys_refuse_bad_domains_and_topics() -> None:
    for bad in (-1, 233, True, 1.0):
        with pytest.raises(ValueError, match="ROS_DOMAIN_ID"):
            keys.ros2_everything(bad)  # type: ignore[arg-type]
    for topic in ("", "/", "/a//b", "/a/*", "/a b"):
        with pytest.raises(ValueError, match="valid key chunk"):
            keys.ros2_topic(0, topic, "T", "H")


def test_the_attachment_is_zenohs_own_serialization() -> None:
    gid = graph.gid_of("@ros2_lv/0/z/0/1/MP/%/%/n/%t/T/H/::,10:,:,:,,")
    a = graph.Attachment(42, 1_700_000_000_123_456_789, gid)
    theirs = zenoh.ext.z_serialize((zenoh.ext.Int64(42), zenoh.ext.Int64(1_700_000_000_123_456_789), gid))
    assert a.encode() == theirs.to_bytes()
    assert graph.Attachment.decode(a.encode()) == a
    for bad in (b"", a.encode()[:-1], a.encode() + b"\0", a.encode()[:16] + b"\x0f" + a.encode()[17:]):
        with pytest.raises(DecodeError, match="33 bytes"):
            graph.Attachment.decode(bad)


def test_odometry_tf_clock_decode_with_rosbags_to_the_values_put_in() -> None:
    f = convert.Frames.of("/robot1")
    p = convert.Pose2(1.5, -2.0, 0.75, v=0.3, w=-0.2)
    odom = t.store().deserialize_cdr(convert.odometry(f, 12_300_000_000, p), t.ODOMETRY)
    assert (odom.header.stamp.sec, odom.header.stamp.nanosec) == (12, 300_000_000)
    assert (odom.header.frame_id, odom.child_frame_id) == ("robot1/odom", "robot1/base_link")
    assert (odom.pose.pose.position.x, odom.pose.pose.position.y) == (1.5, -2.0)
    q = odom.pose.pose.orientation
    assert math.isclose(2 * math.atan2(q.z, q.w), 0.75)
    assert (odom.twist.twist.linear.x, odom.twist.twist.angular.z) == (0.3, -0.2)
    tf = t.store().deserialize_cdr(
        convert.tf_message(5, [("robot1/odom", "robot1/base_link", 1.0, 2.0, 0.5)]), t.TF_MESSAGE
    )
    (tr,) = tf.transforms
    assert (tr.header.frame_id, tr.child_frame_id, tr.transform.translation.x) == (
        "robot1/odom",
        "robot1/base_link",
        1.0,
    )
    assert t.store().deserialize_cdr(convert.clock(3_000_000_007), t.CLOCK).clock.nanosec == 7


def test_scan_and_range_decode_with_rosbags() -> None:
    data = convert.laser_scan(
        "robot1/laser0", 0, angle_deg=0.0, fov_deg=180.0, range_m=8.0, ranges=[1.0, None, 2.5], scan_time_s=0.1
    )
    s = t.store().deserialize_cdr(data, t.LASER_SCAN)
    assert math.isclose(s.angle_min, -math.pi / 2, rel_tol=1e-6)
    assert math.isclose(s.angle_increment, math.pi / 2, rel_tol=1e-6)
    assert list(s.ranges[[0, 2]]) == [1.0, 2.5]
    assert math.isinf(s.ranges[1])
    assert s.range_max == 8.0
    r = t.store().deserialize_cdr(
        convert.range_reading("robot1/range2", 0, cone_deg=60, range_m=4, value=None), t.RANGE
    )
    assert math.isinf(r.range)
    assert math.isclose(r.field_of_view, math.radians(60), rel_tol=1e-6)


def test_a_twist_serialized_by_rosbags_reads_back() -> None:
    v3 = t.store().types["geometry_msgs/msg/Vector3"]
    msg = t.store().types[t.TWIST](linear=v3(0.4, 0.0, 0.0), angular=v3(0.0, 0.0, -0.3))
    assert convert.twist_of(bytes(t.store().serialize_cdr(msg, t.TWIST))) == (0.4, -0.3)
    assert convert.twist_of(convert.twist(0.2, 0.1, stamped=True, frame="x"), stamped=True) == (0.2, 0.1)
    big_endian = bytes(t.store().serialize_cdr(msg, t.TWIST, little_endian=False))
    assert convert.twist_of(big_endian) == (0.4, -0.3)


def test_hostile_commands_are_refused_with_a_reason() -> None:
    good = convert.twist(0.1, 0.0)
    cases = {
        "truncated": good[:30],
        "empty": b"",
        "header only": good[:4],
        "not CDR": b"\x01\x02\x00\x00" + good[4:],
        "huge": good + bytes(t.MAX_PAYLOAD),
        "NaN": good[:4] + struct.pack("<d", math.nan) + good[12:],
        "inf": good[:-8] + struct.pack("<d", math.inf),
    }
    for what, data in cases.items():
        with pytest.raises(DecodeError) as e:
            convert.twist_of(data)
        assert str(e.value), what
    stamped = convert.twist(0.1, 0.0, stamped=True, frame="abc")
    huge_length = stamped[:12] + struct.pack("<I", 0x7FFFFFFF) + stamped[16:]
    with pytest.raises(DecodeError, match="string length"):
        convert.twist_of(huge_length, stamped=True)


@given(st.binary(max_size=200), st.booleans())
def test_any_bytes_give_a_command_or_a_decode_error(data: bytes, stamped: bool) -> None:
    try:
        v, w = convert.twist_of(data, stamped=stamped)
    except DecodeError:
        return
    assert math.isfinite(v)
    assert math.isfinite(w)


@given(st.binary(min_size=4, max_size=120))
def test_mutated_commands_never_raise_anything_else(tail: bytes) -> None:
    for stamped in (False, True):
        with contextlib.suppress(DecodeError):
            convert.twist_of(b"\x00\x01\x00\x00" + tail, stamped=stamped)


@given(
    st.floats(-3, 3),
    st.floats(-3, 3),
    st.floats(0.1, 5),
    st.floats(0.2, 2),
)
def test_powers_for_a_twist_drive_the_motor_model_at_that_twist(v: float, w: float, vmax: float, base: float) -> None:
    import numpy as np

    left, right = powers_for_twist(v, w, vmax, base)
    assert abs(left) <= MAX_POWER + 1e-12
    assert abs(right) <= MAX_POWER + 1e-12
    wheels = wheel_speeds_mps(np.array([[left, right]]), np.array([vmax]))
    got_v = 0.5 * (wheels[0, 0] + wheels[0, 1])
    got_w = (wheels[0, 1] - wheels[0, 0]) / base
    scale = max(abs(v - 0.5 * w * base), abs(v + 0.5 * w * base)) / vmax
    k = 1.0 if scale <= 1.0 else 1.0 / scale  # beyond reach: the same curvature, slower
    assert math.isclose(got_v, k * v, abs_tol=1e-9)
    assert math.isclose(got_w, k * w, abs_tol=1e-9)
    moved = integrate_pose(np.zeros((1, 3)), wheels, np.array([base]), 0.1)
    assert math.isclose(moved[0, 0], k * v * 0.1, abs_tol=abs(k * w) * 0.1 * abs(v) * 0.1 + 1e-9)
    assert powers_for_twist(math.nan, 0.0, vmax, base) == (0.0, 0.0)


@given(st.binary(max_size=64))
def test_any_attachment_reads_or_is_refused_with_a_reason(data: bytes) -> None:
    if len(data) == 33 and data[16] == 16:
        assert graph.Attachment.decode(data).encode() == data
    else:
        with pytest.raises(DecodeError, match="33 bytes"):
            graph.Attachment.decode(data)


@given(
    st.floats(allow_nan=False, allow_infinity=False),
    st.floats(allow_nan=False, allow_infinity=False),
    st.floats(0.1, 5),
    st.floats(0.2, 2),
)
@example(1e308, 0.0, 0.1, 0.5)
@example(-1.7976931348623157e308, 1.7976931348623157e308, 1.0, 0.6)
def test_any_finite_twist_gives_finite_powers_within_reach(v: float, w: float, vmax: float, base: float) -> None:
    # a hostile cmd_vel of 1e308 m/s overflowed to inf, and inf/inf made the powers NaN
    left, right = powers_for_twist(v, w, vmax, base)
    assert math.isfinite(left)
    assert math.isfinite(right)
    assert abs(left) <= MAX_POWER + 1e-12
    assert abs(right) <= MAX_POWER + 1e-12
    if v > 1e7 and abs(w) < 1.0:  # straight on at full power, not stopped
        assert math.isclose(left, MAX_POWER)
        assert math.isclose(right, MAX_POWER)
