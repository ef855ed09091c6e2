"""The launcher's verdict on hostile states: a malformed, inconsistent, non-ASCII, non-finite or
huge state among a burst of good ones is skipped, nothing raises, and the good ones are each
judged (the goal at the state that reached it). That the launcher is given every state, not the
newest, is tests/integration/test_verdict_every_state.py's, through a real run."""

from __future__ import annotations

from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.bus.net import free_port
from iw_zenoh.launch.launcher import STATES_KEPT, Launcher
from iw_zenoh.messages import WorldState, encode
from iw_zenoh.scenario.file import load_scenario

SCENARIO = """
name = "judged"
[world]
map = "lab.xml"
mode = "lockstep"
[[agents]]
program = "waypoint"
args = ["--id", "1", "--waypoints", "9,5"]
[[criteria.reach]]
robot = 1
x = 9.0
y = 5.0
within = 0.5
"""


def _state(tick: int, x: float) -> bytes:
    return encode(
        WorldState(
            tick=tick,
            sim_time_ns=tick * 100_000_000,
            revision=1,
            ids=[1],
            x=[x],
            y=[5.0],
            heading=[0.0],
            collided=[False],
            rolled_left=[0.0],
            rolled_right=[0.0],
            speed=[0.0],
        )
    )


@pytest.fixture
def launcher(tmp_path: Path) -> Launcher:
    (tmp_path / "lab.xml").write_text('<Lab Name="open" Width="20" Height="10"/>')
    (tmp_path / "judged.toml").write_text(SCENARIO)
    sc = load_scenario(tmp_path / "judged.toml")
    return Launcher(sc, port=free_port(), sim="judged", log_dir=tmp_path / "logs", status=False, record=None)


def test_bad_states_among_good_ones_are_skipped_and_the_good_ones_judged(launcher: Launcher) -> None:
    key = keys.state("judged")
    states = Inbox(maxlen=STATES_KEPT)
    hostile = [
        b"not json",
        b'{"tick": "\xc3\xa9"}',  # non-ASCII where a number goes
        _state(5, 1.0).replace(b'"x":[1.0]', b'"x":[1.0,2.0]'),  # two x for one robot
        _state(6, 1.0).replace(b'"x":[1.0]', b'"x":[NaN]'),
        b"[" * 100_000,  # huge and deep
    ]
    for d in hostile:
        states.put((key, d, 0))
    # the chair drives through its goal between ticks 40 and 44, and on past it
    for tick in range(1, 81):
        states.put((key, _state(tick, 3.0 + 0.15 * tick), 0))
    launcher._update(states, Inbox(), Inbox())
    assert launcher.tally.tick == 80
    assert launcher.tally.reached == {1: pytest.approx(3.7)}  # tick 37: x = 8.55, the first within 0.5 m
    ok, lines = launcher.tally.verdict(launcher.sc.criteria)
    assert ok, lines
