"""One legacy robot's state as the Ciber-Rato server keeps it, pure: its motors and LEDs from its
Actions, the sensors it asked for this cycle (the request rules), its sensors' latency queues,
what it heard, its game, and the Measures it is sent.

No sockets, no bus, no clock: the bridge's node feeds it datagrams' frames, the world's readings
and the simulator's state, and sends what it returns.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field
from typing import Any

from iw_zenoh.agent.hosting import Command
from iw_zenoh.core.params import SimParameters
from iw_zenoh.messages import SensorReading

from .codec import ActionsFrame, Measures, Score, build_measures
from .scoring import RobotGame, StepInput

__all__ = ["GPS_OFFSET", "NO_MEASUREMENT", "LegacyRobot"]

GPS_OFFSET = (840.1877, 394.3829)  # the legacy simulator's GPS origin on glibc, until a reset
NO_MEASUREMENT: dict[str, Any] = {"ir": 0.0, "compass": 0.0, "ground": -1, "collision": False, "beacon": None}


def _round_half_away(b: float) -> float:
    """A beacon's direction rounded as the legacy server prints it (half away from zero)."""
    return float(int(b + 0.5 if b >= 0 else b - 0.5))


@dataclass
class LegacyRobot:
    """A legacy robot's state between datagrams.

    Attributes:
        robot_id: Its id in the world.
        name: Its registered name.
        n_beacons: Beacon sensors it has: the beacons there were when it registered (legacy).
        start: Its grid position.
        left: Left motor power it last asked for.
        right: Right motor power.
        leds: Its LEDs, as last set.
        reading: Its newest readings from the world.
        heard: What it heard, by tick: each tick's goes in that tick's Measures.
        missed: Messages heard for a tick whose Measures had gone already (never sent a cycle late).
        sent_tick: The tick of the last Measures it was sent.
        requests: Sensor requests of this cycle, in order.
        finished: EndLed seen (or the game says Finished): the robot never moves again.
        game: Its legacy state machine and score.
        returning_now: A ReturningLed="On" arrived this cycle.
        pose: Its last committed centre.
        fifos: Its sensors' latency queues.
    """

    robot_id: int
    name: str = ""
    n_beacons: int = 0
    start: tuple[float, float] = (0.0, 0.0)
    left: float = 0.0
    right: float = 0.0
    leds: dict[str, bool] = field(default_factory=dict)
    reading: SensorReading | None = None
    heard: dict[int, list[tuple[int, str]]] = field(default_factory=dict)
    missed: int = 0
    sent_tick: int = -1
    requests: list[str] = field(default_factory=list)
    finished: bool = False
    game: RobotGame | None = None
    returning_now: bool = False
    pose: tuple[float, float] = (0.0, 0.0)
    fifos: dict[str, collections.deque[Any]] = field(default_factory=dict)

    def on_actions(self, frame: ActionsFrame, *, sim_finished: bool = False) -> Command:
        """Takes one Actions datagram: motors and LEDs given are kept, requests are added to the
        cycle's; a Finished robot (or any, once the simulation is finished) never moves again.

        Args:
            frame: The parsed datagram.
            sim_finished: Whether the simulator's Time has reached SimTime.

        Returns:
            The robot's command now (its radio message and pose report, if the datagram had any).
        """
        self.requests += list(frame.requests)
        self.left = frame.left if frame.left is not None else self.left
        self.right = frame.right if frame.right is not None else self.right
        self.leds.update(frame.leds)
        if frame.leds.get("ReturningLed"):
            self.returning_now = True
        if self.leds.get("EndLed"):
            self.finished = True
        if self.finished or sim_finished:
            self.left = self.right = 0.0
        return Command(
            self.left,
            self.right,
            say=frame.say,
            end_led=self.leds.get("EndLed", False),
            returning_led=self.leds.get("ReturningLed", False),
            visiting_led=self.leds.get("VisitingLed", False),
            pose=frame.pose,
        )

    def stamp(self) -> tuple[int, int]:
        """The tick and simulation time its commands answer: those of its newest readings."""
        r = self.reading
        return (r.tick, r.sim_time_ns) if r is not None else (0, 0)

    def delayed(self, name: str, value: Any, latency: int) -> Any:
        """The reading ``latency`` updates ago (Ciber-Rato's FIFO; "no measurement" at first)."""
        q = self.fifos.get(name)
        if q is None:
            default = NO_MEASUREMENT[name.rstrip("0123456789")]
            q = self.fifos[name] = collections.deque([default] * latency, maxlen=latency + 1)
        q.append(value)
        return q[0]

    def measures(self, tick: int, p: SimParameters, *, running: bool, finished_at: int | None = None) -> Measures:
        """This cycle's Measures from its newest readings; the cycle's requests are spent.

        Args:
            tick: The simulator's Time.
            p: The legacy parameters (sensors on, requestable, latencies).
            running: Whether the simulator runs (the Start and Stop buttons).
            finished_at: The Time at which the simulation finished, if it has: Time stays there
                and both buttons are Off.
        """
        buttons = (running, not running)
        if finished_at is not None:
            tick = min(tick, finished_at)
            buttons = (False, False)
        r = self.reading
        heard = tuple(self.heard.get(tick, ()))
        if r is None:  # no reading yet (stopped before the first step): what it heard all the same
            return Measures(time=tick, collision=False, ir=(0.0,) * 4, messages=heard, buttons=buttons)
        # requests: at most NRequestsPerCycle honoured, in order, across the cycle's datagrams
        granted = set(self.requests[: p.n_requests_per_cycle])
        self.requests = []

        def wanted(name: str, requestable: bool) -> bool:
            return not requestable or name in granted

        ir = tuple(
            float(self.delayed(f"ir{i}", v, p.obstacle_latency))
            if wanted(f"IRSensor{i}", p.obstacle_requestable)
            else None
            for i, v in enumerate(r.proximity_legacy[:4])
        )
        compass = self.delayed("compass", float(round(r.compass_deg)), p.compass_latency)
        ground = self.delayed("ground", r.ground, p.ground_latency)
        collision = self.delayed("collision", r.collision, p.collision_latency)
        beacons = None
        if p.beacon_sensor and (not p.beacon_requestable or any(n.startswith("Beacon") for n in granted)):
            now = tuple(None if b is None else _round_half_away(b) for b in r.beacons_deg[: self.n_beacons])
            beacons = tuple(self.delayed(f"beacon{i}", v, p.beacon_latency) for i, v in enumerate(now))
        return Measures(
            time=tick,
            collision=bool(collision) if wanted("Collision", p.collision_requestable) else None,
            compass=float(compass) if p.compass_sensor and wanted("Compass", p.compass_requestable) else None,
            ground=int(ground) if wanted("Ground", p.ground_requestable) else None,
            ir=ir,
            beacons=beacons,
            gps=(round(r.gps[0] + GPS_OFFSET[0], 1), round(r.gps[1] + GPS_OFFSET[1], 1)) if p.gps else None,
            messages=heard,
            leds=(
                self.leds.get("EndLed", False),
                self.leds.get("ReturningLed", False),
                self.leds.get("VisitingLed", False),
            ),
            buttons=buttons,
            score=self.score() if p.score_sensor else None,
        )

    def next_measures(
        self,
        tick: int,
        p: SimParameters,
        *,
        running: bool,
        finished_at: int | None = None,
        force: bool = False,
    ) -> bytes | None:
        """The Measures datagram of ``tick``, once a tick (unless forced); what it heard in that
        tick is then delivered (what it heard in an earlier tick is dropped, counted in
        :attr:`missed`: a message is never heard a cycle late). Arguments as :meth:`measures`.

        Returns:
            The datagram, or None when this tick's was sent already.
        """
        if tick == self.sent_tick and not force:
            return None
        self.sent_tick = tick
        data = build_measures(self.measures(tick, p, running=running, finished_at=finished_at))
        for t in [t for t in self.heard if t <= tick]:
            if t < tick:
                self.missed += len(self.heard[t])
            del self.heard[t]
        return bytes(data)

    def score(self) -> Score | None:
        """Its score as the Measures' ScoreSensor tells it (None before its game exists)."""
        g = self.game
        if g is None:
            return None
        return Score(
            g.score,
            arrival_time=g.arrival_time,
            returning_time=g.returning_time,
            collisions=g.collisions,
            collision=g.collision,
            visited_mask=g.visited_mask,
        )

    def step(self, tick: int, x: float, y: float, *, collision: bool, hit_wall: bool, hit_robot: bool) -> None:
        """One committed step of its game (state machine and score), from the world's state.

        Args:
            tick: The step's tick.
            x: Its centre's x.
            y: Its centre's y.
            collision: Whether it collided.
            hit_wall: Whether a wall was hit.
            hit_robot: Whether another robot was hit.
        """
        if self.game is None:
            return  # no game yet (the world's lab unknown): nothing is stepped
        self.game.step(
            StepInput(
                now=tick,
                running=True,
                x=x,
                y=y,
                collision=collision,
                hit_wall=hit_wall,
                hit_robot=hit_robot,
                end_led=self.leds.get("EndLed", False),
                returning_led=self.leds.get("ReturningLed", False),
                visiting_led=self.leds.get("VisitingLed", False),
                returning_now=self.returning_now,
            )
        )
        self.returning_now = False
        self.pose = (x, y)
        self.finished = self.finished or self.game.finished

    def pause(self, tick: int) -> None:
        """A step of its game while the simulator is stopped (nothing scores)."""
        if self.game is not None:
            self.game.step(StepInput(now=tick, running=False, x=self.pose[0], y=self.pose[1]))
