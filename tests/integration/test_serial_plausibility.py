"""A broken chair board on a real pseudo-terminal (issue 33): the test is the board, writing Status
frames at 20 Hz to the serial bridge, and the chair's agent, commanding robot 1 all along. Its
encoder counts then jump 2^31-1 a frame (they wrapped the odometry 1,074 km a frame until a pose
report out of range ended the bridge), then its battery reads 0 V. Each is refused with a
``bad-message`` event (one a second, counted), the odometry never jumps, the chair is held (zero
powers) while it persists and driven again once the board is plausible, and the bridge stays up.
"""

from __future__ import annotations

import os
import select
import threading
import time
import tty
from collections.abc import Callable

import pytest

from bridges.serial.protocol import FrameDecoder, Motors, Status, encode_frame
from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.messages import Actions, ChairReading, Event, EventKind, decode, encode
from tests.integration.harness import Net, subscribe, wait_msg
from tests.integration.serial_sim import start_sim

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(150)]

POWER = 0.1  # the agent's command: 1000 power units on both wheels
CREEP_MPS = 0.1  # the good board's counts: 10 a frame at 20 Hz, 2,000 a metre (maps/chair.toml)


class Board:
    """The chair's board on the master side of a pty: Status at 20 Hz in one of three modes, and
    every Motors frame the bridge sends, with its monotonic time."""

    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.mode = "good"
        self.motors: list[tuple[float, Motors]] = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            self._serve()
        except OSError:  # closed by close() under this thread: the test is over
            if not self.stop.is_set():
                raise

    def _serve(self) -> None:
        counts, seq, decoder = [0, 0], 0, FrameDecoder()
        while not self.stop.is_set():
            if self.mode == "wrap":  # a jump of 2^31-1 a frame, wrapping the int32 counts
                counts = [(c + 2**31 - 1 + 2**31) % 2**32 - 2**31 for c in counts]
            else:
                counts = [c + 10 for c in counts]  # 5 mm a frame: a chair creeping
            battery = 0 if self.mode == "dead" else 25_000
            status = Status(ack=0, encoders=(counts[0], counts[1]), wheels=(0, 0), battery_mv=battery)
            os.write(self.master, encode_frame(status, seq))
            seq += 1
            end = time.monotonic() + 0.05
            while (left := end - time.monotonic()) > 0:
                ready, _, _ = select.select([self.master], [], [], left)
                if ready:
                    for f in decoder.feed(os.read(self.master, 4096)):
                        if isinstance(f.msg, Motors):
                            self.motors.append((time.monotonic(), f.msg))

    def frames_since(self, t: float) -> int:
        """How many motor frames came since ``t``."""
        return sum(1 for s, _ in list(self.motors) if s >= t)

    def driven_since(self, t: float) -> set[tuple[int, int]]:
        """The powers sent since ``t``."""
        return {(m.left, m.right) for s, m in list(self.motors) if s >= t}

    def close(self) -> None:
        self.stop.set()
        self.thread.join(10)
        os.close(self.master)
        os.close(self.slave)


def _until(cond: object, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not cond():  # type: ignore[operator]
        assert time.monotonic() < deadline, what
        time.sleep(0.05)  # polling the board's record of what it was sent: no event to wait on


def _refusal(says: str) -> Callable[[Event], bool]:
    return lambda e: e.kind == EventKind.BAD_MESSAGE and says in e.reason


def _refusals(box: Inbox) -> list[Event]:
    out = []
    for d in box.drain():
        ev = decode(d[1], Event)
        if ev.kind == EventKind.BAD_MESSAGE and ev.key.endswith("/robot/1/chair"):
            out.append(ev)
    return out


def test_wrapping_encoders_and_a_dead_battery_are_refused_hold_the_chair_and_never_end_the_bridge(net: Net) -> None:
    board, stop = Board(), threading.Event()
    driver: threading.Thread | None = None
    try:
        bus = start_sim(net, board.path)
        bridge = net.procs[-1]
        events = subscribe(bus, keys.all_events(net.sim))
        chairs = subscribe(bus, keys.chair(net.sim, 1), maxlen=1)

        def agent() -> None:
            while not stop.is_set():
                bus.publish(keys.actions(net.sim, 1), encode(Actions(robot_id=1, left=POWER, right=POWER)))
                stop.wait(0.05)  # an agent's pace

        driver = threading.Thread(target=agent, daemon=True)
        driver.start()
        _until(lambda: (1000, 1000) in board.driven_since(0), 60, "the bridge never drove the chair")
        start = wait_msg(chairs, ChairReading, lambda r: r.link == "up").pose
        since = time.monotonic()

        for mode, says in (("wrap", "encoder step of"), ("dead", "battery 0 V")):
            board.mode = mode
            t0 = time.monotonic()
            ev = wait_msg(events, Event, _refusal(says), 20)
            assert ev.robot_id == 1, ev
            _until(lambda t=t0: (0, 0) in board.driven_since(t + 1.0), 10, f"{mode}: the chair was not held")
            held = time.monotonic()
            # 20 frames watched while held (a second at the bridge's 20 Hz): every one at zero powers
            _until(lambda h=held: board.frames_since(h) >= 20, 10, f"{mode}: the bridge sent no frames")
            assert board.driven_since(held) == {(0, 0)}, f"{mode}: driven while held"
            assert bridge.popen.poll() is None, bridge.output()
            board.mode = "good"
            t1 = time.monotonic()
            _until(lambda t=t1: (1000, 1000) in board.driven_since(t), 10, f"{mode}: not driven again once plausible")

        pose = wait_msg(chairs, ChairReading, lambda r: r.link == "up").pose
        # no jump of kilometres: a metre, and the creep of the good board meanwhile (a loaded machine
        # takes longer over the two faults; x and y apart, a straight creep is at most 1.5 times it)
        crept = CREEP_MPS * (time.monotonic() - since)
        assert abs(pose[0] - start[0]) + abs(pose[1] - start[1]) < 1.0 + 1.5 * crept, (start, pose, crept)
        refusals = _refusals(events)
        assert len(refusals) < 30, [e.reason for e in refusals]  # one per reason a second, not one a frame
        assert bridge.popen.poll() is None, bridge.output()
    finally:
        stop.set()
        if driver is not None:
            driver.join(2)
        board.close()
