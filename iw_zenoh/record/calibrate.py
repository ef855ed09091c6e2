"""``iwz calibrate LOG.csv``: MaxSpeed and AccelerationCurve from a real chair's log.

The CSV has a header and either ``t,speed`` (seconds, m/s) or ``t,left_ticks,right_ticks``
(cumulative encoder ticks; give ``--ticks-per-m``). The log starts with the step to full power,
unless it also has ``left_cmd,right_cmd`` (the log ``iwz bridge serial --log`` writes of a real
run): then the step is found in it, the first run commanded at its top power on both wheels.
"""

from __future__ import annotations

import argparse
import csv
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from iw_zenoh.core.calibration import fit_motor, rise_time_of, speeds_from_ticks, step_window

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz calibrate``."""
    p = argparse.ArgumentParser(
        prog="iwz calibrate", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("log", help="CSV: t,speed or t,left_ticks,right_ticks")
    p.add_argument(
        "--ticks-per-m", type=float, default=2000.0, help="encoder ticks per metre (tick logs; default 2000)"
    )
    p.add_argument("--period-ms", type=float, default=100.0, help="simulator tick the curve is for (default 100)")
    args = p.parse_args(argv)
    try:
        with Path(args.log).open(newline="") as f:
            rows = list(csv.DictReader(f))
        cols = set(rows[0]) if rows else set()
        if {"left_cmd", "right_cmd"} <= cols:  # a serial bridge's log: find the step in it
            a, b = step_window(
                np.array([float(r["left_cmd"]) for r in rows]), np.array([float(r["right_cmd"]) for r in rows])
            )
            print(f"step to power {float(rows[a + 1]['left_cmd']):g} at t = {float(rows[a]['t']):.2f} s, {b - a} rows")
            rows = rows[a:b]
        t = np.array([float(r["t"]) for r in rows])
        if {"t", "speed"} <= cols:
            v = np.array([float(r["speed"]) for r in rows])
        elif {"t", "left_ticks", "right_ticks"} <= cols:
            v = speeds_from_ticks(
                t,
                np.array([float(r["left_ticks"]) for r in rows]),
                np.array([float(r["right_ticks"]) for r in rows]),
                args.ticks_per_m,
            )
        else:
            raise ValueError(
                f"{args.log}: the header must name t,speed or t,left_ticks,right_ticks; it has {sorted(cols)}"
            )
        fit = fit_motor(t, v, period_s=args.period_ms / 1000.0)
    except (OSError, ValueError, KeyError) as e:
        print(f"iwz calibrate: {e}")
        return 2
    t0 = t - t[0]
    print(f"MaxSpeed = {fit.max_speed_mps:.3f} m/s")
    print(f"AccelerationCurve = {fit.curve:.3f} (for {args.period_ms:g} ms ticks)")
    logged = rise_time_of(t0, v, fit.max_speed_mps)
    modelled = rise_time_of(t0, fit.speed(t0), fit.max_speed_mps)
    print(f"rise time 10-90 %: log {logged:.2f} s, model {modelled:.2f} s")
    return 0
