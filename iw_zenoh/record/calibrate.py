"""``iwz calibrate LOG.csv``: MaxSpeed and AccelerationCurve from a real chair's log.

The CSV has a header and either ``t,speed`` (seconds, m/s) or ``t,left_ticks,right_ticks``
(cumulative encoder ticks; give ``--ticks-per-m``). The log starts with the step to full power,
unless it also has ``left_cmd,right_cmd`` (the log ``iwz bridge serial --log`` writes of a real
run): then the step is found in it, the first run commanded at its top power on both wheels.

Examples:
  iwz calibrate chair-step.csv                        # t,speed: a step from rest, logged by hand
  iwz calibrate ticks.csv --ticks-per-m 2000          # t,left_ticks,right_ticks
  iwz calibrate bridge.csv --period-ms 50             # what `iwz bridge serial --log bridge.csv` wrote

A log that cannot be trusted (a truncated or run-together row, a word or NaN where a number
belongs, times that go back, two runs in one file) is refused with its file, line and column,
never fitted: fix or cut the line it names.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from iw_zenoh.core.calibration import fit_motor, rise_time_of, speeds_from_ticks, step_window
from iw_zenoh.errors import LogError

__all__ = ["main", "read_log"]

FloatArray = npt.NDArray[np.float64]
KINDS = (("t", "speed"), ("t", "left_ticks", "right_ticks"))  # the columns each kind of log needs
COMMANDS = ("left_cmd", "right_cmd")  # a serial bridge's log also has these: the step is found in it
BOUNDS = {  # a value beyond is corrupt, not a chair: (largest magnitude, what the column holds)
    "t": (1e10, "seconds"),
    "speed": (20.0, "m/s"),
    "left_ticks": (2.0**53, "encoder ticks"),  # exact in a double
    "right_ticks": (2.0**53, "encoder ticks"),
    "left_cmd": (1.0, "motor power (the bridge logs at most 0.15)"),
    "right_cmd": (1.0, "motor power (the bridge logs at most 0.15)"),
}


def _columns(source: str, header: list[str], line: int) -> tuple[str, ...]:
    """The columns to read for a header (the kind's, and the commands when it has both)."""
    names = [h.strip() for h in header]
    if all(_number(n) for n in names):
        raise LogError(
            source,
            line,
            "no header: the first line holds numbers; start the log with one naming its columns "
            "(t,speed or t,left_ticks,right_ticks, as `iwz bridge serial --log` writes)",
        )
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise LogError(source, line, f"the header names {', '.join(dup)} twice: name each column once")
    kind = next((k for k in KINDS if set(k) <= set(names)), None)
    if kind is None:
        raise LogError(
            source,
            line,
            f"the header is {','.join(names) or '(empty)'}; it must name t,speed or t,left_ticks,right_ticks "
            "(as `iwz bridge serial --log` writes): give the log a header line",
        )
    return kind + (COMMANDS if set(COMMANDS) <= set(names) else ())


def _number(text: str) -> bool:
    """Whether a field reads as a number."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def _value(source: str, line: int, name: str, text: str) -> float:
    """One field as a finite number within its column's bounds."""
    try:
        v = float(text)
    except ValueError:
        raise LogError(source, line, f"column {name} holds {text.strip()[:40]!r}, not a number") from None
    if not math.isfinite(v):
        raise LogError(source, line, f"column {name} holds {text.strip()!r}: a number is needed (finite)")
    top, unit = BOUNDS[name]
    if abs(v) > top:
        raise LogError(source, line, f"column {name} holds {v:g}, beyond +-{top:g} {unit}: a corrupt row? cut it")
    return v


def _rows(
    source: str, lines: Iterable[tuple[int, list[str]]], names: list[str], columns: tuple[str, ...]
) -> dict[str, list[float]]:
    """Every data row's values of ``columns`` (rows with their line numbers), checked field by field
    (times must increase)."""
    where = [names.index(c) for c in columns]
    out: dict[str, list[float]] = {c: [] for c in columns}
    last: tuple[float, int] | None = None
    for line, row in lines:
        if not row or all(not f.strip() for f in row):
            continue  # a blank line
        if [f.strip() for f in row] == names:
            raise LogError(
                source, line, "the header again: the file holds more than one run (the bridge appends); keep one"
            )
        if len(row) != len(names):
            raise LogError(
                source,
                line,
                f"{len(row)} fields where the header has {len(names)}: a truncated row (the run cut off "
                "mid-line?); delete the line",
            )
        for c, i in zip(columns, where, strict=True):
            out[c].append(_value(source, line, c, row[i]))
        t = out["t"][-1]
        if last is not None and t <= last[0]:
            raise LogError(
                source, line, f"t = {t:g} does not come after t = {last[0]:g} (line {last[1]}): times must increase"
            )
        last = (t, line)
    if not out["t"]:
        raise LogError(source, None, "a header and no rows: log a run (a step to full power from rest)")
    return out


def read_log(path: Path) -> dict[str, FloatArray]:
    """A chair's CSV log, checked: every row complete, every value a finite number in range, times
    increasing.

    Args:
        path: The CSV file (``t,speed``; ``t,left_ticks,right_ticks``; or the serial bridge's log).

    Returns:
        The columns the fit needs (``t`` and ``speed`` or the ticks, and the commands when the
        log has them), by name, one value per row.

    Raises:
        LogError: The file cannot be read or a line is refused (names the line and the fix).
    """
    source = str(path)
    try:
        with path.open(newline="", encoding="utf-8") as f:
            reader = csv.reader(f)
            header = next((r for r in reader if any(h.strip() for h in r)), None)
            if header is None:
                raise LogError(source, None, "empty: give the CSV log of a run (a header line, then rows)")
            names = [h.strip() for h in header]
            columns = _columns(source, header, reader.line_num)
            rows = _rows(source, ((reader.line_num, r) for r in reader), names, columns)
    except OSError as e:
        raise LogError(source, None, f"cannot read it ({e.strerror or e}): give the path of a CSV log") from None
    except UnicodeDecodeError:
        raise LogError(source, None, "not text (UTF-8): give the CSV the chair or its bridge logged") from None
    except csv.Error as e:
        raise LogError(source, reader.line_num, f"not CSV ({e}): give the CSV the chair or its bridge logged") from None
    return {c: np.array(v, dtype=np.float64) for c, v in rows.items()}


def _positive(text: str) -> float:
    """An argparse type: a positive finite number."""
    v = float(text)
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return v


def _fit(log: dict[str, FloatArray], source: str, ticks_per_m: float, period_s: float) -> None:
    """Finds the step (a bridge's log), fits and prints the model."""
    t = log["t"]
    if "left_cmd" in log:
        try:
            a, b = step_window(log["left_cmd"], log["right_cmd"])
        except ValueError as e:
            raise LogError(source, None, f"{e}: log a run with a step to full power on both wheels") from None
        print(f"step to power {log['left_cmd'][b - 1]:g} at t = {t[a]:.2f} s, {b - a} rows")
        log = {k: v[a:b] for k, v in log.items()}
        t = log["t"]
    v = log["speed"] if "speed" in log else speeds_from_ticks(t, log["left_ticks"], log["right_ticks"], ticks_per_m)
    try:
        fit = fit_motor(t, v, period_s=period_s)
    except ValueError as e:
        raise LogError(source, None, f"{e} (the step to full power, from rest, until the speed is steady)") from None
    t0 = t - t[0]
    print(f"MaxSpeed = {fit.max_speed_mps:.3f} m/s")
    print(f"AccelerationCurve = {fit.curve:.3f} (for {period_s * 1000.0:g} ms ticks)")
    logged = rise_time_of(t0, v, fit.max_speed_mps)
    modelled = rise_time_of(t0, fit.speed(t0), fit.max_speed_mps)
    print(f"rise time 10-90 %: log {logged:.2f} s, model {modelled:.2f} s")


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz calibrate``."""
    p = argparse.ArgumentParser(
        prog="iwz calibrate", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("log", help="CSV: t,speed or t,left_ticks,right_ticks (or the serial bridge's --log)")
    p.add_argument(
        "--ticks-per-m", type=_positive, default=2000.0, help="encoder ticks per metre (tick logs; default 2000)"
    )
    p.add_argument("--period-ms", type=_positive, default=100.0, help="simulator tick the curve is for (default 100)")
    args = p.parse_args(argv)
    try:
        _fit(read_log(Path(args.log)), args.log, args.ticks_per_m, args.period_ms / 1000.0)
    except LogError as e:
        print(f"iwz calibrate: error: {e}", file=sys.stderr)
        return 2
    return 0
