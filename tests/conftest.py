"""Shared fixtures and builders: a seeded generator, a small map and its scene, a world state and
its proposal, an agent host on a fake bus."""

from __future__ import annotations

import inspect
import os
import subprocess
from collections.abc import Iterator, Sequence
from pathlib import Path
from types import CodeType, ModuleType
from typing import TYPE_CHECKING

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

from iw_zenoh.core import cones, contact
from iw_zenoh.core.lab import Lab, Scene, Wall
from iw_zenoh.messages import LabMsg, Proposed, RegisterReply, RobotSpecMsg, WorldInfo, WorldState, encode

if TYPE_CHECKING:
    from iw_zenoh.agent import Agent, AgentHost
    from tests.bridges.fakes import FakeBus

settings.register_profile("ci", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("ci")


TESTS = Path(__file__).resolve().parent
# what a test module that starts processes holds: the modules (or their names) it starts them with
PROCESS_STARTERS = frozenset({"subprocess", "multiprocessing", "tests.integration.harness"})
_warm: list[bool] = []
CHECKS = frozenset({"_kernels_for_processes", "_no_process_unless_slow"})  # this file's own, on every test


def _starter(value: object) -> bool:
    name = value.__name__ if isinstance(value, ModuleType) else getattr(value, "__module__", None)
    return name in PROCESS_STARTERS


def _codes(code: CodeType) -> Iterator[CodeType]:
    """A code object and every one nested in it (its lambdas, comprehensions, inner functions)."""
    yield code
    for const in code.co_consts:
        if isinstance(const, CodeType):
            yield from _codes(const)


def _reaches_a_starter(fn: object, seen: set[int]) -> bool:
    """Whether ``fn`` (a function or a class of the tests), or what of the tests it calls, uses a
    process starter."""
    if id(fn) in seen:
        return False
    seen.add(id(fn))
    if isinstance(fn, type):
        return any(_reaches_a_starter(v, seen) for v in vars(fn).values() if inspect.isfunction(v))
    fn = inspect.unwrap(fn) if callable(fn) else fn
    code, scope = getattr(fn, "__code__", None), getattr(fn, "__globals__", None)
    if code is None or scope is None:
        return False
    for name in {n for c in _codes(code) for n in c.co_names}:
        value = scope.get(name)
        if value is None:
            continue
        if _starter(value):
            return True
        ours = inspect.isfunction(value) or isinstance(value, type)
        if ours and str(value.__module__).startswith("tests") and _reaches_a_starter(value, seen):
            return True
    return False


def _starts_processes(item: pytest.Item) -> bool:
    """Whether a test starts processes: it is an integration test, carries the ``zenoh`` marker, or
    its function or one of its fixtures (or a helper of the tests they call) uses ``subprocess``,
    ``multiprocessing`` or the integration harness."""
    if "integration" in Path(str(item.path)).resolve().relative_to(TESTS).parts:
        return True
    if item.get_closest_marker("zenoh") is not None:
        return True
    seen: set[int] = set()
    if _reaches_a_starter(getattr(item, "function", None), seen):
        return True
    info = getattr(item, "_fixtureinfo", None)
    defs = info.name2fixturedefs.values() if info is not None else ()
    return any(_reaches_a_starter(d[-1].func, seen) for d in defs if d and d[-1].argname not in CHECKS)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Every test that starts processes is ``slow``: ``pytest -m "not slow"`` is the quick loop."""
    for item in items:
        if _starts_processes(item):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(autouse=True)
def _kernels_for_processes(request: pytest.FixtureRequest) -> None:
    """Compiles the proximity and contact kernels once, before the first test that starts processes
    (a sensors or collision process or an agent that plans would otherwise each compile them, for
    seconds, in a fresh checkout); a quick run (``-m "not slow"``) compiles only what its tests call."""
    if not _warm and request.node.get_closest_marker("slow") is not None:
        cones.warm_up()
        contact.warm_up()
        _warm.append(True)


@pytest.fixture(autouse=True)
def _no_process_unless_slow(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """With ``IWZ_CHECK_SLOW=1``, a test not marked ``slow`` that starts a process fails, naming it:
    the check that the ``slow`` marker is on every test that starts processes."""
    if os.environ.get("IWZ_CHECK_SLOW") != "1" or request.node.get_closest_marker("slow") is not None:
        return

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError(f"{request.node.nodeid} starts a process ({args[:1]}) but is not marked slow")

    monkeypatch.setattr(subprocess.Popen, "__init__", refuse)


def box_wall(x0: float, y0: float, x1: float, y1: float, height_m: float = 4.0) -> Wall:
    """An axis-aligned rectangular wall."""
    return Wall(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), height_m)


def random_scene(g: np.random.Generator) -> Scene:
    """A 10 x 10 m lab with up to five random box walls (the sensors' tests against shapely)."""
    walls = []
    for _ in range(g.integers(0, 6)):
        x, y = g.uniform(0.5, 8.5, 2)
        w, h = g.uniform(0.05, 2.0, 2)
        walls.append(box_wall(x, y, min(x + w, 9.9), min(y + h, 9.9)))
    return Scene(Lab("random", 10.0, 10.0, tuple(walls)))


def random_poses(g: np.random.Generator, n: int) -> np.ndarray:
    """(n, 3) poses anywhere in :func:`random_scene`'s lab, facing anywhere."""
    return np.column_stack([g.uniform(0.5, 9.5, n), g.uniform(0.5, 9.5, n), g.uniform(-np.pi, np.pi, n)])


def world_state(
    tick: int,
    ids: Sequence[int] = (1,),
    *,
    revision: int = 1,
    x: float | Sequence[float] = 1.0,
    y: float = 1.0,
    heading: float = 0.0,
    collided: bool | Sequence[bool] = False,
    rolled: float = 0.0,
    speed: float = 0.0,
    held: bool = False,
    held_reason: str = "",
) -> WorldState:
    """The world's state of ``tick`` (at 100 ms a tick) for robots ``ids``: every robot alike, each
    scalar given for all of them, ``x`` and ``collided`` also one a robot."""
    n = len(ids)
    xs = [x] * n if isinstance(x, float | int) else list(x)
    hits = [collided] * n if isinstance(collided, bool) else list(collided)
    return WorldState(
        tick=tick,
        sim_time_ns=tick * 100_000_000,
        revision=revision,
        ids=list(ids),
        x=[float(v) for v in xs],
        y=[y] * n,
        heading=[heading] * n,
        collided=hits,
        rolled_left=[rolled] * n,
        rolled_right=[rolled] * n,
        speed=[speed] * n,
        held=held,
        held_reason=held_reason,
    )


def proposal_of(st: WorldState) -> Proposed:
    """The world's proposal whose next poses and distances rolled are those of ``st`` (every robot
    from the origin, active): what commits ``st`` if no robot collides."""
    n = len(st.ids)
    return Proposed(
        tick=st.tick,
        sim_time_ns=st.sim_time_ns,
        revision=st.revision,
        ids=st.ids,
        x=[0.0] * n,
        y=[0.0] * n,
        heading=[0.0] * n,
        next_x=st.x,
        next_y=st.y,
        next_heading=st.heading,
        linear=[0.0] * n,
        active=[True] * n,
        rolled_left=st.rolled_left,
        rolled_right=st.rolled_right,
        tick_wall_ns=st.tick_wall_ns,
    )


DEAD_END = Lab(
    "dead end",
    6.0,
    3.0,
    (box_wall(2.0, 0.0, 6.0, 1.05), box_wall(2.0, 1.95, 6.0, 3.0), box_wall(5.0, 1.05, 6.0, 1.95)),
)  # a 0.9 m corridor from the open end at x = 2 to a wall at x = 5: too narrow to turn the chair in


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator, the same in every run."""
    return np.random.default_rng(20261122)


@pytest.fixture
def small_map() -> Lab:
    """A 10 x 6 lab with one 1 x 1 pillar at (5..6, 2..3)."""
    return Lab("small", 10.0, 6.0, (box_wall(5.0, 2.0, 6.0, 3.0),))


@pytest.fixture
def small_scene(small_map: Lab) -> Scene:
    """The small map's geometry."""
    return Scene(small_map)


def agent_host(*agents: Agent, world_tick: int = 50) -> tuple[AgentHost, FakeBus]:
    """An agent host on a fake bus, with ``agents`` registered as robots 1, 2, ... of a world at
    ``world_tick`` (in real time)."""
    from iw_zenoh.agent import AgentHost
    from tests.bridges.fakes import FakeBus

    bus = FakeBus()
    ids = iter(range(1, len(agents) + 1))

    def answer(key: str, payload: bytes) -> list[bytes]:
        rid = next(ids)
        spec = RobotSpecMsg(name=f"r{rid}", id=rid, x=1.0, y=float(rid))
        return [encode(RegisterReply(tick=world_tick, ok=True, robot_id=rid, spec=spec))]

    bus.answer = answer
    bus.info = [encode(WorldInfo(tick=world_tick, revision=1, lab=LabMsg(name="l", width=5, height=5), period_ns=1))]
    host = AgentHost(bus, "t", "host")
    for i, agent in enumerate(agents, start=1):
        assert host.add(agent, timeout_s=1.0) == i
    return host, bus
