"""Parity with the legacy simulator: a scripted legacy robot on the bridge senses exactly what it
sensed in the legacy simulator itself (``tests/data/legacy/README.md``, "Parity trace"; the script
is :mod:`benchmarks.parity`, which ``benchmarks/c1_held.py`` runs in real time)."""

from __future__ import annotations

import pytest

from benchmarks.parity import PARAMS, ROBOT, LegacyClient, displaced, drive, first_difference, real_rows
from tests.integration.harness import Net
from tests.integration.legacy import ciberrato_world

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

CYCLE_S = 60.0  # how long a lock-step cycle may take here: the world waits as long for the robot's answer


def test_a_scripted_legacy_robot_senses_exactly_what_the_legacy_simulator_gave(
    net: Net, clients: list[LegacyClient]
) -> None:
    real = real_rows()
    # lock-step, as long as it takes: a loaded machine slows the run, never changes it
    port = ciberrato_world(net, PARAMS, world=("--lockstep", "--lockstep-timeout-ms", "60000", "--paused"))
    robot, viewer = LegacyClient(port), LegacyClient(port)
    clients += [robot, viewer]
    assert b'Status="Ok"' in robot.register(ROBOT)
    robot.sock.settimeout(CYCLE_S)  # not croblink's 2 s: on a loaded machine a cycle may take longer
    assert b'Status="Ok"' in viewer.register(b"<View/>\n\x00")
    rows = drive(robot, viewer, last_t=len(real))
    times = [r["t"] for r in rows]
    assert times == list(range(1, len(real) + 1)), f"Times received: {times}"
    diff = first_difference(displaced(rows), displaced(real))
    assert diff is None, f"{diff[0]} rows differ; first: ours {diff[1]}, legacy {diff[2]}"
