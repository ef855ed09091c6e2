"""``iwz study SCENARIO --seeds 1-50 [--set FIELD=VALUE ...] [--condition NAME --set ...] [--jobs N]``:
many lock-step runs of a scenario, measured as ``iwz report`` measures one, aggregated per
condition (mean, spread, 95 % interval), written as JSON and an HTML page (docs/study.md).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import msgspec

from iw_zenoh.core.modes import Mode
from iw_zenoh.errors import ConfigError, IwError
from iw_zenoh.scenario.fields import parse_set
from iw_zenoh.scenario.file import load_scenario
from iw_zenoh.scenario.shipped import resolve_scenario
from iw_zenoh.study.runs import Condition, RunJob, run_all
from iw_zenoh.study.stats import summarize

__all__ = ["main", "parse_seeds"]

SEEDS_MAX = 100_000  # runs one study makes at most
BASE = "base"  # the condition's name when none is given
NAME = r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}"  # a condition's name: its runs' folder

EPILOG = """examples:
  iwz study demo --seeds 1-20                          20 seeds of a shipped scenario, the cores busy
  iwz study room.toml --seeds 1-50 --jobs 2 --out out  its JSON and page in out/
  iwz study room.toml --seeds 1-10 --set world.duration_s=30 --set 'agents[0].spec.max_speed_mps=0.4'
  iwz study room.toml --seeds 1-20 --set world.duration_s=30 \\
      --condition slow --set 'agents[0].args=["--speed", "0.05", "--waypoints", "8,5"]' \\
      --condition fast --set 'agents[0].args=["--speed", "0.12", "--waypoints", "8,5"]'
                                                       two conditions side by side, 20 seeds each

