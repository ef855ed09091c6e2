"""The viewer's sources: a page's commands become world controls; a recording plays in-process,
holds at its end, and seeks back."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.messages import Control, Obstacle, WorldState, decode
from iw_zenoh.messages.page import PageCommand, PageFrame, PageTimeline
from iw_zenoh.record.reader import open_recording
from iw_zenoh.viewer.feed import Feed
from iw_zenoh.viewer.sources import LiveSource, LocalBus, ReplaySource

SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "demo-sample.mcap"


def test_a_live_source_publishes_the_pages_controls_on_the_control_key_and_refuses_replay_commands() -> None:
    control = Inbox()
    bus = LocalBus(Inbox())
    bus.subscribe(keys.control("s"), control)
    source = LiveSource(bus, "s", threading.Event())
    ob = Obstacle(name="b", x0=1, y0=1, x1=2, y1=2)
    assert source.command(PageCommand(cmd="step", steps=3)) == ""
    assert source.command(PageCommand(cmd="add_obstacle", obstacle=ob)) == ""
    assert source.command(PageCommand(cmd="remove", robot_id=7)) == ""
    assert "obstacle" in source.command(PageCommand(cmd="move_obstacle"))
    assert "replays" in source.command(PageCommand(cmd="seek", at_ns=5))
    sent = [decode(d[1], Control) for d in control.drain()]
    assert [(c.command, c.steps, c.robot_id, c.obstacle) for c in sent] == [
        ("step", 3, 0, None),
        ("add_obstacle", 1, 0, ob),
        ("remove", 1, 7, None),
    ]


def _until(source: ReplaySource, feed: Feed, done: object, timeout_s: float = 30.0) -> list[object]:
    """Polls the source (as the pump does) until ``done(messages so far)``."""
    out: list[object] = []
    deadline = time.monotonic() + timeout_s
    while not done(out):  # type: ignore[operator]
        assert time.monotonic() < deadline, f"not done within {timeout_s} s; last: {out[-3:]}"
        source.inbox.wait(0.05)
        out += source.poll(feed, time.time_ns())
    return out


def test_a_replay_plays_to_its_end_holds_there_and_seeks_back_to_show_that_moment() -> None:
    with open_recording(SAMPLE) as rec:
        states = [r.message for r in rec.records(("state",)) if isinstance(r.message, WorldState)]
    source = ReplaySource(SAMPLE, threading.Event(), rate=0)
    try:
        feed = Feed(source.sim)
        source.command(PageCommand(cmd="start"))  # a replay starts paused
        [timeline] = source.extra()
        assert isinstance(timeline, PageTimeline)
        assert timeline.marks
        assert timeline.start_ns == states[0].sim_time_ns
        assert states[-10].sim_time_ns < timeline.end_ns <= states[-1].sim_time_ns
        # at its end, and its last state shown (the player reaches the end before the pump's
        # next poll has taken the last states from the inbox: wait for both, as a page would)
        _until(
            source,
            feed,
            lambda _: source.player.at_end and feed.state is not None and feed.state.tick >= states[-1].tick,
        )
        assert feed.state is not None
        assert feed.state.tick == states[-1].tick
        want = states[len(states) // 2]
        assert source.command(PageCommand(cmd="seek", at_ns=want.sim_time_ns)) == ""
        frames = _until(source, feed, lambda out: any(isinstance(m, PageFrame) for m in out))
        [frame] = [m for m in frames if isinstance(m, PageFrame)]
        assert frame.tick == want.tick
        assert frame.x == pytest.approx(want.x, abs=1e-4)
        assert "recording" in source.command(PageCommand(cmd="remove", robot_id=1))
    finally:
        source.close()


def test_a_replays_timeline_ends_at_the_last_state_and_seeking_there_shows_it() -> None:
    # the sample's recorder indexed one state a simulated second, not its last: its last 0.2 s
    # were missing from the timeline
    with open_recording(SAMPLE) as rec:
        states = [r.message for r in rec.records(("state",)) if isinstance(r.message, WorldState)]
    source = ReplaySource(SAMPLE, threading.Event(), rate=1)
    try:
        feed = Feed(source.sim)
        source.command(PageCommand(cmd="pause"))
        _until(source, feed, lambda _: source.player.paused)  # (the player takes it in its own thread)
        [timeline] = source.extra()
        assert isinstance(timeline, PageTimeline)
        assert timeline.end_ns == states[-1].sim_time_ns
        source.command(PageCommand(cmd="seek", at_ns=timeline.end_ns))
        # (the player moves its position just after publishing the state: wait for both)
        _until(
            source,
            feed,
            lambda _: (
                feed.state is not None
                and feed.state.tick == states[-1].tick
                and source.timeline().position_ns == states[-1].sim_time_ns
            ),
        )
        assert feed.state is not None
        assert feed.state.x == pytest.approx(states[-1].x)
        assert source.timeline().position_ns == states[-1].sim_time_ns
    finally:
        source.close()


def test_a_replay_starts_paused_showing_its_first_state_and_a_step_shows_the_next() -> None:
    # a replay opened in the page used to play at once: a person saw it already under way
    with open_recording(SAMPLE) as rec:
        states = [r.message for r in rec.records(("state",)) if isinstance(r.message, WorldState)]
    source = ReplaySource(SAMPLE, threading.Event(), rate=0)  # as fast as it goes, once started
    try:
        feed = Feed(source.sim)
        _until(source, feed, lambda _: feed.state is not None and source.player.steps == 0)
        assert feed.state is not None
        assert feed.state.tick == states[0].tick
        timeline = source.timeline()
        assert not timeline.playing
        assert timeline.position_ns == timeline.start_ns == states[0].sim_time_ns
        source.command(PageCommand(cmd="step"))
        _until(source, feed, lambda _: feed.state is not None and feed.state.tick != states[0].tick)
        assert feed.state.tick == states[1].tick
        assert not source.timeline().playing
    finally:
        source.close()
