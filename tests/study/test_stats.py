"""A study's figures: mean, sample spread and Student's 95 % interval of each measure, missing
values left out, counts of runs, failures and goals reached."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.study.cli import parse_seeds
from iw_zenoh.study.stats import describe, summarize, t975


def test_t_quantiles_are_students() -> None:
    assert t975(1) == 12.706
    assert t975(4) == 2.776
    assert t975(35) == pytest.approx(2.030, abs=0.002)  # between the table's 30 and 40
    assert t975(10_000) == pytest.approx(1.960, abs=0.001)


def test_describe_gives_mean_spread_and_the_95_percent_interval() -> None:
    s = describe([1.0, 2.0, 3.0, None, 4.0, 5.0])
    assert s is not None
    assert s["n"] == 5
    assert s["mean"] == 3.0
    assert s["std"] == pytest.approx(math.sqrt(2.5))
    half = 2.776 * math.sqrt(2.5) / math.sqrt(5)
    assert s["ci95"] == pytest.approx([3.0 - half, 3.0 + half])
    assert (s["min"], s["max"]) == (1.0, 5.0)
    assert describe([None, None]) is None
    assert describe([7])["ci95"] == [7.0, 7.0]  # type: ignore[index]


@given(st.lists(st.floats(-1e6, 1e6) | st.none(), max_size=30))
def test_the_interval_holds_the_mean(values: list[float | None]) -> None:
    s = describe(values)
    if s is None:
        assert all(v is None for v in values)
        return
    assert s["ci95"][0] <= s["mean"] + 1e-6 * max(1.0, abs(s["mean"]))
    assert s["mean"] <= s["ci95"][1] + 1e-6 * max(1.0, abs(s["mean"]))
    assert np.isfinite(s["std"])


def _row(seed: int, status: str = "ok", reached: float | None = 3.0) -> dict[str, object]:
    chair = {"robot_id": 1, "name": "c", "time_to_goal_s": reached, "collisions": seed}
    report = {
        "duration_s": 5.0,
        "ticks": 50,
        "run": {"collisions": seed, "goals_reached": int(reached is not None)},
        "chairs": [chair],
    }
    return {
        "condition": "a",
        "seed": seed,
        "status": status,
        "criteria_met": reached is not None,
        "report": report if status == "ok" else None,
    }


def test_summarize_counts_runs_failures_and_goals() -> None:
    s = summarize([_row(1), _row(2, reached=None), _row(3, status="failed")])
    assert (s["runs"], s["failed"], s["criteria_met"]) == (2, 1, 1)
    assert s["run"]["collisions"]["mean"] == 1.5
    chair = s["chairs"]["1"]
    assert (chair["runs"], chair["reached"]) == (2, 1)
    assert chair["measures"]["time_to_goal_s"]["n"] == 1


@pytest.mark.parametrize(("text", "seeds"), [("1-5", [1, 2, 3, 4, 5]), ("3,7,9", [3, 7, 9]), ("1-3,2,8", [1, 2, 3, 8])])
def test_seeds_are_ranges_and_lists(text: str, seeds: list[int]) -> None:
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize("text", ["", "a-b", "5-1", "-3", "1-1000000"])
def test_seeds_not_of_the_form_are_refused(text: str) -> None:
    with pytest.raises(ValueError, match="--seeds"):
        parse_seeds(text)
