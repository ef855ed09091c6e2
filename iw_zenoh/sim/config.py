"""How the world runs: its period, mode, profile, seed, timeouts and roster (from ``iwz world``'s
options, a scenario, or a recording to re-simulate)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import msgspec

from iw_zenoh.core.modes import Mode, Profile, Silence

__all__ = ["MS", "PERIOD_MS", "TIMEOUT_MS_MAX", "VERDICT_MARGIN_MS", "WorldConfig", "WorldSettings"]

MS = 1_000_000
PERIOD_MS = (1.0, 60_000.0)  # a tick from 1 ms to a minute
TIMEOUT_MS_MAX = 86_400_000.0  # a day: the longest wait or timeout of the world's settings
VERDICT_MARGIN_MS = 5.0  # real time: the verdict wait ends this long before the next tick is due


@dataclass(frozen=True)
class WorldConfig:
    """How the world runs.

    Attributes:
        sim: Simulation name.
        period_ms: Tick period (simulated time per tick; real time too in real-time mode).
        mode: ``realtime`` or ``lockstep``.
        profile: ``native`` or ``ciberrato``.
        seed: Seeds movement noise.
        action_timeout_ms: Actions older than this (wall clock) zero the motors, when silence
            stops a robot.
        grace_ms: A robot whose agent is gone is removed after this.
        lockstep_timeout_ms: Lock-step waits this long for a tick's actions before going on.
        verdict_timeout_ms: Longest wait for a collision verdict in lock-step (see
            :attr:`verdict_wait_ns`).
        expect: Robots to wait for before the first tick (a scenario's roster).
        duration_ticks: Stop after this many ticks (0: run until stopped).
        start_paused: Do not tick until a ``start`` control arrives.
        motors_noise_pct: Ciber-Rato MotorsNoise (legacy profile).
        silence: What a robot whose actions stop coming does (None: its profile's rule,
            :meth:`Silence.of`).
        owners: A secured run's agents and the robots each may register (``None`` for any
            robot: a trusted bridge); an agent not listed registers nothing. ``None``: open.
        reserved: The ids a scenario gives its agents, by agent name: another registration asking
            for any id (0) does not get one, and one asking for it by number is refused.
    """

    sim: str = "default"
    period_ms: float = 100.0
    mode: Mode = Mode.REALTIME
    profile: Profile = Profile.NATIVE
    seed: int = 0
    action_timeout_ms: float = 500.0
    grace_ms: float = 5000.0
    lockstep_timeout_ms: float = 2000.0
    verdict_timeout_ms: float = 2000.0
    expect: int = 0
    duration_ticks: int = 0
    start_paused: bool = False
    motors_noise_pct: float = 0.0
    silence: Silence | None = None
    owners: dict[str, tuple[int, ...] | None] | None = None
    reserved: dict[str, tuple[int, ...]] | None = None

    @property
    def silent_robots(self) -> Silence:
        """What a silent robot does: as set, or its profile's rule."""
        return self.silence if self.silence is not None else Silence.of(self.profile)

    @property
    def verdict_wait_ns(self) -> int:
        """How long a tick waits for its collision verdict before it holds every robot still (a
        held tick changes a run): lock-step as long as it waits for actions (``verdict_timeout_ms``
        at least), so a slow machine changes how long a run takes, never what happens in it; real
        time, in every profile, as long as the period allows: until :data:`VERDICT_MARGIN_MS` (a
        tenth of a short period) before the next tick is due, time enough to commit and publish
        (the legacy simulator never holds a robot, and a native run should not either while a
        collision process answers)."""
        if self.mode == Mode.LOCKSTEP:
            return int(max(self.verdict_timeout_ms, self.lockstep_timeout_ms) * MS)
        return self.period_ns - min(self.period_ns // 10, int(VERDICT_MARGIN_MS * MS))

    @property
    def period_ns(self) -> int:
        """The period in ns."""
        return int(round(self.period_ms * MS))


_CORE = WorldConfig()


class WorldSettings(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """How the world runs, declared once: a scenario's ``[world]`` (``WorldSection``) and ``iwz
    world``'s options (``WorldOptions``) are this with what each adds; the defaults are the world
    core's (:class:`WorldConfig`), which the options become (``world_config``).

    Attributes:
        period_ms: Tick period, ms.
        mode: ``realtime`` or ``lockstep``.
        profile: Motion and collision rules, ``native`` or ``ciberrato``.
        seed: Seeds movement noise (numpy takes no negative seed).
        action_timeout_ms: Actions older than this zero a robot's motors (when silence stops it).
        grace_ms: A robot is removed this long after its agent is gone.
        lockstep_timeout_ms: Lock-step waits this long for a tick's actions.
        motors_noise_pct: Ciber-Rato MotorsNoise, percent.
        silence: What a robot whose actions stop coming does: ``stop`` or ``keep``; None: the
            profile's (native stop, ciberrato keep).
        start_paused: Do not tick until a ``start`` control arrives.
    """

    period_ms: Annotated[float, msgspec.Meta(ge=PERIOD_MS[0], le=PERIOD_MS[1])] = _CORE.period_ms
    mode: Mode = _CORE.mode
    profile: Profile = _CORE.profile
    seed: Annotated[int, msgspec.Meta(ge=0)] = _CORE.seed
    action_timeout_ms: Annotated[float, msgspec.Meta(gt=0, le=TIMEOUT_MS_MAX)] = _CORE.action_timeout_ms
    grace_ms: Annotated[float, msgspec.Meta(ge=0, le=TIMEOUT_MS_MAX)] = _CORE.grace_ms
    lockstep_timeout_ms: Annotated[float, msgspec.Meta(gt=0, le=TIMEOUT_MS_MAX)] = _CORE.lockstep_timeout_ms
    motors_noise_pct: Annotated[float, msgspec.Meta(ge=0, le=100)] = _CORE.motors_noise_pct
    silence: Silence | None = _CORE.silence
    start_paused: bool = _CORE.start_paused
