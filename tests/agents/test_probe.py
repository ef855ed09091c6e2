"""The benchmarks' probe chair: latencies recorded, creeping back and forth without pushing on."""

from __future__ import annotations

from pathlib import Path

from agents.probe import CONES_4M, Probe
from iw_zenoh.messages import SensorReading


def _reading(near: dict[int, float], tick_wall_ns: int = 0) -> SensorReading:
    ids = [s.id for s in CONES_4M]
    return SensorReading(
        tick=1,
        robot_id=1,
        proximity_ids=ids,
        proximity_m=[near.get(i) for i in ids],
        proximity_legacy=[0.0] * len(ids),
        compass_deg=0.0,
        gps=(0.0, 0.0, 0.0),
        tick_wall_ns=tick_wall_ns,
    )


def test_the_probe_creeps_the_other_way_when_something_is_near_where_it_goes() -> None:
    front = next(s.id for s in CONES_4M if s.angle_deg == 0.0)
    rear = next(s.id for s in CONES_4M if abs(s.angle_deg) == 180.0)
    p = Probe("p", 0.02, [], avoid_m=0.3)
    assert p.on_sensors(_reading({}), []).left == 0.02
    assert p.on_sensors(_reading({rear: 0.1}), []).left == 0.02  # behind it: no matter going ahead
    assert p.on_sensors(_reading({front: 0.2}), []).left == -0.02
    assert p.on_sensors(_reading({front: 0.2}), []).left == -0.02  # backing away
    assert p.on_sensors(_reading({rear: 0.25}), []).right == 0.02
    pushing = Probe("q", 0.02, [])
    assert pushing.on_sensors(_reading({front: 0.01}), []).left == 0.02


def test_the_probe_records_how_late_each_reading_is() -> None:
    sink: list[int] = []
    Probe("p", 0.0, sink).on_sensors(_reading({}, tick_wall_ns=1), [])
    assert len(sink) == 1
    assert sink[0] > 0


def test_a_probe_keeps_no_latencies_unless_asked(tmp_path: Path) -> None:
    # the 1,000-chair soak found each 250-chair probe host growing 42 MB in 6,000 ticks: every
    # reading's latency was kept though nobody had asked for them (--latency-out)
    import argparse

    from agents.probe import add_arguments, make

    p = argparse.ArgumentParser()
    add_arguments(p)
    probes = make(p.parse_args(["--count", "2"]))
    for probe in probes:
        probe.on_sensors(_reading({}, tick_wall_ns=1), [])
        assert probe.sink is None
    kept = make(p.parse_args(["--count", "2", "--latency-out", str(tmp_path / "lat.txt")]))
    kept[0].on_sensors(_reading({}, tick_wall_ns=1), [])
    assert kept[0].sink is not None
    assert len(kept[0].sink) == 1
    assert kept[1].sink is kept[0].sink
