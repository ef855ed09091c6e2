"""The legacy simulator's rules of time in a ciberrato-profile world, with real processes and real
UDP: a silent robot keeps its last command for ever (the watchdog only where a world asks for it),
and an action sent just before Start is applied at tick 1 (docs/runtime.md, "Safety" and "The
tick")."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.messages import WorldState
from tests.integration.harness import MAPS, Net, subscribe, wait_msg
from tests.integration.legacy import LegacyClient, ciberrato_world, measures_of

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(150)]

PARAMS_GPS = ('GPS="Off"', 'GPS="On"')
EAST = b'<Actions LeftMotor="0.1" RightMotor="0.1"/>'
MEASURES_S = 30.0  # how long the test's robot waits for a Measures (croblink's 2 s: a loaded machine may lag more)


def _gps_params(net: Net) -> Path:
    """C1's parameters with the GPS on."""
    path = net.tmp / "gps.xml"
    path.write_text((MAPS / "ciberrato" / "C1-config.xml").read_text().replace(*PARAMS_GPS))
    return path


def _gps_x(data: bytes) -> tuple[int, float]:
    m = measures_of(data)
    return int(m.get("Time")), float(m.find("Sensors/GPS").get("X"))


@pytest.mark.parametrize(("silence", "kept"), [((), True), (("--silence", "stop"), False)])
def test_a_silent_legacy_robot_keeps_its_last_command_unless_the_world_stops_silent_robots(
    net: Net, clients: list[LegacyClient], silence: tuple[str, ...], kept: bool
) -> None:
    port = ciberrato_world(net, _gps_params(net), world=silence)
    robot = LegacyClient(port)
    clients.append(robot)
    assert b'Status="Ok"' in robot.register(b'<Robot Id="1" Name="quiet"/>')
    robot.sock.settimeout(MEASURES_S)
    t0, x0 = _gps_x(robot.recv())
    robot.send(EAST)  # one command, then silence
    seen = {t0: x0}
    while max(seen) < t0 + 40:  # 2 s of Measures, read and never answered
        t, x = _gps_x(robot.recv())
        seen[t] = x
    end = max(seen)
    last_10 = seen[end] - seen[max(t for t in seen if t <= end - 10)]  # a cycle may be skipped
    if kept:  # the legacy simulator: 843.2 to 847.1 in these 2 s, 0.1 a cycle to the end
        assert last_10 == pytest.approx(1.0, abs=0.15)
        assert seen[end] - x0 > 3.0
    else:  # the watchdog zeroed it 500 ms after its command: it rolled to a stop
        assert last_10 == 0.0
        assert seen[end] - x0 < 1.5


def test_an_action_sent_just_before_start_is_applied_at_tick_1(net: Net, clients: list[LegacyClient]) -> None:
    port = ciberrato_world(net, world=("--paused",))
    states = subscribe(net.client(), keys.state(net.sim))
    robot, viewer = LegacyClient(port), LegacyClient(port)
    clients += [robot, viewer]
    assert b'Status="Ok"' in robot.register(b'<Robot Id="1" Name="first"/>')
    robot.sock.settimeout(MEASURES_S)
    assert b'Status="Ok"' in viewer.register(b"<View/>\n\x00")
    assert measures_of(robot.recv()).get("Time") == "0"
    bridge = next(p for p in net.procs if p.name.startswith("bridge"))
    os.kill(bridge.popen.pid, signal.SIGSTOP)  # both datagrams wait for the bridge's same pass
    try:
        robot.send(EAST)
        viewer.send(b"<Start/>\n\x00")
    finally:
        os.kill(bridge.popen.pid, signal.SIGCONT)
    first = wait_msg(states, WorldState, lambda s: 1 in s.ids)
    assert first.tick == 1
    assert first.x[first.ids.index(1)] == pytest.approx(3.0 + 0.05)  # half the power: the motors' inertia
