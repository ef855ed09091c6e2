"""Driving a chair from the page: the viewer relays a page's ``drive`` command to the chair's
drive key (as an ``iw.DriveInput`` under the page's driver name) and tells the pages each chair's
drive state (``iw.DriveState``, which only the chair's agent publishes). The agent decides who
drives; the viewer only relays, releases the chair of a page whose socket is lost, and, in a
secured run, lets a page drive only the chairs its identity's policy grants (docs/driving.md).
"""

from __future__ import annotations

import logging
from pathlib import Path

from iw_zenoh import keys
from iw_zenoh.bus import Bus
from iw_zenoh.errors import ConfigError, IwError
from iw_zenoh.messages import decode, encode
from iw_zenoh.messages.drive import DRIVER_MAX, DriveInput, DriveState
from iw_zenoh.messages.page import PageDrive, PageDriveInput, PageMessage

__all__ = ["DriveGrant", "Drives", "decode_state", "driver_name", "relay"]

logger = logging.getLogger(__name__)


def driver_name(viewer: str, page: int) -> str:
    """The driver name of the viewer's ``page``-th page: ``viewer#page`` (the viewer's name cut
    so that the whole fits :data:`~iw_zenoh.messages.drive.DRIVER_MAX`)."""
    tail = f"#{page}"
    return viewer[: DRIVER_MAX - len(tail)] + tail


class DriveGrant:
    """Which chairs this viewer's pages may drive: any (an unsecured run), or in a secured run
    those its identity's policy entry names in ``robots`` (the router refuses the rest anyway;
    this says why to the page).

    Args:
        identity: The viewer's ``--identity`` (``DIR/NAME``), or ``None`` (not secured).
        policy: The policy to read (default ``DIR/policy.toml``).
    """

    def __init__(self, identity: str | None, policy: Path | None = None) -> None:
        self.identity = identity
        self.robots: frozenset[int] | None = None  # None: any chair
        self.why = ""
        if identity is None:
            return
        from iw_zenoh.secure.cli import POLICY_FILE
        from iw_zenoh.secure.policy import load_policy

        d, name = Path(identity).parent, Path(identity).name
        self.path = policy or d / POLICY_FILE
        self.robots = frozenset()
        try:
            entry = load_policy(self.path).identities.get(name)
        except (OSError, ConfigError, IwError) as e:
            self.why = f"cannot read the policy {self.path} ({e}): this secured viewer drives no chair"
            return
        if entry is None:
            self.why = f"the policy {self.path} does not name this viewer's identity {name!r}"
            return
        self.robots = frozenset(entry.robots)
        self.name = name

    def refusal(self, robot_id: int) -> str:
        """Why this viewer may not drive chair ``robot_id`` ("" when it may)."""
        if self.robots is None or robot_id in self.robots:
            return ""
        if self.why:
            return self.why
        granted = ", ".join(map(str, sorted(self.robots))) or "none"
        return (
            f"this viewer's identity {self.name!r} may not drive chair {robot_id}: the policy {self.path} grants it "
            f"chairs [{granted}] (add the chair to its robots, e.g. `robots = [{robot_id}]`, and restart the router)"
        )


def relay(bus: Bus, sim: str, robot_id: int, driver: str, d: PageDriveInput) -> None:
    """Publishes a page's input on chair ``robot_id``'s drive key as ``driver``'s."""
    msg = DriveInput(
        robot_id=robot_id,
        driver=driver,
        seq=d.seq,
        x=d.x,
        y=d.y,
        buttons=d.buttons,
        level=d.level,
        take=d.take,
        release=d.release,
        goto=d.goto,
        assist=d.assist,
    )
    bus.publish(keys.drive(sim, robot_id), encode(msg))


class Drives:
    """The chairs' drive states the pages are told: each one that changed, and on joining all."""

    def __init__(self) -> None:
        self.states: dict[int, DriveState] = {}

    def on_state(self, robot_id: int, st: DriveState) -> list[PageMessage]:
        """A chair's drive state: told the pages when it changed."""
        if self.states.get(robot_id) == st:
            return []
        self.states[robot_id] = st
        return [PageDrive(robot_id=robot_id, state=st)]

    def keep(self, ids: list[int]) -> list[PageMessage]:
        """Forgets the chairs no longer in the world (the pages are told)."""
        gone = [r for r in self.states if r not in ids]
        for r in gone:
            del self.states[r]
        return [PageDrive(robot_id=r, state=None) for r in gone]

    def snapshot(self) -> list[PageMessage]:
        """Every chair's drive state (for a page that joins)."""
        return [PageDrive(robot_id=r, state=s) for r, s in self.states.items()]


def decode_state(key: str, data: bytes) -> tuple[int, DriveState] | None:
    """A chair's drive state off its key (``None``, logged, when it is not one, or another chair's)."""
    rid = keys.robot_id_of(key)
    try:
        st = decode(data, DriveState)
    except IwError as e:
        logger.warning("dropped a bad drive state on %s: %s", key, e)
        return None
    if rid != st.robot_id:
        logger.warning("dropped a drive state of chair %d on %s", st.robot_id, key)
        return None
    return rid, st
