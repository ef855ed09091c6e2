"""Every legacy scoring mode scores a robot the same whenever it registers: into a world already
running, or into a paused world that is then started (the bridge fed the world's messages as the
world sends them, its sockets faked; the same with real processes:
tests/integration/test_legacy_scores.py).

The drive, on the shipped C1 lab: from its grid position (3, 11), on target 0, with the
VisitingLed on for the first step, then east along the corridor, across three control cells, into
the wall at x = 9.9 (CollisionWallPenalty 5)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from iw_zenoh.bridges.ciberrato.node import Bridge
from iw_zenoh.bridges.ciberrato.scoring import Mode

from iw_zenoh import keys
from iw_zenoh.convert import lab_to_msg
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.params import SimParameters
from iw_zenoh.maps import load_lab
from iw_zenoh.messages import Hit, Message, RegisterReply, RobotSpecMsg, Tick, Verdict, WorldInfo, WorldState, encode
from tests.support.fakes import FakeBus, FakeTransport, Transports

PEER = ("127.0.0.1", 40001)
PERIOD_NS = 50_000_000
LAB = load_lab(str(Path(__file__).resolve().parents[3] / "maps" / "ciberrato" / "C1-lab.xml"))
START = (3.0, 11.0)
RID = 1
# (before the wall, after it): the legacy rules on this drive
EXPECTED = {
    Mode.CONTROL: (30, 25),  # 10 a loop cell east of the start; the penalty subtracted
    Mode.COMPETITIVE: (300, 305),  # 100 + 100 per target, 100 off for the visit; the penalty added
    Mode.MAPPING: (-100, -95),  # from 0
    Mode.PLANNING: (-100, -95),
}


class World:
    """Plays the world on the fake bus: ticks, verdicts and committed states, as it sends them."""

    def __init__(self, bridge: Bridge, bus: FakeBus, tick: int) -> None:
        self.bridge, self.bus, self.tick = bridge, bus, tick
        self.ids: list[int] = []

    def _put(self, key: str, msg: Message) -> None:
        self.bus.queue(key).put(key, encode(msg))

    def paused(self) -> None:
        """A paused cycle: the clock says so, nothing steps."""
        self._put(keys.tick(self.bridge.sim), Tick(tick=self.tick, period_ns=PERIOD_NS, running=False))
        self.bridge.poll(0)

    def step(self, x: float, *, wall: bool = False) -> None:
        """One running step: the robot committed at (x, 11), into a wall or not."""
        self.tick += 1
        n, sim = len(self.ids), self.bridge.sim
        hits = [Hit(robot_id=RID, wall=3)] if wall else []
        collided = [wall] * n
        self._put(keys.verdict(sim), Verdict(tick=self.tick, revision=1, ids=self.ids, collided=collided, hits=hits))
        state = WorldState(
            tick=self.tick,
            revision=1,
            ids=self.ids,
            x=[x] * n,
            y=[START[1]] * n,
            heading=[0.0] * n,
            collided=collided,
            rolled_left=[0.0] * n,
            rolled_right=[0.0] * n,
            speed=[0.0] * n,
        )
        self._put(keys.state(sim), state)
        self._put(keys.tick(sim), Tick(tick=self.tick, period_ns=PERIOD_NS))
        self.bridge.poll(0)


@pytest.fixture
def made() -> Iterator[Transports]:
    t = Transports()
    yield t
    for s in t.made:
        s.close()


def _bridge(mode: Mode, made: Transports, world_tick: list[int]) -> tuple[Bridge, FakeBus, FakeTransport]:
    bus, reception = FakeBus(), FakeTransport()
    spec = RobotSpecMsg(name="r", id=RID, x_m=START[0], y_m=START[1])
    bus.answer = lambda key, payload: [encode(RegisterReply(tick=world_tick[0], ok=True, robot_id=RID, spec=spec))]
    info = WorldInfo(revision=1, lab=lab_to_msg(LAB), profile=Profile.CIBERRATO, period_ns=PERIOD_NS)
    bus.info.append(encode(info))
    params = SimParameters(sim_time=5000, collision_wall_penalty=5)
    return Bridge(bus, "s", reception, new_transport=made, params=params, scoring=mode, pace=False), bus, reception


def _drive(world: World, own: FakeTransport) -> tuple[int, int]:
    """The drive (module docstring); the robot's score before the wall and after it."""
    own.deliver(b'<Actions LeftMotor="0.1" RightMotor="0.1" VisitingLed="On"/>', PEER)
    world.bridge.poll(0)
    world.step(START[0])
    own.deliver(b'<Actions VisitingLed="Off"/>', PEER)
    world.bridge.poll(0)
    x = START[0]
    while x < 9.4:
        x = round(x + 0.1, 1)
        world.step(x)
    game = world.bridge.robots[RID].game
    assert game is not None
    before = game.score
    world.step(9.4, wall=True)
    world.step(9.4, wall=True)  # still touching: no second penalty
    return before, game.score


def _register(world: World, reception: FakeTransport, made: Transports) -> FakeTransport:
    reception.deliver(b'<Robot Id="1" Name="r"/>', PEER)
    world.bridge.poll(0)
    own = made.made[-1]
    assert own.sent[0][0].startswith(b'<Reply Status="Ok">')
    world.ids = [RID]
    return own


@pytest.mark.parametrize("mode", list(Mode))
def test_a_robot_registered_into_a_running_world_scores_as_the_legacy_game(mode: Mode, made: Transports) -> None:
    tick = [0]
    bridge, bus, reception = _bridge(mode, made, tick)
    world = World(bridge, bus, 0)
    for _ in range(300):  # the world has run 15 s before the robot comes
        world.step(0.0)
    tick[0] = world.tick
    own = _register(world, reception, made)
    assert _drive(world, own) == EXPECTED[mode]
    bridge.close()


@pytest.mark.parametrize("mode", list(Mode))
def test_a_robot_registered_into_a_paused_world_then_started_scores_as_the_legacy_game(
    mode: Mode, made: Transports
) -> None:
    bridge, bus, reception = _bridge(mode, made, [0])
    world = World(bridge, bus, 0)
    world.paused()
    own = _register(world, reception, made)
    for _ in range(3):
        world.paused()
    assert bridge.robots[RID].game is not None
    assert bridge.robots[RID].game.state == "Stopped"
    assert _drive(world, own) == EXPECTED[mode]  # Start: the world steps from Time 1
    bridge.close()


@pytest.mark.parametrize("mode", list(Mode))
def test_a_robot_registered_into_a_world_paused_mid_run_then_started_scores_as_the_legacy_game(
    mode: Mode, made: Transports
) -> None:
    tick = [0]
    bridge, bus, reception = _bridge(mode, made, tick)
    world = World(bridge, bus, 0)
    for _ in range(120):
        world.step(0.0)
    world.paused()
    tick[0] = world.tick
    own = _register(world, reception, made)
    world.paused()
    assert _drive(world, own) == EXPECTED[mode]
    bridge.close()
