"""How the world runs: its period, mode, profile, seed, timeouts and roster (from ``iwz world``'s
options, a scenario, or a recording to re-simulate)."""

from __future__ import annotations

from typing import Annotated

import msgspec

from iw_zenoh.core.modes import Mode, Profile, Silence

__all__ = ["MS", "PERIOD_MS", "TIMEOUT_MS_MAX", "VERDICT_MARGIN_MS", "WorldConfig", "WorldSettings"]

MS = 1_000_000
PERIOD_MS = (1.0, 60_000.0)  # a tick from 1 ms to a minute
TIMEOUT_MS_MAX = 86_400_000.0  # a day: the longest wait or timeout of the world's settings
VERDICT_MARGIN_MS = 5.0  # real time: the verdict wait ends this long before the next tick is due


class WorldSettings(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """How the world runs, declared once: a scenario's ``[world]`` (``WorldSection``), ``iwz
    world``'s options (``WorldOptions``) and the world core's configuration (:class:`WorldConfig`)
    are this with what each adds.

    Each field says its type, range and default, and, for ``iwz world``'s flag that sets it
    (generated from it, :func:`~iw_zenoh.process.options.declared_flags`), its help
    (``description``, ``{default}`` replaced by the default) and the flag's own spelling where it
    is not the field's name (``extra``).

    Attributes:
        period_ms: Tick period, ms (simulated time per tick; real time too in real-time mode).
        mode: ``realtime`` or ``lockstep``.
        profile: Motion and collision rules, ``native`` or ``ciberrato``.
        seed: Seeds movement noise (numpy takes no negative seed).
        action_timeout_ms: Actions older than this (wall clock) zero a robot's motors (when
            silence stops it).
        grace_ms: A robot is removed this long after its agent is gone.
        lockstep_timeout_ms: Lock-step waits this long for a tick's actions before going on.
        motors_noise_pct: Ciber-Rato MotorsNoise, percent.
        silence: What a robot whose actions stop coming does: ``stop`` or ``keep``; None: the
            profile's (native stop, ciberrato keep; :meth:`Silence.of`).
        start_paused: Do not tick until a ``start`` control arrives.
    """

    period_ms: Annotated[
        float,
        msgspec.Meta(
            ge=PERIOD_MS[0],
            le=PERIOD_MS[1],
            description="tick period in ms (default {default:g}; Ciber-Rato uses 50)",
            extra={"metavar": "MS"},
        ),
    ] = 100.0
    mode: Annotated[
        Mode,
        msgspec.Meta(
            description="lock-step: wait for every live agent's actions each tick (default: real time)",
            extra={"flag": "--lockstep", "const": Mode.LOCKSTEP.value},
        ),
    ] = Mode.REALTIME
    profile: Annotated[Profile, msgspec.Meta(description="motion and collision rules (default {default})")] = (
        Profile.NATIVE
    )
    seed: Annotated[
        int, msgspec.Meta(ge=0, description="seed of movement noise (default {default})", extra={"metavar": "N"})
    ] = 0
    action_timeout_ms: Annotated[
        float,
        msgspec.Meta(
            gt=0,
            le=TIMEOUT_MS_MAX,
            description="zero a robot's motors when its actions are older, if silence stops it (default {default:g})",
            extra={"metavar": "MS"},
        ),
    ] = 500.0
    grace_ms: Annotated[
        float,
        msgspec.Meta(
            ge=0,
            le=TIMEOUT_MS_MAX,
            description="remove a robot this long after its agent is gone (default {default:g})",
            extra={"metavar": "MS"},
        ),
    ] = 5000.0
    lockstep_timeout_ms: Annotated[
        float,
        msgspec.Meta(
            gt=0,
            le=TIMEOUT_MS_MAX,
            description="lock-step: wait this long for a tick's actions (default {default:g})",
            extra={"metavar": "MS"},
        ),
    ] = 2000.0
    motors_noise_pct: Annotated[
        float,
        msgspec.Meta(
            ge=0,
            le=100,
            description="Ciber-Rato MotorsNoise, percent (legacy profile)",
            extra={"flag": "--motors-noise", "metavar": "PCT"},
        ),
    ] = 0.0
    silence: Annotated[
        Silence | None,
        msgspec.Meta(
            description="what a robot whose actions stop coming does: stop (its motors zeroed after "
            "--action-timeout-ms) or keep (its last command for ever, as the legacy simulator); "
            "default: the profile's, native stop, ciberrato keep"
        ),
    ] = None
    start_paused: Annotated[
        bool, msgspec.Meta(description="start paused; a 'start' control runs it", extra={"flag": "--paused"})
    ] = False


class WorldConfig(WorldSettings, frozen=True, kw_only=True):
    """How the world core runs: :class:`WorldSettings` (the defaults are theirs) and what only the
    core has (``world_config`` in ``iw_zenoh/nodes/world.py`` builds it from ``iwz world``'s options).

    Attributes:
        sim: Simulation name.
        verdict_timeout_ms: Longest wait for a collision verdict in lock-step (see
            :attr:`verdict_wait_ns`).
        expect: Robots to wait for before the first tick (a scenario's roster).
        duration_ticks: Stop after this many ticks (0: run until stopped).
        owners: A secured run's agents and the robots each may register (``None`` for any
            robot: a trusted bridge); an agent not listed registers nothing. ``None``: open.
        reserved: The ids a scenario gives its agents, by agent name: another registration asking
            for any id (0) does not get one, and one asking for it by number is refused.
    """

    sim: str = "default"
    verdict_timeout_ms: float = 2000.0
    expect: int = 0
    duration_ticks: int = 0
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
