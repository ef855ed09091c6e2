"""``iwz report RUN.mcap [OTHER.mcap ...]``: what a study measures of a run, per chair and for the run.

Time to goal, path length, minimum clearance to walls and to people or chairs, collisions and
near misses, watchdog stops, mean and peak speed and acceleration, jerk, time waiting at doors
(:mod:`iw_zenoh.record.metrics` defines each), and for a chair a person drove the driver's inputs,
commands and the time shared control intervened (:mod:`iw_zenoh.record.drive_metrics`); as a
table, as JSON (``--json``) or as an HTML page with plots (``--html OUT.html``); up to four
recordings side by side (manual, assisted, autonomous...; the page takes two).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

from iw_zenoh.errors import IwError, RecordingError
from iw_zenoh.messages import DriveInput, DriveState, Event, WorldInfo, WorldState
from iw_zenoh.record.incidents import clearance_arg
from iw_zenoh.record.metrics import Goal, RunMeter, RunReport, parse_goals, recorded_goals
from iw_zenoh.record.reader import discard_cut_off, file_error, open_recording, print_notes

__all__ = ["GOALS_META", "ROWS", "as_json", "main", "report_of", "table"]

MAX_RUNS = 4  # recordings side by side (manual, safe, assist, autonomous: the seed's Table 7.3)
GOALS_META = ("iw.user", "goals")  # where the launcher writes the scenario's [[criteria.reach]]

ROWS = (  # (field, label, format) of the table, in order
    ("time_to_goal_s", "time to goal, s", "{:.1f}"),
    ("time_to_stop_s", "time to stop, s", "{:.1f}"),
    ("path_length_m", "path length, m", "{:.2f}"),
    ("min_clearance_walls_m", "min clearance to walls, m", "{:.2f}"),
    ("min_clearance_people_m", "min clearance to people/chairs, m", "{:.2f}"),
    ("collisions", "collisions", "{}"),
    ("near_misses", "near misses", "{}"),
    ("watchdog_stops", "watchdog stops", "{}"),
    ("mean_speed_mps", "mean speed (moving), m/s", "{:.2f}"),
    ("peak_speed_mps", "peak speed, m/s", "{:.2f}"),
    ("mean_abs_accel_mps2", "mean |acceleration|, m/s2", "{:.2f}"),
    ("peak_accel_mps2", "peak |acceleration|, m/s2", "{:.2f}"),
    ("rms_jerk_mps3", "jerk (RMS), m/s3", "{:.2f}"),
    ("peak_jerk_mps3", "peak |jerk|, m/s3", "{:.2f}"),
    ("door_wait_s", "waiting at doors, s", "{:.1f}"),
    ("driver_inputs", "driver inputs", "{}"),  # a chair a person drove (docs/driving.md)
    ("commands_given", "commands given", "{}"),
    ("assist_intervened_s", "assistance intervened, s", "{:.1f}"),
)
RUN_ROWS = (
    ("chairs", "chairs", "{}"),
    ("goals_reached", "goals reached", "{}"),
    ("time_to_last_goal_s", "time to the last goal, s", "{:.1f}"),
    ("path_length_m", "path length (all), m", "{:.2f}"),
    ("min_clearance_walls_m", "min clearance to walls, m", "{:.2f}"),
    ("min_clearance_people_m", "min clearance to people/chairs, m", "{:.2f}"),
    ("collisions", "collisions", "{}"),
    ("near_misses", "near misses", "{}"),
    ("watchdog_stops", "watchdog stops", "{}"),
    ("mean_speed_mps", "mean speed (moving), m/s", "{:.2f}"),
    ("peak_speed_mps", "peak speed, m/s", "{:.2f}"),
    ("peak_accel_mps2", "peak |acceleration|, m/s2", "{:.2f}"),
    ("rms_jerk_mps3", "jerk (RMS), m/s3", "{:.2f}"),
    ("door_wait_s", "waiting at doors, s", "{:.1f}"),
)


def report_of(path: str | Path, goals: dict[int, Goal] | None = None, *, near_m: float = 0.2) -> RunReport:
    """Reads a recording (every part of it) and measures it.

    Args:
        path: The recording.
        goals: Chairs' goals; the recording's own (its scenario's) are used for the others.
        near_m: Near-miss clearance, metres.

    Returns:
        The report.

    Raises:
        RecordingError: When the file cannot be read, or holds no world state to measure.
        ValueError: When the goals recorded in it are malformed.
    """
    with open_recording(path) as rec:
        recorded = rec.metadata().get(GOALS_META[0], {}).get(GOALS_META[1], "")
        meter = RunMeter({**recorded_goals(recorded), **(goals or {})}, near_m=near_m)
        for r in rec.records(("info", "state", "event", "drive", "driving")):
            match r.message:
                case DriveInput() as inp:
                    meter.drive.on_input(inp)
                case DriveState() as ds:
                    meter.drive.on_state(ds)
                case WorldInfo() as info:
                    meter.on_info(info)
                case WorldState() as st:
                    meter.on_state(st)
                case Event() as ev:
                    meter.on_event(ev)
        print_notes("iwz report", rec)
    out = meter.finish()
    if not out.ticks:
        raise RecordingError(str(path), "no world state with a known robot to measure (was the world recorded?)")
    return out


def _cell(value: object, fmt: str) -> str:
    return "-" if value is None else fmt.format(value)


def table(reports: Sequence[tuple[str, RunReport]]) -> str:
    """The reports as a text table: the run's figures, then each chair's, runs side by side."""
    cols = [(f"{name}", r.run) for name, r in reports]
    lines = [f"{'run':<36}" + "".join(f"{Path(n).name[-24:]:>26}" for n, _ in cols)]
    lines.append(f"{'duration, s':<36}" + "".join(f"{r.duration_s:>26.1f}" for _, r in reports))
    lines += [f"{label:<36}" + "".join(f"{_cell(c.get(k), fmt):>26}" for _, c in cols) for k, label, fmt in RUN_ROWS]
    ids = sorted({c.robot_id for _, r in reports for c in r.chairs})
    for rid in ids:
        per = [next((c for c in r.chairs if c.robot_id == rid), None) for _, r in reports]
        name = next(c.name for c in per if c is not None)
        lines += ["", f"{f'chair {rid} ({name})':<36}"]
        for k, label, fmt in ROWS:
            lines.append(f"  {label:<34}" + "".join(f"{_cell(getattr(c, k) if c else None, fmt):>26}" for c in per))
    return "\n".join(lines)


def _goals(text: list[str]) -> dict[int, Goal]:
    try:
        return parse_goals(";".join(text))
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


EPILOG = """examples:
  iwz report recordings/demo-sample.mcap               a table: the run, then each chair
  iwz report run.mcap --json > run.json                the same figures as JSON
  iwz report run.mcap --html run.html                  a page with plots (paths, speed, clearance)
  iwz report before.mcap after.mcap --html cmp.html    two runs side by side
  iwz report manual.mcap safe.mcap auto.mcap           manual, assisted and autonomous, side by side
  iwz report run.mcap --goal 1=20,6.1,0.5              time to goal for chair 1 (scenarios record theirs)
"""


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz report``."""
    p = argparse.ArgumentParser(
        prog="iwz report",
        description="What a study measures of a run, per chair and for the run (see docs/report.md).",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("files", nargs="+", metavar="FILE", help="one MCAP recording, or up to four to compare")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.add_argument("--html", metavar="OUT", help="also write an HTML page with plots (self-contained)")
    p.add_argument("--near", type=clearance_arg, default=0.2, help="near-miss clearance, m (default 0.2)")
    p.add_argument("--goal", action="append", default=[], metavar="ID=X,Y[,WITHIN]", help="a chair's goal (repeatable)")
    args = p.parse_args(argv)
    if len(args.files) > MAX_RUNS:
        p.error(f"at most {MAX_RUNS} recordings side by side, got {len(args.files)}")
    if args.html and len(args.files) > 2:
        p.error(f"--html compares at most two recordings, got {len(args.files)}; leave --html out for the table")
    try:
        goals = _goals(args.goal)
    except argparse.ArgumentTypeError as e:
        p.error(f"--goal: {e}")
    reports = []
    for f in args.files:
        try:
            reports.append((f, report_of(f, goals, near_m=args.near)))
        except (IwError, OSError, ValueError) as e:
            hint = "; check it with iwz doctor (and iwz recover)" if Path(f).is_file() else ""
            print(f"iwz report: {file_error(f, e)}{hint}", file=sys.stderr)
            return 2
    if args.html:
        from iw_zenoh.record.report_page import write_page  # matplotlib only when a page is asked for

        try:
            write_page(Path(args.html), reports)
        except OSError as e:
            discard_cut_off(args.html, e)
            print(
                f"iwz report: --html {args.html}: cannot write it ({e.strerror or e}); give a writable path",
                file=sys.stderr,
            )
            return 2
    if args.json:
        print(json.dumps({"runs": [{"file": f, **as_json(r)} for f, r in reports]}))
    else:
        print(table(reports))
        if args.html:
            print(f"\nwrote {args.html}")
    return 0


def as_json(r: RunReport) -> dict[str, object]:
    """A run's report as ``--json`` prints it (without its file's name): what ``iwz study`` keeps of each run."""
    return {
        "duration_s": r.duration_s,
        "ticks": r.ticks,
        "run": r.run,
        "chairs": [asdict(c) for c in r.chairs],
    }
