"""How a run goes: its pacing (:class:`Mode`), its rules of motion and contact
(:class:`Profile`), and what becomes of a robot whose actions stop coming (:class:`Silence`).

All are string enums, so their values are what the wire, the recordings, the scenario files
and the command lines have always said (``"lockstep"``, ``"ciberrato"``...).
"""

from __future__ import annotations

import enum

__all__ = ["Mode", "Profile", "Silence"]


class Mode(enum.StrEnum):
    """How the world paces its ticks."""

    REALTIME = "realtime"  # a tick every period; a late agent keeps its last command
    LOCKSTEP = "lockstep"  # each tick waits for every live agent's actions (or a timeout)


class Profile(enum.StrEnum):
    """How the world moves and checks bodies."""

    NATIVE = "native"  # Intellwheels: rectangles, curve motor model, exact polygons
    CIBERRATO = "ciberrato"  # the legacy simulator's motion and collision rules, exactly


class Silence(enum.StrEnum):
    """What the world does with a robot whose actions stop coming while its agent is alive."""

    STOP = "stop"  # its motors are zeroed once its actions are older than the action timeout
    KEEP = "keep"  # its last command applies for ever, as the legacy simulator's motors do

    @staticmethod
    def of(profile: Profile) -> Silence:
        """A profile's own rule: the native watchdog, or the legacy simulator's sticky motors.

        Args:
            profile: The world's profile.

        Returns:
            STOP for the native profile, KEEP for the ciberrato profile.
        """
        return Silence.KEEP if profile == Profile.CIBERRATO else Silence.STOP
