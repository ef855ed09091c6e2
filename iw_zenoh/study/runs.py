"""A study's runs: every condition and seed as its own lock-step ``iwz run`` (a process, with
its router on a port of its own), ``jobs`` at a time, each measured as ``iwz report`` measures
it. A run that fails (an exit other than 0 or 1, a recording that cannot be measured) or outlives
its timeout is a row with its reason; the others go on.
"""

from __future__ import annotations

import logging
import signal
import subprocess
import sys
import threading
import time
import zlib
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from iw_zenoh.bus.net import free_port
from iw_zenoh.errors import IwError
from iw_zenoh.record.report import as_json, report_of

__all__ = ["Condition", "RunJob", "run_all", "run_one"]

logger = logging.getLogger(__name__)

STOP_WAIT_S = 30.0  # a run past its timeout is stopped as Ctrl-C stops it, then killed this much later
TAIL_LINES = 6  # the last lines of a failed run's output that say why


@dataclass(frozen=True)
class Condition:
    """One condition of a study: its name and the fields it changes (``FIELD=VALUE`` as written)."""

    name: str
    sets: tuple[str, ...] = ()


@dataclass
class RunJob:
    """One run to make: a condition and a seed, where its files go, and how long it may take."""

    scenario: Path
    condition: Condition
    seed: int
    folder: Path
    timeout_s: float
    common: tuple[str, ...] = ()  # every condition's sets, before its own
    extra: tuple[str, ...] = field(default=())  # more of iwz run's options (tests)

    @property
    def stem(self) -> Path:
        """``FOLDER/seed-N``: its recording is ``.mcap``, its output ``.log``, its processes' logs the folder."""
        return self.folder / f"seed-{self.seed}"

    def argv(self, port: int) -> list[str]:
        """The ``iwz run`` command line of this run."""
        sets = [a for s in (*self.common, *self.condition.sets) for a in ("--set", s)]
        return [
            sys.executable,
            "-m",
            "iw_zenoh.cli",
            "run",
            str(self.scenario),
            "--lockstep",
            "--seed",
            str(self.seed),
            *sets,
            "--no-status",
            "--port",
            str(port),
            "--sim",  # a key space of its own: runs side by side never hear each other, even on one router
            f"study-{zlib.crc32(self.condition.name.encode()):08x}-seed-{self.seed}",
            "--log-dir",
            str(self.stem),
            "--record",
            str(self.stem.with_suffix(".mcap")),
            *self.extra,
        ]


def _tail(path: Path) -> str:
    lines = [ln for ln in path.read_text(errors="replace").splitlines() if ln.strip()] if path.exists() else []
    return " | ".join(lines[-TAIL_LINES:]) or "no output"


def _wait(p: subprocess.Popen[bytes], timeout_s: float) -> int | None:
    """The run's exit code, or None when it outlived ``timeout_s`` (it is then stopped, by pid)."""
    try:
        return p.wait(timeout_s)
    except subprocess.TimeoutExpired:
        p.send_signal(signal.SIGINT)  # iwz run stops every process it started, in order
        try:
            p.wait(STOP_WAIT_S)
        except subprocess.TimeoutExpired:
            p.kill()  # its processes stop by themselves once it is gone (docs/runtime.md, Faults)
            p.wait()
        return None


PORT_TRIES = 3  # a run whose router could not take its port is started again on another, this often
ROLE_FAILED = 3  # iwz run's exit code when a role could not start
# what iwz run says when its router could not take the port: it did not start, or nothing answered there
ROUTER_FAILED = ("the router did not start on", "cannot join the bus")


def run_one(job: RunJob, stop: threading.Event | None = None) -> dict[str, Any]:
    """Makes one run and measures it: its row of the study (see :func:`iw_zenoh.study.stats.summarize`)."""
    job.folder.mkdir(parents=True, exist_ok=True)
    argv = job.argv(free_port())
    row: dict[str, Any] = {
        "condition": job.condition.name,
        "seed": job.seed,
        "status": "failed",
        "reason": "",
        "exit_code": None,
        "criteria_met": False,
        "wall_s": 0.0,
        "recording": str(job.stem.with_suffix(".mcap")),
        "command": " ".join(["iwz", *argv[3:]]),
        "report": None,
    }
    if stop is not None and stop.is_set():
        row["reason"] = "not run: the study was interrupted"
        return row
    t0 = time.monotonic()
    log = job.stem.with_suffix(".log")
    for attempt in range(1, PORT_TRIES + 1):
        with log.open("wb") as out:
            p = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        code = _wait(p, job.timeout_s)
        said = log.read_text(errors="replace") if log.exists() else ""
        router_failed = any(words in said for words in ROUTER_FAILED)
        if code != ROLE_FAILED or not router_failed or attempt == PORT_TRIES or (stop and stop.is_set()):
            break
        # the free port was taken between our look and its router's bind (another run's, or any
        # connection's own port): the run never ran; again on another port
        logger.info("run %s seed %d: its router's port was taken; again on another", job.condition.name, job.seed)
        argv = job.argv(free_port())
        row["command"] = " ".join(["iwz", *argv[3:]])
    row["wall_s"] = round(time.monotonic() - t0, 3)
    row["exit_code"] = code
    if code is None:
        row["reason"] = f"timed out after {job.timeout_s:g} s (stopped); its output: {log}"
        return row
    if code not in (0, 1):
        row["reason"] = f"iwz run exited with {code}: {_tail(log)}"
        return row
    try:
        report = report_of(job.stem.with_suffix(".mcap"))
    except (IwError, OSError, ValueError) as e:
        row["reason"] = f"its recording could not be measured: {e}; its output: {_tail(log)}"
        return row
    row.update(status="ok", criteria_met=code == 0, report=as_json(report))
    return row


def run_all(
    jobs: Sequence[RunJob],
    *,
    workers: int,
    progress: Callable[[dict[str, Any], int, int], None] | None = None,
    stop: threading.Event | None = None,
) -> list[dict[str, Any]]:
    """Makes every run, ``workers`` at a time; the rows in the jobs' order. ``progress(row,
    done, total)`` is told of each run as it ends."""
    done = 0
    lock = threading.Lock()

    def one(job: RunJob) -> dict[str, Any]:
        nonlocal done
        try:
            row = run_one(job, stop)
        except Exception as e:  # a study goes on: this run's row says what went wrong
            logger.exception("run %s seed %d", job.condition.name, job.seed)
            row = {"condition": job.condition.name, "seed": job.seed, "status": "failed", "reason": repr(e)}
        with lock:
            done += 1
            if progress is not None:
                progress(row, done, len(jobs))
        return row

    with ThreadPoolExecutor(max_workers=max(1, workers), thread_name_prefix="study") as pool:
        return list(pool.map(one, jobs))
