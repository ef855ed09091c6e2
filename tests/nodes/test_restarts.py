from __future__ import annotations

from pathlib import Path

from iw_zenoh.nodes.child import Child
from iw_zenoh.nodes.restarts import BACKOFF_S, Restarts


def _child(role: str, name: str = "", token: str = "") -> Child:
    return Child(role, name or role, ["x"], Path("x.log"), token=token)


def test_every_role_but_the_recorder_is_restarted_unless_it_finished_by_itself() -> None:
    r = Restarts()
    for role in ("router", "world", "collision", "sensors", "radio", "bridge", "agent"):
        assert r.restartable(_child(role), -9)
    assert not r.restartable(_child("record"), -9)
    assert not r.restartable(_child("world"), 0)  # its duration reached: the run is over
    assert not r.restartable(_child("agent"), 0)
    assert r.restartable(_child("collision"), 0)


def test_restarts_wait_longer_each_time_and_report_the_time_to_recover() -> None:
    r = Restarts()
    c = _child("sensors", "sensors-1", token="sensors-1-1")
    assert r.due(c, 10.0)  # the first at once
    r.restarted(c)
    assert r.on_alive([c], "sensors", "sensors-2-2", 10.2) == ""  # another shard's token
    assert "sensors-1 is back 0.40 s" in r.on_alive([c], "sensors", "sensors-1-1", 10.4)
    assert list(r.recovered) == ["sensors-1"]
    assert abs(r.recovered["sensors-1"][0] - 0.4) < 1e-9
    assert not r.due(c, 20.0)  # found dead again: the second waits
    assert r.due(c, 20.0 + BACKOFF_S[1])
