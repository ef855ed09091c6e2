"""Every role reports the refusals it counted, whatever its loop: start_role runs a thread that
flushes them each second, and a last time when the role stops (a flood that stopped is said)."""

from __future__ import annotations

import time

import pytest

from iw_zenoh.errors import DecodeError
from iw_zenoh.messages import Event, decode
from iw_zenoh.process import runtime
from tests.bridges.fakes import FakeBus


def _counts(bus: FakeBus) -> list[int]:
    out = []
    for key, data in bus.published:
        if "/events/" in key:
            out.append(int(decode(data, Event).data.get("count", 1)))
    return out


def test_a_role_that_never_flushes_still_reports_its_counted_refusals(monkeypatch: pytest.MonkeyPatch) -> None:
    bus = FakeBus()
    monkeypatch.setattr(runtime, "ZenohBus", lambda net: bus)

    def run(proc: runtime.Process) -> int:  # an agent, sensors, iwz ros2...: bad_message only
        for _ in range(100):
            proc.io.bad_message("iw/s/robot/1/sensors", DecodeError("malformed"))
        return 0

    assert runtime.start_role(["--sim", "s"], role="sensors", description="test", run=run) == 0
    assert sorted(_counts(bus)) == [1, 99]  # the first at once, the 99 counted said as the role stopped


def test_the_reporting_thread_says_counts_each_period() -> None:
    bus = FakeBus()
    io = runtime.NodeIO(bus, "s", "sensors", "n")
    io.refusals.period_ns = 1  # every count is due at once
    for _ in range(2):
        io.bad_message("k", DecodeError("malformed"))
    io.refusals.admit("k", "DecodeError", 0)  # one counted, its period long over
    stop = io.report_refusals(every_s=0.01)
    try:
        deadline = time.monotonic() + 10
        while sum(_counts(bus)) < 3 and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        stop()
    assert sum(_counts(bus)) == 3
