"""The bridge's pacer: Measures at a steady offset from the tick's start, learned from arrivals."""

from __future__ import annotations

from bridges.ciberrato.pacing import Pacer

MS = 1_000_000
PERIOD = 50 * MS


def test_the_offset_covers_nearly_every_recent_arrival_plus_a_margin() -> None:
    p = Pacer(PERIOD, window=100, quantile=0.98, margin_ns=2 * MS, every=10)
    assert p.offset_ns is None
    for k in range(100):
        p.observe((10 + k % 10) * MS)  # 10..19 ms after the tick began
    assert p.offset_ns == 21 * MS  # the 98th percentile (19) + 2
    assert p.due_ns(1_000 * MS) == 1_021 * MS


def test_the_offset_moves_only_every_few_ticks() -> None:
    p = Pacer(PERIOD, window=100, every=10)
    p.observe(10 * MS)
    first = p.offset_ns
    for _ in range(8):
        p.observe(30 * MS)
    assert p.offset_ns == first  # one step every ten arrivals, not at each
    p.observe(30 * MS)
    assert p.offset_ns is not None
    assert first is not None
    assert p.offset_ns > first


def test_agents_keep_the_rest_of_the_cycle_whatever_the_delays() -> None:
    p = Pacer(PERIOD, cap=0.7, every=1)
    for _ in range(50):
        p.observe(45 * MS)
    assert p.offset_ns == 35 * MS  # never later than 70 % of the period: late readings go at once


def test_start_up_stalls_and_clock_skew_are_not_learned() -> None:
    p = Pacer(PERIOD, every=1)
    p.observe(12 * MS)
    for bad in (3_000 * MS, 101 * MS, -5 * MS):  # registration stalls, a clock behind
        p.observe(bad)
    assert p.offset_ns == 14 * MS
