"""``iwz ctl`` against a real world process on a real Zenoh router."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from iw_zenoh import keys
from iw_zenoh.bus.net import free_port
from iw_zenoh.messages import RobotSpecMsg, SensorReading, Tick, WorldInfo, WorldState, decode
from tests.integration.harness import Net, Proc, register, subscribe, wait_alive, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(180)]

LAB = """<Lab Name="test" Width="20" Height="10">
  <Wall Height="2"><Corner X="9" Y="0"/><Corner X="10" Y="0"/><Corner X="10" Y="3"/><Corner X="9" Y="3"/></Wall>
</Lab>"""
GRID = """<Grid><Position X="2" Y="5" Dir="0"/><Position X="5" Y="8" Dir="0"/></Grid>"""
CTL_TIMEOUT_S = 20  # the world answers in a tick; a loaded machine may take seconds to start a process


def _world(net: Net, *extra: str) -> Proc:
    (net.tmp / "lab.xml").write_text(LAB)
    (net.tmp / "grid.xml").write_text(GRID)
    world = net.spawn("world", str(net.tmp / "lab.xml"), "--grid", str(net.tmp / "grid.xml"), *extra)
    net.spawn("collision")
    return world


def ctl(net: Net, *args: str, timeout_s: float = CTL_TIMEOUT_S) -> tuple[int, dict[str, Any]]:
    """Runs ``iwz ctl ARGS --json`` to its end; its exit status and its JSON outcome."""
    argv = [sys.executable, "-m", "iw_zenoh.cli", "ctl", *args, "--json", "--sim", net.sim, "-e", net.endpoint]
    p = subprocess.run(argv, capture_output=True, text=True, timeout=timeout_s + 60, check=False)
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
    assert lines, f"iwz ctl printed no JSON (status {p.returncode}):\n{p.stdout}\n{p.stderr}"
    return p.returncode, json.loads(lines[-1])


def _info(net: Net) -> WorldInfo:
    got = net.client().query(keys.info(net.sim), timeout_s=5.0)
    assert got, "no world info"
    return decode(got[0], WorldInfo)


def test_pause_stops_the_tick_step_advances_exactly_n_and_resume_goes_on(net: Net) -> None:
    _world(net)
    bus = net.client()
    ticks = subscribe(bus, keys.tick(net.sim))
    wait_msg(ticks, Tick, lambda t: t.tick >= 3 and t.running)
    rc, out = ctl(net, "pause", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 0, out
    assert out["ok"]
    assert out["event"] == "paused"
    paused = out["tick"]
    # paused, the world still sends its clock every period: the tick number stays where it was
    idle = [wait_msg(ticks, Tick, lambda t: not t.running and t.tick >= paused) for _ in range(5)]
    assert {t.tick for t in idle[1:]} == {paused}
    rc, out = ctl(net, "step", "3", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 0, out
    assert (out["from_tick"], out["tick"], out["steps"]) == (paused, paused + 3, 3)
    after = [wait_msg(ticks, Tick, lambda t: t.tick >= paused + 3) for _ in range(5)]
    assert {t.tick for t in after} == {paused + 3}  # exactly 3, then it holds
    rc, out = ctl(net, "resume", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 0, out
    assert out["event"] == "started"
    wait_msg(ticks, Tick, lambda t: t.running and t.tick >= paused + 10)


def test_step_on_a_running_world_pauses_it_first_and_counts_from_there(net: Net) -> None:
    _world(net)
    ticks = subscribe(net.client(), keys.tick(net.sim))
    wait_msg(ticks, Tick, lambda t: t.tick >= 3 and t.running)
    rc, out = ctl(net, "step", "2", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 0, out
    assert out["tick"] == out["from_tick"] + 2
    held = [wait_msg(ticks, Tick, lambda t: t.tick >= out["tick"]) for _ in range(4)]
    assert {(t.tick, t.running) for t in held} == {(out["tick"], False)}


def test_remove_takes_a_robot_out_and_an_unknown_id_is_refused(net: Net) -> None:
    _world(net)
    bus = net.client()
    states = subscribe(bus, keys.state(net.sim), maxlen=1)
    rid = register(bus, net.sim, RobotSpecMsg(name="a")).robot_id
    wait_msg(states, WorldState, lambda m: rid in m.ids)
    rc, out = ctl(net, "remove", "99", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 1
    assert not out["ok"]
    assert out["event"] == "bad-control"
    assert "no robot 99" in out["reason"]
    assert f"robots in the world: {rid}" in out["reason"]
    rc, out = ctl(net, "remove", str(rid), "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 0, out
    assert out["event"] == "removed"
    wait_msg(states, WorldState, lambda m: rid not in m.ids and m.tick > out["tick"])
    assert [r.id for r in _info(net).robots] == []


def _front(r: SensorReading) -> float | None:
    return r.proximity_m[r.proximity_ids.index(0)]


def test_an_obstacle_added_moved_and_removed_shows_in_the_world_and_the_readings(net: Net) -> None:
    _world(net)
    net.spawn("sensors")
    bus = net.client()
    wait_alive(bus, keys.alive(net.sim, "sensors", "sensors-1-1"))
    rid = register(bus, net.sim, RobotSpecMsg(name="a")).robot_id  # at 2,5 facing +x, still
    readings = subscribe(bus, keys.sensors(net.sim, rid))
    wait_msg(readings, SensorReading, lambda r: _front(r) is None)  # open space ahead
    rc, out = ctl(net, "obstacle", "add", "box", "3,4.7,3.3,5.3", "--height", "0.8", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 0, out
    assert out["event"] == "obstacle"
    [box] = _info(net).obstacles
    assert (box.name, box.x0, box.y0, box.x1, box.y1, box.height) == ("box", 3, 4.7, 3.3, 5.3, 0.8)
    seen = wait_msg(readings, SensorReading, lambda r: r.tick > out["tick"] and _front(r) is not None)
    assert _front(seen) == pytest.approx(0.5, abs=0.1)  # the front sensor is 0.5 m ahead of the axis
    rc, out = ctl(net, "obstacle", "move", "box", "15,8", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 0, out
    [box] = _info(net).obstacles
    assert (box.x0, box.y0, box.x1, box.y1, box.height) == pytest.approx((14.85, 7.7, 15.15, 8.3, 0.8))
    wait_msg(readings, SensorReading, lambda r: r.tick > out["tick"] and _front(r) is None)
    rc, out = ctl(net, "obstacle", "remove", "box", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 0, out
    assert _info(net).obstacles == []


def test_a_refused_obstacle_exits_non_zero_with_the_worlds_reason(net: Net) -> None:
    _world(net)
    rc, out = ctl(net, "obstacle", "add", "far", "19,4,23,5", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 1
    assert out["event"] == "bad-control"
    assert "'far'" in out["reason"]
    rc, out = ctl(net, "obstacle", "remove", "ghost", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 1
    assert "no obstacle named 'ghost'" in out["reason"]


def test_no_world_is_a_clear_error_within_the_timeout(net: Net) -> None:
    t0 = time.monotonic()
    rc, out = ctl(net, "pause", "--timeout", "2")
    assert rc == 3
    assert not out["ok"]
    assert f"no world answered on iw/{net.sim}/world/info within 2 s" in out["reason"]
    assert time.monotonic() - t0 < 2 + 15  # the timeout, and a Python start on a busy machine


def test_no_router_is_a_clear_error_within_the_timeout(tmp_path: Path) -> None:
    argv = [
        sys.executable,
        "-m",
        "iw_zenoh.cli",
        "ctl",
        "pause",
        "--timeout",
        "2",
        "-e",
        f"tcp/127.0.0.1:{free_port()}",
    ]
    t0 = time.monotonic()
    p = subprocess.run(argv, capture_output=True, text=True, timeout=60, check=False)
    assert p.returncode == 2
    assert "iwz ctl: cannot join the bus" in p.stdout
    assert time.monotonic() - t0 < 2 + 15


def test_stop_ends_the_worlds_run(net: Net) -> None:
    world = _world(net)
    ticks = subscribe(net.client(), keys.tick(net.sim))
    wait_msg(ticks, Tick, lambda t: t.tick >= 1)
    rc, out = ctl(net, "stop", "--timeout", str(CTL_TIMEOUT_S))
    assert rc == 0, out
    assert out["event"] == "stopped"
    assert world.popen.wait(30) == 0
