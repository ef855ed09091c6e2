"""The optional hooks of an agent, as typed protocols: an agent may have any of them, and the
agent host (and the type checker) knows each by its protocol rather than by looking for a name.

Each is ``runtime_checkable``: the host asks ``isinstance(agent, OnRegistered)``. Import them from
:mod:`iw_zenoh.agent`, with the rest of the agent API::

    from iw_zenoh.agent import Command, OnRegistered, Spec

    class GoTo(OnRegistered):          # saying so is optional: having the method is enough
        def on_registered(self, robot_id: int, spec: Spec) -> None:
            self.robot_id = robot_id
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from iw_zenoh.agent.hosting import Command
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import ChairReading, DriveInput, DriveState, WorldState

__all__ = ["AttachTo", "DrivesNow", "OnChair", "OnDrive", "OnRegistered", "OnState", "attached_to"]


@runtime_checkable
class OnRegistered(Protocol):
    """An agent told of its robot once the world accepted it."""

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """Called once the world has accepted the robot (again after each registration anew).

        Args:
            robot_id: The id the world gave the robot.
            spec: The spec the world accepted (its start pose filled in).
        """


@runtime_checkable
class OnChair(Protocol):
    """An agent that also reads a real chair's own readings (the serial bridge's, ``robot/{id}/chair``)."""

    def on_chair(self, reading: ChairReading) -> None:
        """Called with each of the chair's readings, before the tick's ``on_sensors``.

        Args:
            reading: The chair's odometry, encoders, sonars, battery and stop state.
        """


@runtime_checkable
class OnState(Protocol):
    """An agent that judges itself by where it truly is (a learned policy: ``iwz agent policy``)."""

    def on_state(self, state: WorldState) -> None:
        """Called with the world's committed state of the tick, just before that tick's
        ``on_sensors`` (in lock-step the host waits for the state before answering).

        Args:
            state: The world's state of the tick.
        """


@runtime_checkable
class OnDrive(Protocol):
    """An agent that accepts a driver (a chair a person drives: ``docs/driving.md``)."""

    def on_drive(self, drive: DriveInput) -> None:
        """Called with each driver's input to one of its chairs (``robot/{id}/drive``).

        Args:
            drive: The driver's input (its robot id checked against the key's).
        """

    def drive_messages(self) -> list[DriveInput | DriveState]:
        """The drive messages of the tick just answered: its drive state, and the inputs a replayed
        trace gave (recorded as a live driver's would be)."""


@runtime_checkable
class DrivesNow(Protocol):
    """An agent that answers a driver's input at once, between ticks (docs/driving.md)."""

    def drive_now(self) -> Command | None:
        """Called (real time only) after the drivers' inputs that just came were handed to
        ``on_drive``: the command of the tick last answered, made again with the newest input, or
        None when the input changes nothing. The host sends it (and then ``drive_messages()``)
        on the tick's actions key at once; the world applies the newest actions at its next step.
        """


@runtime_checkable
class AttachTo(Protocol):
    """An agent that drives a robot another process registers (a real chair's serial bridge):
    ``attach_to`` is that robot's id (0: none, register one's own robot)."""

    attach_to: int


def attached_to(agent: object) -> int:
    """The robot id an agent drives without registering it (:class:`AttachTo`), or 0."""
    return int(agent.attach_to or 0) if isinstance(agent, AttachTo) else 0
