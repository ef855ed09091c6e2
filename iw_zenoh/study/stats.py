"""A study's figures: each measure over the runs of a condition, its mean, spread and 95 %
interval (pure: rows in, numbers out).

The interval is Student's: ``mean +- t(0.975, n - 1) * std / sqrt(n)``, ``std`` the sample
standard deviation (``n - 1``); with one run it is the value itself, with none the measure is left
out. A measure that is missing (``None``: a chair that never reached its goal has no time to goal)
in some runs is taken over the runs that have it, and ``n`` says how many.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["Summary", "describe", "summarize", "t975"]

Summary = dict[str, Any]

# Student's t, two-sided 95 % (the 0.975 quantile), by degrees of freedom: the published table
# (scipy.stats.t.ppf(0.975, df) to three decimals); between rows it is interpolated in 1/df,
# past the last it is the normal's 1.960
_T975 = {
    1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262,
    10: 2.228, 11: 2.201, 12: 2.179, 13: 2.160, 14: 2.145, 15: 2.131, 16: 2.120, 17: 2.110,
    18: 2.101, 19: 2.093, 20: 2.086, 21: 2.080, 22: 2.074, 23: 2.069, 24: 2.064, 25: 2.060,
    26: 2.056, 27: 2.052, 28: 2.048, 29: 2.045, 30: 2.042, 40: 2.021, 60: 2.000, 120: 1.980,
}  # fmt: skip
_Z975 = 1.960


def t975(df: int) -> float:
    """Student's t 0.975 quantile for ``df`` >= 1 degrees of freedom (see :data:`_T975`)."""
    if df in _T975:
        return _T975[df]
    rows = sorted(_T975)
    if df > rows[-1]:
        lo_df, lo_t, hi_inv, hi_t = rows[-1], _T975[rows[-1]], 0.0, _Z975
    else:
        lo_df = max(r for r in rows if r < df)
        hi_df = min(r for r in rows if r > df)
        lo_t, hi_inv, hi_t = _T975[lo_df], 1.0 / hi_df, _T975[hi_df]
    f = (1.0 / lo_df - 1.0 / df) / (1.0 / lo_df - hi_inv)
    return lo_t + f * (hi_t - lo_t)


def describe(values: Iterable[float | int | None]) -> Summary | None:
    """``n, mean, std, min, max, ci95`` of the values given (``None`` left out); None when none."""
    v = np.asarray([float(x) for x in values if x is not None and not isinstance(x, bool)], dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    mean = float(v.mean())
    std = float(v.std(ddof=1)) if v.size > 1 else 0.0
    half = t975(v.size - 1) * std / math.sqrt(v.size) if v.size > 1 else 0.0
    return {
        "n": int(v.size),
        "mean": mean,
        "std": std,
        "min": float(v.min()),
        "max": float(v.max()),
        "ci95": [mean - half, mean + half],
    }


def _numeric(d: Mapping[str, Any]) -> list[str]:
    return [k for k, v in d.items() if v is None or (isinstance(v, int | float) and not isinstance(v, bool))]


def _measures(dicts: Sequence[Mapping[str, Any]]) -> dict[str, Summary]:
    """Each numeric field of the dicts (in the first one's order) described over all of them."""
    names: list[str] = []
    for d in dicts:
        names += [k for k in _numeric(d) if k not in names]
    out: dict[str, Summary] = {}
    for k in names:
        s = describe(d.get(k) for d in dicts)
        if s is not None:
            out[k] = s
    return out


def _without_id(chair: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in chair.items() if k != "robot_id"}


def summarize(rows: Sequence[Mapping[str, Any]]) -> Summary:
    """One condition's figures from its rows (``iwz study``'s runs: ``status``, ``criteria_met``,
    ``report`` as ``iwz report --json`` gives a run).

    Returns:
        ``runs`` (measured), ``failed``, ``criteria_met`` (runs whose criteria all held), ``run``
        (each run measure described), ``chairs`` (by robot id: its ``name``, the ``runs`` it
        was in, how many of them it ``reached`` its goal in, and each chair measure described,
        ``measures``) and ``duration_s``.
    """
    ok = [r for r in rows if r.get("status") == "ok" and r.get("report")]
    reports = [r["report"] for r in ok]
    chairs: dict[str, list[Mapping[str, Any]]] = {}
    for rep in reports:
        for c in rep["chairs"]:
            chairs.setdefault(str(c["robot_id"]), []).append(c)
    return {
        "runs": len(ok),
        "failed": len(rows) - len(ok),
        "criteria_met": sum(1 for r in ok if r.get("criteria_met")),
        "duration_s": describe(rep["duration_s"] for rep in reports),
        "run": _measures([rep["run"] for rep in reports]),
        "chairs": {
            rid: {
                "name": cs[0].get("name", ""),
                "runs": len(cs),
                "reached": sum(1 for c in cs if c.get("time_to_goal_s") is not None),
                "measures": _measures([_without_id(c) for c in cs]),
            }
            for rid, cs in sorted(chairs.items(), key=lambda kv: int(kv[0]))
        },
    }
