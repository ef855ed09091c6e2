"""Legacy control scores with real processes and real UDP, whenever the robot registers: the
shipped ciberrato-c1 scenario (its world runs before any robot comes), and a paused world started
by a viewer. Driving east from the C1 grid position crosses three cells of the control loop (30)
and ends in the wall at x = 9.9 (CollisionWallPenalty 5: 25), as in the legacy simulator. Every
mode, registering before and after the world starts: tests/bridges/ciberrato/test_bridge_scores.py."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest
from lxml import etree

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import NetConfig
from iw_zenoh.messages import WorldState
from tests.integration.harness import MAPS, Net, iwz_run_argv, stop_run, subscribe, wait_msg
from tests.integration.legacy import LegacyClient, ciberrato_world, measures_of, udp_port

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

EAST = b'<Actions LeftMotor="0.1" RightMotor="0.1"/>'


def _viewer(port: int, clients: list[LegacyClient]) -> LegacyClient:
    """A registered viewer that asked for the lab (as the Qt viewer does, so it is kept)."""
    viewer = LegacyClient(port)
    clients.append(viewer)
    assert b'Status="Ok"' in viewer.register(b"<View/>\n\x00")
    viewer.send(b"<LabReq/>\n\x00")
    return viewer


def _drive_east_into_the_wall(robot: LegacyClient) -> int:
    """Drives east (an Actions for every Measures) until 5 cycles after the first collision;
    the Time of that collision."""
    hit: int | None = None
    for _ in range(1000):
        m = measures_of(robot.recv())
        robot.send(EAST)
        t = int(m.get("Time"))
        if hit is None and m.find("Sensors").get("Collision") == "Yes":
            hit = t
        if hit is not None and t >= hit + 5:
            return hit
    raise AssertionError("the robot never reached the wall")


def _scores(viewer: LegacyClient, robot_id: int, hit: int) -> tuple[int, int]:
    """The robot's score as the viewer was told it: before the collision, and 5 cycles after."""
    viewer.sock.settimeout(1.0)
    told: dict[int, int] = {}
    deadline = time.monotonic() + 30  # a bridge a loaded machine stalls a second tells it later
    while time.monotonic() < deadline:
        try:
            data = viewer.recv(65536)
        except TimeoutError:
            continue
        el = etree.fromstring(data.rstrip(b"\x00"))
        if el.tag == "Robot" and el.get("Id") == str(robot_id):
            told[int(el.get("Time"))] = int(el.get("Score"))
            if int(el.get("Time")) >= hit + 5:
                break
    assert any(t >= hit + 5 for t in told), f"the viewer was told Times {sorted(told)}, none 5 after {hit}"
    # a viewer is told the newest state of each pass of the bridge: a busy pass may skip a cycle
    return told[max(t for t in told if t < hit)], told[min(t for t in told if t >= hit + 5)]


def test_the_shipped_c1_scenario_scores_a_robot_registered_while_its_world_runs(
    tmp_path: Path, clients: list[LegacyClient]
) -> None:
    port = udp_port()
    text = (MAPS / "scenarios" / "ciberrato-c1.toml").read_text().replace("port = 6000", f"port = {port}")
    sc = tmp_path / "c1.toml"
    sc.write_text(text.replace('"../ciberrato/', f'"{MAPS}/ciberrato/'))
    argv = iwz_run_argv(sc, tmp_path, "c1score")
    endpoint = f"tcp/127.0.0.1:{argv[argv.index('--port') + 1]}"
    run = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    bus: ZenohBus | None = None
    try:
        bus = ZenohBus(NetConfig(connect=(endpoint,)))
        states = subscribe(bus, keys.state("c1score"))
        wait_msg(states, WorldState, lambda s: s.tick >= 20, timeout_s=60)  # it runs, with no robot
        viewer = _viewer(port, clients)
        robot = LegacyClient(port)
        clients.append(robot)
        assert b'Status="Ok"' in robot.register(b'<Robot Id="1" Name="east"/>', tries=60)
        hit = _drive_east_into_the_wall(robot)
        assert _scores(viewer, 1, hit) == (30, 25)
    finally:
        if bus is not None:
            bus.close()
        stop_run(run)


def test_a_robot_registered_into_a_paused_world_then_started_scores_the_same(
    net: Net, clients: list[LegacyClient]
) -> None:
    port = ciberrato_world(net, bridge=("--scoring", "1"), world=("--paused",))
    viewer = _viewer(port, clients)
    robot = LegacyClient(port)
    clients.append(robot)
    assert b'Status="Ok"' in robot.register(b'<Robot Id="1" Name="east"/>')
    assert measures_of(robot.recv()).get("Time") == "0"
    robot.send(EAST)
    viewer.send(b"<Start/>\n\x00")
    hit = _drive_east_into_the_wall(robot)
    assert _scores(viewer, 1, hit) == (30, 25)
