from __future__ import annotations

import math

import pytest

from iw_zenoh.core.spec import (
    LASER_MAX_BEAMS,
    MAX_BODY_M,
    MAX_BUMPER_CORNERS,
    MAX_BUMPERS,
    MAX_IR,
    MAX_LASERS,
    BumperSpec,
    IrSensorSpec,
    LaserSpec,
    RobotSpec,
    RobotType,
    default_ir_sensors,
)
from iw_zenoh.errors import SpecError


def test_defaults_follow_table_4_3() -> None:
    s = RobotSpec("chair")
    assert (s.width_m, s.height_m, s.com) == (1.0, 1.0, 0.5)
    assert (s.max_speed_mps, s.acceleration_curve) == (0.5, 0.5)
    assert s.type == RobotType.SIMULATED
    assert s.x_m is None
    assert s.dir_deg is None


def test_default_sensors_follow_table_4_5() -> None:
    w, h, com = 1.04, 0.66, 0.81
    got = RobotSpec("c", width_m=w, height_m=h, com=com).sensors
    assert [(s.id, s.x_m, s.y_m, s.angle_deg, s.cone_deg) for s in got] == [
        (0, w * com, 0.0, 0.0, 60.0),
        (1, 0.0, 0.5 * h, 90.0, 60.0),
        (2, 0.0, -0.5 * h, -90.0, 60.0),
        (3, -w * (1 - com), 0.0, 180.0, 60.0),
    ]
    assert got == default_ir_sensors(w, h, com)


def test_registered_sensors_replace_the_defaults() -> None:
    mine = (IrSensorSpec(0, 0.72, 0.24, 0.0, 60.0),)
    assert RobotSpec("c", ir_sensors=mine).sensors == mine


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"name": ""}, "name"),
        ({"name": "x" * 21}, "name"),
        ({"width_m": 0.0}, "width_m"),
        ({"height_m": -1.0}, "height_m"),
        ({"com": 0.0}, "com"),
        ({"com": 1.0}, "com"),
        ({"x_m": 0.0}, "x_m"),
        ({"y_m": float("nan")}, "y_m"),
        ({"dir_deg": 180.5}, "dir_deg"),
        ({"max_speed_mps": 0.0}, "max_speed_mps"),
        ({"acceleration_curve": 0.0}, "acceleration_curve"),
        ({"acceleration_curve": 1.01}, "acceleration_curve"),
        ({"id": -1}, "id"),
        ({"type": "Flying"}, "type"),
        ({"width_m": "wide"}, "width_m"),
    ],
)
def test_out_of_range_fields_are_refused_with_the_field(kwargs: dict[str, object], field: str) -> None:
    args: dict[str, object] = {"name": "chair", **kwargs}
    with pytest.raises(SpecError) as e:
        RobotSpec(**args)  # type: ignore[arg-type]
    assert e.value.field == field
    assert e.value.reason


def test_acceleration_curve_of_one_is_allowed() -> None:
    assert RobotSpec("c", acceleration_curve=1.0).acceleration_curve == 1.0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"angle_deg": 181.0}, "ir[0].angle"),
        ({"cone_deg": 0.0}, "ir[0].cone"),
        ({"cone_deg": 180.0}, "ir[0].cone"),
        ({"range_m": 0.0}, "ir[0].range"),
    ],
)
def test_sensor_fields_are_refused(kwargs: dict[str, float], field: str) -> None:
    with pytest.raises(SpecError) as e:
        IrSensorSpec(0, **kwargs)
    assert e.value.field == field


def test_legacy_robots_have_at_most_eight_sensors_numbered_0_to_7() -> None:
    eight = tuple(IrSensorSpec(i) for i in range(8))
    assert len(RobotSpec("c", ir_sensors=eight, legacy=True).sensors) == 8
    with pytest.raises(SpecError, match="at most 8"):
        RobotSpec("c", ir_sensors=(*eight, IrSensorSpec(8)), legacy=True)
    with pytest.raises(SpecError, match="0..7"):
        RobotSpec("c", ir_sensors=(IrSensorSpec(9),), legacy=True)


