"""Progress on long jobs: on a terminal every second, elsewhere every 10 % once a job is long,
never on a short one, and a closed stderr silences it."""

from __future__ import annotations

import io
from pathlib import Path

from iw_zenoh.record.progress import Progress
from iw_zenoh.record.tools import recover
from tests.support.parts import recorded_part as _part


class _Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def _run(p: Progress, clock: _Clock, steps: int, dt_s: float) -> None:
    for i in range(1, steps + 1):
        clock.t += dt_s
        p.update(i / steps, f"step {i}")
    p.done()


def test_a_short_job_says_nothing_off_a_terminal() -> None:
    out, clock = io.StringIO(), _Clock()
    _run(Progress("iwz x", stream=out, tty=False, clock=clock), clock, 100, 0.01)
    assert out.getvalue() == ""


def test_a_long_job_off_a_terminal_says_each_tenth_on_its_own_line() -> None:
    out, clock = io.StringIO(), _Clock()
    _run(Progress("iwz x", stream=out, tty=False, clock=clock), clock, 1000, 0.01)  # 10 s
    lines = out.getvalue().splitlines()
    assert 8 <= len(lines) <= 10  # from 2 s on, once per tenth
    assert lines[-1].startswith("iwz x: 100 % (step 1000)")
    assert "\r" not in out.getvalue()


def test_a_terminal_line_is_rewritten_every_second_and_ended() -> None:
    out, clock = io.StringIO(), _Clock()
    _run(Progress("iwz x", stream=out, tty=True, clock=clock), clock, 50, 0.1)  # 5 s
    text = out.getvalue()
    assert 4 <= text.count("\r") <= 5  # once a second (float steps)
    assert text.endswith("\n")


def test_a_closed_stderr_silences_it() -> None:
    out, clock = io.StringIO(), _Clock()
    p = Progress("iwz x", stream=out, tty=True, clock=clock)
    out.close()
    _run(p, clock, 10, 1.0)  # raises nothing


def test_recover_reports_how_far_it_has_read(tmp_path: Path) -> None:
    path = _part(tmp_path / "long.mcap", range(1, 3000), run=None, cut=True)
    seen: list[float] = []
    with path.open("rb") as fi:
        recover(fi, io.BytesIO(), path.stat().st_size, progress=seen.append)
    assert seen
    assert seen == sorted(seen)
    assert 0.5 < seen[-1] <= 1.0
