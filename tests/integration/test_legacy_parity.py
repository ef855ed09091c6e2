"""Parity with the legacy simulator: a scripted legacy robot on the bridge senses exactly what it
sensed in the legacy simulator itself (``tests/data/legacy/README.md``, "Parity trace")."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from lxml import etree

from tests.integration.harness import Net
from tests.integration.legacy import LegacyClient, ciberrato_world, measures_of

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

DATA = Path(__file__).resolve().parents[1] / "data" / "legacy"
REAL = DATA / "parity_C1_nonoise.real.json"
PARAMS = DATA / "parity_C1_nonoise.param.xml"
PHASES = ((0.1, 0.1), (0.05, 0.12), (-0.08, 0.08), (-0.06, -0.06))  # (left, right), 40 cycles each
ROBOT = (
    b'<Robot Id="1" Name="parity"><IRSensor Id="0" Angle="0.0" /><IRSensor Id="1" Angle="60.0" />'
    b'<IRSensor Id="2" Angle="-60.0" /><IRSensor Id="3" Angle="180.0" /></Robot>'
)


@pytest.fixture
def clients() -> Iterator[list[LegacyClient]]:
    """Legacy clients of a test, closed after it."""
    made: list[LegacyClient] = []
    yield made
    for c in made:
        c.close()


def _row(m: etree._Element) -> dict[str, Any]:
    """A Measures as a row of the reference: t, GPS, compass, collision, the four IR values."""
    sensors = m.find("Sensors")
    gps = sensors.find("GPS")
    ir = {int(e.get("Id")): float(e.get("Value")) for e in sensors.findall("IRSensor")}
    return {
        "t": int(m.get("Time")),
        "x": float(gps.get("X")),
        "y": float(gps.get("Y")),
        "compass": float(sensors.get("Compass")),
        "collision": sensors.get("Collision") == "Yes",
        "ir": [ir[i] for i in range(4)],
    }


def _displaced(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """GPS as displacement from the first fix (GPS offsets differ by design)."""
    x0, y0 = rows[0]["x"], rows[0]["y"]
    return [{**r, "x": round(r["x"] - x0, 1), "y": round(r["y"] - y0, 1)} for r in rows]


def _command(t: int) -> bytes:
    left, right = PHASES[(t // 40) % 4]
    return f'<Actions LeftMotor="{left}" RightMotor="{right}"/>'.encode()


def test_a_scripted_legacy_robot_senses_exactly_what_the_legacy_simulator_gave(
    net: Net, clients: list[LegacyClient]
) -> None:
    real = json.loads(REAL.read_text())["rows"]
    # lock-step, as long as it takes: a loaded machine slows the run, never changes it
    port = ciberrato_world(net, PARAMS, world=("--lockstep", "--lockstep-timeout-ms", "60000", "--paused"))
    robot, viewer = LegacyClient(port), LegacyClient(port)
    clients += [robot, viewer]
    assert b'Status="Ok"' in robot.register(ROBOT)
    assert b'Status="Ok"' in viewer.register(b"<View/>\n\x00")
    rows: list[dict[str, Any]] = []
    started = False
    while len(rows) < len(real):
        m = measures_of(robot.recv())
        t = int(m.get("Time"))
        robot.send(_command(t))  # every Measures answered, those of Time 0 (before Start) too
        if not started:  # Start right after an action: the action must not be overtaken
            viewer.send(b"<Start/>\n\x00")
            started = True
        if t >= 1:
            assert not rows or t == rows[-1]["t"] + 1, f"Time {t} after {rows[-1]['t']}"
            rows.append(_row(m))
    got, want = _displaced(rows), _displaced(real)
    diff = [(g, w) for g, w in zip(got, want, strict=True) if g != w]
    assert not diff, f"{len(diff)} rows differ; first: ours {diff[0][0]}, legacy {diff[0][1]}"
