"""benchmarks/tickline.py lines up each process's stamps on the tick the world began."""

from __future__ import annotations

import json
from pathlib import Path

from benchmarks.tickline import line_up, load, table


def _stamps(ticks: int) -> dict[str, list[tuple[int, str, str]]]:
    """A world proposing every 1,000 us, a collision answering 200 us after, two agents' readings
    at 500 and 700 us; tick 3's collision slower (400 us)."""
    world, collision, a1, a2 = [], [], [], []
    for i in range(ticks):
        t0 = 10_000_000 + i * 1_000_000
        world.append((t0, "P", "iw/bench/world/proposed"))
        collision.append((t0 + (400_000 if i == 3 else 200_000), "R", "iw/bench/world/proposed"))
        a1.append((t0 + 500_000, "R", "iw/bench/robot/1/sensors"))
        a2.append((t0 + 700_000, "R", "iw/bench/robot/2/sensors"))
    world.append((5_000_000, "P", "iw/bench/robot/1/spec"))  # start-up: before the first tick
    return {"world": world, "collision": collision, "probe0": a1, "probe1": a2}


def test_steps_are_medians_since_the_proposal_first_and_last_over_processes() -> None:
    rows, tick = line_up(_stamps(30))
    assert tick == 1000.0
    got = {(r["process"], r["stamp"], r["key"]): (r["first_us"], r["last_us"]) for r in rows}
    assert got == {
        ("world", "P", "world/proposed"): (0.0, 0.0),
        ("collision", "R", "world/proposed"): (200.0, 200.0),  # the one slow tick is not the median
        ("agents", "R", "robot/*/sensors"): (500.0, 700.0),  # both agents as one kind, robot ids folded
    }
    assert [r["first_us"] for r in rows] == sorted(r["first_us"] for r in rows)
    lines = table(rows, tick)
    assert "+300" in lines[3]  # the agents' step, 300 us after the collision's
    assert "last 700" in lines[3]


def test_start_up_and_the_last_tick_are_left_out(tmp_path: Path) -> None:
    stamps = _stamps(30)
    stamps["collision"].append((10_000_000 + 29 * 1_000_000 + 900_000, "P", "iw/bench/world/verdict"))
    for name, got in stamps.items():
        (tmp_path / f"{name}-{len(name)}.json").write_text(json.dumps(got))
    rows, _ = line_up(load(tmp_path))
    assert {r["key"] for r in rows} == {"world/proposed", "robot/*/sensors"}
    assert all(r["ticks"] == 26 for r in rows)  # ticks 3..28: the first tenth (3) and the last out