--set FIELD=VALUE changes a scenario field by its path (tables by '.', array items by [i]), VALUE
as in the file (TOML; text otherwise). --set before any --condition applies to every condition;
each --condition NAME starts a condition, and the --set after it are its own. Every run is a
lock-step `iwz run SCENARIO --seed N --set ...` (its command line is in the JSON), recorded in
OUT/runs/CONDITION/seed-N.mcap. A run that fails or times out is listed with its reason; the
study goes on. Exit: 0 every run measured, 1 some run failed, 2 arguments or scenario refused.
"""


def parse_seeds(text: str) -> list[int]:
    """Seeds written ``1-50``, ``3,7,9`` or ``1-5,10`` (each once, in order).

    Raises:
        ValueError: Saying the form.
    """
    seeds: list[int] = []
    for part in text.split(","):
        a, dash, b = part.strip().partition("-")
        try:
            lo, hi = int(a), int(b) if dash else int(a)
        except ValueError:
            raise ValueError(f"--seeds takes 1-50, 3,7,9 or 1-5,10 (non-negative integers); got {text!r}") from None
        if lo < 0 or hi < lo:
            raise ValueError(f"--seeds: {part!r} is not a range from low to high of non-negative seeds")
        if len(seeds) + hi - lo + 1 > SEEDS_MAX:
            raise ValueError(f"--seeds: at most {SEEDS_MAX} runs in one study")
        seeds += [s for s in range(lo, hi + 1) if s not in seeds]
    return seeds


class _Condition(argparse.Action):
    """``--condition NAME``: a new condition; the ``--set`` after it are its own."""

    def __call__(self, p: argparse.ArgumentParser, ns: argparse.Namespace, value: Any, opt: str | None = None) -> None:
        if not re.fullmatch(NAME, value):
            p.error(f"--condition {value!r}: a name is 1 to 64 letters, digits, '.', '_' or '-' (names a folder)")
        if value in [c.name for c in ns.conditions]:
            p.error(f"--condition {value!r} is given twice: name each condition once")
        ns.conditions.append(Condition(value))


class _Set(argparse.Action):
    """``--set FIELD=VALUE``: the last condition's, or every condition's before the first."""

    def __call__(self, p: argparse.ArgumentParser, ns: argparse.Namespace, value: Any, opt: str | None = None) -> None:
        try:
            parse_set(value)
        except ConfigError as e:
            p.error(f"--set {value!r}: {e.reason}")
        if ns.conditions:
            last = ns.conditions[-1]
            ns.conditions[-1] = Condition(last.name, (*last.sets, value))
        else:
            ns.common.append(value)


def build_parser() -> argparse.ArgumentParser:
    """The arguments of ``iwz study``."""
    p = argparse.ArgumentParser(
        prog="iwz study",
        description="Many lock-step runs of a scenario (seeds x conditions), every iwz report measure "
        "aggregated with its mean, spread and 95 %% interval, conditions side by side: JSON and an HTML page.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("scenario", help="a scenario TOML file, or a shipped scenario by name (iwz scenarios)")
    p.add_argument("--seeds", default="1-10", help="the world seeds: 1-50, 3,7,9 or 1-5,10 (default 1-10)")
    p.add_argument("--set", action=_Set, metavar="FIELD=VALUE", help="change a scenario field (repeatable)")
    p.add_argument("--condition", action=_Condition, metavar="NAME", help="start a condition (repeatable)")
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="runs at a time (default: the cores)")
    p.add_argument("--out", metavar="DIR", help="where the study goes (default studies/SCENARIO-DATE-TIME)")
    p.add_argument(
        "--timeout",
        type=float,
        metavar="S",
        help="a run still going after S s is stopped and failed "
        "(default: 10 x the scenario's duration, at least 120 s)",
    )
    p.set_defaults(conditions=[], common=[])
    return p


def _checked(path: Path, common: list[str], conditions: list[Condition]) -> float:
    """Reads the scenario under every condition as its runs will (refusing what would fail them
    all); the longest duration, s."""
    longest = 0.0
    for c in conditions:
        sc = load_scenario(path, [parse_set(s) for s in (*common, *c.sets)])
        if sc.chair is not None:
            raise ConfigError(
                f"{sc.name}: chair", "a chair on a serial link runs in real time; iwz study runs lock-step"
            )
        if sc.bridge is not None:
            raise ConfigError(f"{sc.name}: bridge", "a legacy bridge's clients are not run by iwz study; leave it out")
        longest = max(longest, msgspec.structs.replace(sc.world, mode=Mode.LOCKSTEP).duration_s)
    return longest


def _progress(row: dict[str, Any], done: int, total: int) -> None:
    what = "ok" if row.get("status") == "ok" else f"FAILED: {row.get('reason', '')}"
    wall = f" ({row['wall_s']:.1f} s)" if row.get("wall_s") else ""
    print(f"iwz study: {done}/{total} {row['condition']} seed {row['seed']}: {what}{wall}", file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz study``."""
    p = build_parser()
    args = p.parse_args(argv)
    try:
        seeds = parse_seeds(args.seeds)
    except ValueError as e:
        p.error(str(e))
    if args.jobs < 1:
        p.error(f"--jobs must be at least 1, got {args.jobs}")
    conditions: list[Condition] = args.conditions or [Condition(BASE)]
    try:
        path = Path(resolve_scenario(args.scenario))
        longest = _checked(path, args.common, conditions)
    except IwError as e:
        print(f"iwz study: {e}", file=sys.stderr)
        return 2
    out = Path(args.out or Path("studies") / f"{path.stem}-{time.strftime('%Y%m%d-%H%M%S')}")
    timeout = args.timeout if args.timeout is not None else max(120.0, 10.0 * longest)
    jobs = [RunJob(path, c, s, out / "runs" / c.name, timeout, tuple(args.common)) for c in conditions for s in seeds]
    print(
        f"iwz study: {len(jobs)} runs ({len(conditions)} conditions x {len(seeds)} seeds), "
        f"{args.jobs} at a time, into {out}",
        file=sys.stderr,
        flush=True,
    )
    out.mkdir(parents=True, exist_ok=True)
    rows = run_all(jobs, workers=args.jobs, progress=_progress)
    return _write(out, path, args, conditions, rows)


def _write(out: Path, path: Path, args: argparse.Namespace, conditions: list[Condition], rows: list[Any]) -> int:
    """Writes ``study.json`` and ``study.html``; the exit code."""
    from iw_zenoh.study.page import write_page  # matplotlib once the runs are made

    study = {
        "scenario": str(path),
        "scenario_name": path.stem,
        "seeds_text": args.seeds,
        "common": list(args.common),
        "conditions": [{"name": c.name, "sets": [*args.common, *c.sets]} for c in conditions],
        "summary": {c.name: summarize([r for r in rows if r["condition"] == c.name]) for c in conditions},
        "runs": rows,
    }
    (out / "study.json").write_text(json.dumps(study, indent=1))
    write_page(out / "study.html", study)
    failed = sum(1 for r in rows if r.get("status") != "ok")
    print(
        f"iwz study: {len(rows) - failed} of {len(rows)} runs measured"
        + (f", {failed} failed (listed in the JSON and the page)" if failed else "")
        + f"; wrote {out / 'study.json'} and {out / 'study.html'}",
        file=sys.stderr,
        flush=True,
    )
    return 1 if failed else 0
