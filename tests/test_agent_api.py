"""The one-import agent API (issue #31): an agent's author imports everything from
``iw_zenoh.agent``; ``Command.from_velocity`` goes through the chair's own model; readings have
named fields in the core's units; the optional hooks are typed protocols; MAX_POWER has one home."""

from __future__ import annotations

import argparse
import ast
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh import keys
from iw_zenoh.core.motor import integrate_pose, wheel_speeds_mps
from iw_zenoh.messages import Actions, ChairReading, SensorReading, decode, encode
from tests.support.builders import agent_host

ROOT = Path(__file__).resolve().parents[1]


def _reading(
    tick: int = 51, gps: tuple[float, float, float] = (1.0, 2.0, 90.0), compass: float = -90.0
) -> SensorReading:
    return SensorReading(
        tick=tick,
        sim_time_ns=tick * 100_000_000,
        robot_id=1,
        proximity_ids=[],
        proximity_m=[],
        proximity_legacy=[],
        compass_deg=compass,
        gps=gps,
    )


def test_everything_an_agent_needs_comes_from_one_module() -> None:
    import iw_zenoh.agent as api
    from iw_zenoh.agent.hosting import Command
    from iw_zenoh.core import motor, spec
    from iw_zenoh.messages import Heard

    for name in ("Agent", "Command", "Spec", "Readings", "Heard", "Pose", "SensorNoise", "point_arg", "MAX_POWER"):
        assert name in api.__all__, name
    assert api.Spec is spec.RobotSpec
    assert api.Readings is SensorReading
    assert api.Command is Command
    assert api.Heard is Heard
    assert api.MAX_POWER is motor.MAX_POWER
    assert {"OnRegistered", "OnChair", "AttachTo"} <= set(api.__all__)


