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

from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import ChairReading

__all__ = ["AttachTo", "OnChair", "OnRegistered", "attached_to"]


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
class AttachTo(Protocol):
    """An agent that drives a robot another process registers (a real chair's serial bridge):
    ``attach_to`` is that robot's id (0: none, register one's own robot)."""

    attach_to: int


def attached_to(agent: object) -> int:
    """The robot id an agent drives without registering it (:class:`AttachTo`), or 0."""
    return int(agent.attach_to or 0) if isinstance(agent, AttachTo) else 0