def test_native_robots_take_any_number_of_sensors() -> None:
    many = tuple(IrSensorSpec(i) for i in range(32))
    assert len(RobotSpec("c", ir_sensors=many).sensors) == 32


def test_duplicate_sensor_ids_are_refused() -> None:
    with pytest.raises(SpecError, match="unique"):
        RobotSpec("c", ir_sensors=(IrSensorSpec(1), IrSensorSpec(1)))


def test_a_circle_needs_equal_width_and_height() -> None:
    with pytest.raises(SpecError, match="diameter"):
        RobotSpec("c", shape="circle", width_m=1.0, height_m=0.5)  # type: ignore[arg-type]


def test_the_prototype_chair_is_the_one_measured_at_liacc() -> None:
    from iw_zenoh.core.spec import prototype_chair

    c = prototype_chair("p")
    assert (c.width_m, c.height_m, c.com, c.max_speed_mps, c.acceleration_curve) == (1.04, 0.66, 0.81, 0.5, 0.2)
    assert [(s.x_m, s.y_m, s.angle_deg, s.cone_deg) for s in c.sensors][:2] == [
        (0.72, 0.24, 0.0, 60.0),
        (0.72, -0.24, 0.0, 60.0),
    ]
    assert len(c.sensors) == 8


EACH = "per robot"
WHY = "(every tick computes each one)"


def _bumper(i: int, corners: int = 4) -> BumperSpec:
    return BumperSpec(i, tuple((math.cos(k), math.sin(k)) for k in range(corners)))


@pytest.mark.parametrize(
    ("kwargs", "field", "reason"),
    [
        (
            {"ir_sensors": tuple(IrSensorSpec(i) for i in range(MAX_IR + 1))},
            "ir_sensors",
            f"at most 64 {EACH}, got 65 {WHY}",
        ),
        ({"lasers": tuple(LaserSpec(i) for i in range(MAX_LASERS + 1))}, "lasers", f"at most 8 {EACH}, got 9 {WHY}"),
        ({"bumpers": tuple(_bumper(i) for i in range(MAX_BUMPERS + 1))}, "bumpers", f"at most 16 {EACH}, got 17 {WHY}"),
        ({"width_m": MAX_BODY_M + 0.5}, "width_m", "must be at most 10 m, got 10.5"),
        ({"height_m": 1e9}, "height_m", "must be at most 10 m, got 1000000000.0"),
    ],
)
def test_a_registration_too_big_for_every_tick_is_refused_with_the_limit(
    kwargs: dict[str, object], field: str, reason: str
) -> None:
    with pytest.raises(SpecError) as e:
        RobotSpec("c", **kwargs)  # type: ignore[arg-type]
    assert str(e.value) == f"{field}: {reason}"


def test_a_bumper_of_too_many_corners_is_refused_with_the_limit() -> None:
    with pytest.raises(SpecError) as e:
        _bumper(3, MAX_BUMPER_CORNERS + 1)
    assert str(e.value) == f"bumper[3].corners: at most {MAX_BUMPER_CORNERS}, got {MAX_BUMPER_CORNERS + 1}"


def test_a_robot_at_every_limit_is_taken() -> None:
    s = RobotSpec(
        "c",
        width_m=MAX_BODY_M,
        height_m=MAX_BODY_M,
        ir_sensors=tuple(IrSensorSpec(i) for i in range(MAX_IR)),
        lasers=tuple(LaserSpec(i, beams=LASER_MAX_BEAMS) for i in range(MAX_LASERS)),
        bumpers=tuple(_bumper(i, MAX_BUMPER_CORNERS) for i in range(MAX_BUMPERS)),
    )
    assert (len(s.sensors), len(s.lasers), len(s.bumpers)) == (MAX_IR, MAX_LASERS, MAX_BUMPERS)