def test_max_power_is_defined_once() -> None:
    homes = []
    for path in sorted(p for d in ("iw_zenoh", "agents", "bridges") for p in (ROOT / d).rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if "MAX_POWER" not in text:  # no name to assign: no need to parse it
            continue
        for node in ast.walk(ast.parse(text)):
            targets = (
                node.targets
                if isinstance(node, ast.Assign)
                else [node.target]
                if isinstance(node, ast.AnnAssign)
                else []
            )
            if any(isinstance(t, ast.Name) and t.id == "MAX_POWER" for t in targets):
                homes.append(str(path.relative_to(ROOT)))
    assert homes == ["iw_zenoh/core/motor.py"]


def test_a_reading_gives_its_pose_in_metres_and_radians() -> None:
    from iw_zenoh.agent import Pose

    r = _reading(gps=(1.5, 3.0, 90.0), compass=-45.0)
    x, y, heading = r.pose
    assert r.pose == Pose(x_m=1.5, y_m=3.0, heading_rad=math.pi / 2)
    assert (x, y, heading) == (1.5, 3.0, math.pi / 2)
    assert r.compass_rad == pytest.approx(-math.pi / 4)
    assert decode(encode(r), SensorReading) == r  # the wire is as before: the pose is no field of it
    assert b'"pose"' not in encode(r)


def test_a_velocity_command_drives_at_that_velocity_through_the_chairs_model() -> None:
    from iw_zenoh.agent import MAX_POWER, Command, Spec

    chair = Spec("c", width_m=1.04, height_m=0.66, max_speed_mps=0.5)
    left, right = _powers(Command.from_velocity(0.25, 0.0), chair)
    assert left == right == pytest.approx(0.25 / 0.5 * MAX_POWER)
    fast = Spec("f", width_m=1.04, height_m=0.66, max_speed_mps=1.0)  # the same velocity, half the power
    assert _powers(Command.from_velocity(0.25, 0.0), fast) == pytest.approx((left / 2, right / 2))
    spin_l, spin_r = _powers(Command.from_velocity(0.0, 1.0), chair)
    assert spin_l == pytest.approx(-spin_r)
    assert spin_r > 0
    assert _powers(Command.from_velocity(5.0, 0.0), chair) == pytest.approx((MAX_POWER, MAX_POWER))
    assert _powers(Command.from_velocity(float("nan"), 0.0), chair) == (0.0, 0.0)  # nonsense: the chair stops
    assert Command.stop() == Command(0.0, 0.0)
    said = Command.from_velocity(0.1, 0.0, say="hi").resolved(chair)
    assert said.say == "hi"
    assert said.velocity is None
    assert Command(0.1, -0.1).resolved(chair) == Command(0.1, -0.1)  # powers stay powers


def _powers(cmd: object, spec: object) -> tuple[float, float]:
    r = cmd.resolved(spec)  # type: ignore[attr-defined]
    return r.left, r.right


@given(
    v=st.floats(-0.5, 0.5),
    w=st.floats(-1.0, 1.0),
    max_speed=st.floats(0.2, 3.0),
    base=st.floats(0.3, 1.5),
)
def test_steady_wheels_of_a_velocity_command_within_reach_give_that_velocity(
    v: float, w: float, max_speed: float, base: float
) -> None:
    from iw_zenoh.agent import MAX_POWER, Command, Spec

    chair = Spec("c", width_m=1.0, height_m=base, max_speed_mps=max_speed)
    left, right = _powers(Command.from_velocity(v, w), chair)
    assert abs(left) <= MAX_POWER + 1e-12
    assert abs(right) <= MAX_POWER + 1e-12
    speeds = wheel_speeds_mps(np.array([[left, right]]), np.array([max_speed]))
    if abs(v) + abs(w) * base / 2 <= max_speed:  # within the motors' reach: exactly that velocity
        got_v = 0.5 * (speeds[0, 0] + speeds[0, 1])
        got_w = (speeds[0, 1] - speeds[0, 0]) / base
        assert got_v == pytest.approx(v, abs=1e-9)
        assert got_w == pytest.approx(w, abs=1e-9)
    else:  # beyond it: scaled down whole, the same curve
        assert max(abs(left), abs(right)) == pytest.approx(MAX_POWER)
    pose = integrate_pose(np.zeros((1, 3)), speeds, np.array([base]), 0.1)
    assert np.all(np.isfinite(pose))


class _Velocity:
    """An agent of the new API: a velocity command, and every optional hook."""

    def __init__(self) -> None:
        self.registered: list[int] = []
        self.chair: list[ChairReading] = []

    def spec(self):  # type: ignore[no-untyped-def]
        from iw_zenoh.agent import Spec

        return Spec("v", max_speed_mps=0.5)

    def on_registered(self, robot_id: int, spec: object) -> None:
        self.registered.append(robot_id)

    def on_chair(self, reading: ChairReading) -> None:
        self.chair.append(reading)

    def on_sensors(self, reading, heard):  # type: ignore[no-untyped-def]
        from iw_zenoh.agent import Command

        return Command.from_velocity(0.25, 0.0)


def test_the_host_turns_a_velocity_into_the_registered_chairs_powers_and_calls_the_typed_hooks() -> None:
    from iw_zenoh.agent import MAX_POWER, OnChair, OnRegistered

    agent = _Velocity()
    assert isinstance(agent, OnRegistered)
    assert isinstance(agent, OnChair)
    host, bus = agent_host(agent)
    assert agent.registered == [1]  # the hook, found by its protocol
    host.readings.put((keys.sensors("t", 1), encode(_reading()), 0))
    assert host.step(timeout_s=0.0)
    acts = [decode(d, Actions) for k, d in bus.published if k == keys.actions("t", 1)]
    assert [(a.left, a.right) for a in acts] == [pytest.approx((0.25 / 0.5 * MAX_POWER, 0.25 / 0.5 * MAX_POWER))]


def test_an_agent_without_hooks_is_none_of_the_hook_protocols() -> None:
    from iw_zenoh.agent import AttachTo, OnChair, OnRegistered
    from iw_zenoh.agent.hooks import attached_to

    class Plain:
        def spec(self) -> None: ...
        def on_sensors(self, reading: object, heard: object) -> None: ...

    class Attached(Plain):
        attach_to = 7

    assert not isinstance(Plain(), OnRegistered | OnChair | AttachTo)
    assert attached_to(Plain()) == 0
    assert attached_to(Attached()) == 7


SEEDED = """
[world]
map = "{map}"
seed = {seed}
[[agents]]
program = "waypoint"
args = ["--waypoints", "5,5"]
[[agents]]
program = "waypoint"
args = ["--waypoints", "6,5"]
[[agents]]
program = "wanderer"
seed = 42
[[agents]]
program = "wanderer"
args = ["--seed", "9"]
"""


def _seeds(tmp_path: Path, world_seed: int) -> list[int]:
    from iw_zenoh.launch.launcher import Launcher
    from iw_zenoh.scenario.file import parse_scenario

    sc = parse_scenario(SEEDED.format(map=ROOT / "maps" / "open-room.xml", seed=world_seed), tmp_path)
    launcher = Launcher(sc, port=7447, log_dir=tmp_path, status=False)
    launcher.plan()
    out = []
    for c in (c for c in launcher.children if c.role == "agent"):
        parser = argparse.ArgumentParser()
        parser.add_argument("--seed", type=int, action="append")  # every --seed, the last one wins in the agent
        seen, _ = parser.parse_known_args(c.argv)
        out.append(seen.seed[-1])
    return out


def test_iwz_run_hands_every_agent_a_seed_of_its_own_from_the_worlds(tmp_path: Path) -> None:
    first = _seeds(tmp_path, 1)
    assert first == _seeds(tmp_path, 1)  # the same every run
    assert first[0] != first[1]  # two entries, two seeds
    assert first[2:] == [42, 9]  # the entry's own seed; a program's own --seed in its args wins
    assert _seeds(tmp_path, 2)[:2] != first[:2]  # the world's seed changes them


def test_every_agent_program_takes_a_seed_and_one_with_its_own_keeps_it() -> None:
    import argparse

    from iw_zenoh.agent.programs import add_seed_argument, find_program

    for name, own in (("waypoint", False), ("wanderer", True)):
        p = argparse.ArgumentParser()
        find_program(name).add_arguments(p)
        add_seed_argument(p)
        add_seed_argument(p)  # twice is harmless
        assert p.parse_args(["--seed", "7"] + (["--waypoints", "1,1"] if name == "waypoint" else [])).seed == 7
        assert (p.get_default("seed") == 0) or own
