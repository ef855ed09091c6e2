"""Legacy starting places: the ciberrato profile accepts starts that put bodies on each other, as
the legacy simulator does (the shipped Ciber2001 grid puts three discs 1.0 apart); the native
profile keeps refusing them."""

from __future__ import annotations

from pathlib import Path

from iw_zenoh.bridges.ciberrato.registration import parse_registration, registration_spec

from iw_zenoh.convert import spec_to_msg
from iw_zenoh.core.modes import Profile
from iw_zenoh.maps import load_grid, load_lab
from iw_zenoh.messages import RegisterReply, RegisterRequest
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.world import WorldCore

MAPS = Path(__file__).resolve().parents[2] / "maps"


def _ciber2001(profile: Profile) -> list[RegisterReply]:
    lab = load_lab(MAPS / "ciberrato" / "Ciber2001Final.xml")
    core = WorldCore(
        WorldConfig(sim="t", profile=profile), lab, load_grid(MAPS / "ciberrato" / "Ciber2001Grid.xml", lab)
    )
    replies = []
    for i in (1, 2, 3):
        spec = registration_spec(parse_registration(f'<Robot Id="{i}" Name="r{i}"/>'.encode()))
        replies.append(core.register(RegisterRequest(spec=spec_to_msg(spec), agent="ciberrato"), 0)[0])
    return replies


def test_the_ciber2001_grid_takes_its_three_robots_in_the_ciberrato_profile() -> None:
    replies = _ciber2001(Profile.CIBERRATO)
    assert [r.ok for r in replies] == [True, True, True], [r.reason for r in replies]
    assert [(r.spec.x_m, r.spec.y_m) for r in replies if r.spec] == [(0.75, 1.0), (1.75, 1.0), (2.75, 1.0)]


def test_the_native_profile_refuses_a_start_on_another_body() -> None:
    replies = _ciber2001(Profile.NATIVE)
    assert replies[0].ok
    assert not replies[1].ok
    assert "puts the body on robot 1" in replies[1].reason


def _one_robot(profile: Profile) -> WorldCore:
    lab = load_lab(MAPS / "ciberrato" / "C1-lab.xml")
    core = WorldCore(WorldConfig(sim="t", profile=profile), lab, load_grid(MAPS / "ciberrato" / "C1-grid.xml", lab))
    spec = registration_spec(parse_registration(b'<Robot Id="1" Name="r1"/>'))
    assert core.register(RegisterRequest(spec=spec_to_msg(spec), agent="ciberrato"), 0)[0].ok
    return core


def test_a_legacy_run_takes_no_first_step_before_collision_and_sensors_are_alive() -> None:
    core = _one_robot(Profile.CIBERRATO)
    assert not core.due()  # it would hold its robot at the start: the legacy simulator never does
    core.on_alive("collision", "collision", True, 0)
    assert not core.due()
    core.on_alive("sensors", "sensors-1-1", True, 0)
    assert core.due()


def test_a_native_real_time_run_steps_and_holds_as_before() -> None:
    assert _one_robot(Profile.NATIVE).due()
