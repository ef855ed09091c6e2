"""Lock-step survives the loss of any role: a collision process killed while the world waits for
its verdict costs about its restart, not the lock-step timeout (a minute here), and one killed
together with the agent lets the agent, restarted, register again while the world waits."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest

from iw_zenoh.messages import WorldState
from tests.integration.faults import FaultRun as _Run
from tests.integration.faults import fault_scenario as _scenario
from tests.integration.faults import position_of as _at
from tests.integration.harness import wait_event, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

PATIENT = "lockstep_timeout_ms = 60000"  # a minute for a verdict or an answer (docs/agents.md)


def _moving_again(run: _Run, before: WorldState, timeout_s: float) -> float:
    """Seconds until robot 1 drives on past where it was at ``before`` (its tick stepped, not held)."""
    t0 = time.monotonic()
    wait_msg(
        run.states,
        WorldState,
        lambda m: 1 in m.ids and m.tick > before.tick + 3 and not m.held and _at(m)[0] > _at(before)[0] + 0.02,
        timeout_s,
    )
    return time.monotonic() - t0


def test_a_collision_kill_and_a_collision_and_agent_kill_cost_their_restart_not_the_lockstep_timeout(
    tmp_path: Path,
) -> None:
    scenario = _scenario(tmp_path, duration_s=300, world_fields=PATIENT, mode="lockstep", legs="18,5", goal_x=18.0)
    run = _Run(scenario, tmp_path)
    try:
        run.wait_moving(timeout_s=60)
        before = wait_msg(run.states, WorldState, lambda m: 1 in m.ids, timeout_s=20)
        subprocess.run(["kill", "-KILL", str(run.pid("collision"))], check=True, timeout=10)
        collision_s = _moving_again(run, before, timeout_s=30)  # was up to 60 s: the verdict's wait

        before = wait_msg(run.states, WorldState, lambda m: 1 in m.ids, timeout_s=20)
        t0 = time.monotonic()
        for role in ("collision", "agent"):
            subprocess.run(["kill", "-KILL", str(run.pid(role))], check=True, timeout=10)
        wait_event(run.events, "registered", timeout_s=40, pred=lambda e: e.robot_id == 1)
        _moving_again(run, before, timeout_s=30)  # was: a hang, 60 s every tick
        both_s = time.monotonic() - t0
        code, out = run.finish(timeout_s=150)
    finally:
        run.close()
    print(f"lock-step moving again {collision_s:.2f} s after a collision kill, {both_s:.2f} s after collision+agent")
    assert code == 0, out
    assert "PASS robot 1 within 0.5 m of (18, 5)" in out
