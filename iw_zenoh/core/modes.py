"""How a run goes: its pacing (:class:`Mode`) and its rules of motion and contact
(:class:`Profile`).

Both are string enums, so their values are what the wire, the recordings, the scenario files
and the command lines have always said (``"lockstep"``, ``"ciberrato"``...).
"""

from __future__ import annotations

import enum

__all__ = ["Mode", "Profile"]


class Mode(enum.StrEnum):
    """How the world paces its ticks."""

    REALTIME = "realtime"  # a tick every period; a late agent keeps its last command
    LOCKSTEP = "lockstep"  # each tick waits for every live agent's actions (or a timeout)


class Profile(enum.StrEnum):
    """How the world moves and checks bodies."""

    NATIVE = "native"  # Intellwheels: rectangles, curve motor model, exact polygons
    CIBERRATO = "ciberrato"  # the legacy simulator's motion and collision rules, exactly
