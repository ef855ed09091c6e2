"""RefusalLimiter: one report per source and reason a second, with the count of the rest; bounded
memory and reports however many sources flood."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.bus.refusals import PERIOD_NS, RefusalLimiter, counted

S = PERIOD_NS


def test_the_first_refusal_is_reported_and_the_rest_of_its_second_counted_into_the_next_report() -> None:
    lim = RefusalLimiter()
    assert lim.admit("k", "malformed", 0) == 1
    assert [lim.admit("k", "malformed", t) for t in range(1, 1000)] == [0] * 999
    assert lim.admit("k", "not-own", 5) == 1  # another reason is reported on its own
    assert lim.admit("k", "malformed", S) == 1000  # this one and the 999 counted
    assert lim.due(3 * S) == []


def test_counted_refusals_are_due_once_their_second_is_over_when_nothing_more_comes() -> None:
    lim = RefusalLimiter()
    lim.admit("k", "malformed", 0)
    lim.admit("k", "malformed", 1, "bad json")
    lim.admit("k", "malformed", 2, "bad json")
    assert lim.due(S - 1) == []
    assert lim.due(S) == [("k", "malformed", 2, "bad json")]
    assert lim.due(2 * S) == []


def test_many_sources_cost_bounded_reports_and_memory() -> None:
    lim = RefusalLimiter(kept=100, reports_per_period=10)
    reports = sum(1 for k in range(10_000) if lim.admit(f"robot/{k}/actions", "unknown-robot", k))
    assert reports == 10
    assert len(lim._pending) <= 100
    due = lim.due(2 * S)
    assert sum(n for *_, n, _ in due) == 10_000 - 10  # none lost: counted under "*"


@given(st.lists(st.tuples(st.sampled_from("abc"), st.sampled_from("xy"), st.integers(0, 10 * S)), max_size=200))
def test_every_refusal_is_reported_once_in_a_count_and_each_pair_at_most_once_a_second(
    refusals: list[tuple[str, str, int]],
) -> None:
    lim = RefusalLimiter()
    total, last = 0, dict[tuple[str, str], int]()
    for src, why, t in sorted(refusals, key=lambda r: r[2]):
        n = lim.admit(src, why, t)
        if n:
            assert t - last.get((src, why), -S) >= S
            last[src, why] = t
        total += n
    total += sum(n for *_, n, _ in lim.due(20 * S))
    assert total == len(refusals)


def test_a_report_says_how_many_it_stands_for() -> None:
    assert counted("bad", 1) == "bad"
    assert counted("bad", 3) == "bad (and 2 more like it on this key since the last report)"


def test_pairs_forgotten_to_bound_memory_keep_their_counts_not_reported() -> None:
    lim = RefusalLimiter(kept=4)
    reported = sum(lim.admit(f"k{i}", "malformed", 0) + lim.admit(f"k{i}", "malformed", 1) for i in range(10))
    assert len(lim._pending) <= 4 + 1  # the pairs kept, and ("*", reason) the forgotten counts went to
    assert reported + sum(n for *_, n, _ in lim.due(2 * S)) == 20


def test_threads_sharing_a_limiter_lose_no_count_and_raise_nothing() -> None:
    # the serial bridge's thread refuses while the main thread's host does and flushes: due()
    # iterated the dict another thread grew (RuntimeError, killing the serial thread)
    import sys
    import threading

    lim = RefusalLimiter(kept=64, reports_per_period=1_000_000)
    threads, per = 4, 5_000
    go, errors, totals = threading.Barrier(threads + 1), list[BaseException](), [0] * (threads + 1)

    def refuse(t: int) -> None:
        go.wait()
        try:
            totals[t] = sum(lim.admit(f"k{t}-{i % 300}", "malformed", i) for i in range(per))
        except BaseException as e:  # noqa: BLE001 - the test reports any
            errors.append(e)

    def flush() -> None:
        go.wait()
        try:
            while any(th.is_alive() for th in workers):
                totals[threads] += sum(n for *_, n, _ in lim.due(10 * S))
        except BaseException as e:  # noqa: BLE001
            errors.append(e)

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # threads switch as often as they can: the interleavings come
    try:
        workers = [threading.Thread(target=refuse, args=(t,)) for t in range(threads)]
        flusher = threading.Thread(target=flush)
        for th in [*workers, flusher]:
            th.start()
        for th in [*workers, flusher]:
            th.join(60)
    finally:
        sys.setswitchinterval(old)
    assert errors == []
    assert sum(totals) + sum(n for *_, n, _ in lim.due(100 * S)) == threads * per
