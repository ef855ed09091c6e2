"""A secured serial chair's run (``iwz run --secure``, the chair emulator on a pty): the serial
bridge is an identity of its own (``bridge-serial``, role serial), the chair's agent drives robot
1 to its goal through it, and a rogue with a valid agent certificate of the same authority,
commanding robot 1 all the while, never reaches the chair's wheels."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import NetConfig
from iw_zenoh.messages import Actions, WorldState, encode
from iw_zenoh.secure.cli import main as secure_main
from iw_zenoh.secure.policy import load_policy
from tests.integration.harness import MAPS, iwz_run_argv, stop_run, subscribe, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(330)]

SIM = "ssec"
ROGUE = -0.137  # the rogue's command: reverse, a power the chair's agent never asks for both wheels
SCENARIO = """
name = "secured-serial"
[world]
map = "{maps}/liacc.xml"
grid = "{maps}/liacc-grid.xml"
mode = "realtime"
seed = 1
duration_s = 240
[chair]
hardware = "serial"
robot = 1
start = {{ x_m = 10.0, y_m = 6.1, dir_deg = 0.0 }}
seed = 5
[[agents]]
program = "wheelchair"
args = ["--id", "1", "--map", "{maps}/liacc.xml", "--start", "10,6.1,0", "--goal", "12,6.1",
        "--chair", "augmented", "--hardware", "serial"]
[criteria]
max_collisions = 0
stop_when_reached = true
[[criteria.reach]]
robot = 1
x_m = 12.0
y_m = 6.1
within_m = 0.5
"""


def _ids(tmp: Path) -> Path:
    """The run's authority made beforehand, with a rogue agent (robot 2) and a watcher (a viewer)."""
    ids = tmp / "ids"
    assert secure_main(["init", str(ids), "--sim", SIM]) == 0
    assert secure_main(["issue", "rogue", "--role", "agent", "--robots", "2", "--dir", str(ids)]) == 0
    assert secure_main(["issue", "watcher", "--role", "viewer", "--dir", str(ids)]) == 0
    return ids


def _wait_router(log: Path, run: subprocess.Popen[str]) -> None:
    deadline = time.monotonic() + 60
    while "listening on" not in (log.read_text() if log.exists() else ""):
        assert run.poll() is None, run.communicate()[0]
        assert time.monotonic() < deadline, "the run's router did not listen in 60 s"
        time.sleep(0.1)  # polling a log file: there is no event to wait on


def _wheels(path: Path) -> set[tuple[int, int]]:
    """Every (left, right) the emulated chair's wheels were set to."""
    return {(int(b), int(c)) for _, b, c in (ln.split() for ln in path.read_text().splitlines())}


def test_a_secured_serial_chair_is_driven_by_its_agent_and_never_by_a_rogue(tmp_path: Path) -> None:
    ids, logs = _ids(tmp_path), tmp_path / "logs"
    sc = tmp_path / "serial.toml"
    sc.write_text(SCENARIO.format(maps=MAPS))
    argv = iwz_run_argv(sc, logs, SIM, extra=("--secure", "--ids", str(ids)))
    endpoint = f"tls/127.0.0.1:{argv[argv.index('--port') + 1]}"
    run = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    buses: list[ZenohBus] = []
    try:
        _wait_router(logs / "router.log", run)
        watcher, rogue = (ZenohBus(NetConfig(connect=(endpoint,), identity=str(ids / n))) for n in ("watcher", "rogue"))
        buses += [watcher, rogue]
        states, own = subscribe(watcher, keys.state(SIM), maxlen=1), subscribe(watcher, keys.actions(SIM, 2))
        wait_msg(states, WorldState, lambda s: 1 in s.ids, timeout_s=120)  # the bridge registered the chair
        sent, deadline = 0, time.monotonic() + 240
        while run.poll() is None and time.monotonic() < deadline:  # until the agent has it at its goal
            rogue.publish(keys.actions(SIM, 1), encode(Actions(robot_id=1, left=ROGUE, right=ROGUE)))
            rogue.publish(keys.actions(SIM, 2), encode(Actions(robot_id=2, left=ROGUE, right=ROGUE)))
            sent += 1
            time.sleep(0.02)  # a sender's pace, not synchronisation
        out, _ = run.communicate(timeout=60)
    finally:
        for b in buses:
            b.close()
        if run.poll() is None:
            stop_run(run)
    assert run.returncode == 0, out
    assert "(secured)" in out
    assert "PASS robot 1 within 0.5 m of (12, 6.1)" in out, out  # its agent drove it, through the bridge
    assert "PASS collisions 0" in out
    assert sent > 100
    assert own.drain(), "the rogue's own robot's actions never arrived: was it there at all?"
    wheels = _wheels(logs / "chair-wheels.log")
    assert any(left > 0 and right > 0 for left, right in wheels), wheels  # the chair moved under its agent
    assert (round(ROGUE * 10_000), round(ROGUE * 10_000)) not in wheels, wheels  # and never under the rogue
    policy = load_policy(ids / "policy.toml")
    assert list(policy.identities["bridge-serial"].roles) == ["serial"]  # no actions: its chair's agent commands it
    assert policy.identities["agent-1-wheelchair"].robots == [1]
    router = (logs / "router.log").read_text()
    assert f"access denied: Put from 'rogue' on iw/{SIM}/robot/1/actions" in router, router
    assert "from 'bridge-serial'" not in router, router  # the bridge did only what its role may
    assert "from 'agent-1-wheelchair'" not in router, router
