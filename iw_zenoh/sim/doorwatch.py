"""What a run's doors did, judged against the scenario's door criteria (``[[criteria.doors]]``),
from the committed states alone: pure, so ``iwz run`` and a test judge alike.

A door's pose when first seen is its closed pose. It *opened* once it moved :data:`OPEN_M` or
turned :data:`OPEN_DEG` from there (its heading unwrapped tick by tick, so a revolving door's
half turn counts as 180 degrees); it is *closed again* at a later tick standing still back within
:data:`SHUT_M` and :data:`SHUT_DEG` of that pose, its turn taken modulo the criterion's
``symmetry_deg``. *One chair at a time*: no two robots other than doors are ever within
``one_chair_within_m`` of the doorway's middle at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from iw_zenoh.scenario.tables import DoorCriterion

__all__ = ["OPEN_DEG", "OPEN_M", "SHUT_DEG", "SHUT_M", "STILL_DEG", "STILL_M", "DoorWatch"]

OPEN_M = 0.5  # a sliding leaf this far from its closed place is open
OPEN_DEG = 45.0  # a hinged or revolving door turned this far is open
SHUT_M = 0.05  # back this near its closed place ...
SHUT_DEG = 5.0  # ... and turned back this near, a door is closed again ...
STILL_DEG = 0.05  # ... once it stands still (turned at most this since the last state ...
STILL_M = 0.002  # ... and moved at most this): a revolving door passing a shut angle is not shut


@dataclass
class _Door:
    """One door's record: its closed pose, how far it has turned, when it opened and closed."""

    x0: float
    y0: float
    h0_deg: float
    turn_deg: float = 0.0  # unwrapped turn from the closed heading
    last_deg: float = 0.0
    last_x: float = 0.0
    last_y: float = 0.0
    opened_s: float | None = None
    closed_s: float | None = None


@dataclass
class _Crowd:
    """The most chairs seen at once in one doorway, and when first so."""

    most: int = 0
    when_s: float = 0.0
    who: tuple[int, ...] = ()


@dataclass
class DoorWatch:
    """Watches the doors named by the criteria through the run's committed states.

    Attributes:
        doors: Each watched door's record, by robot id.
        crowds: Each criterion's doorway crowding, by its index in the criteria.
    """

    doors: dict[int, _Door] = field(default_factory=dict)
    crowds: dict[int, _Crowd] = field(default_factory=dict)

    def observe(
        self,
        criteria: tuple[DoorCriterion, ...],
        sim_s: float,
        poses: dict[int, tuple[float, float, float]],
        door_ids: set[int],
    ) -> None:
        """Takes one committed state.

        Args:
            criteria: The scenario's door criteria.
            sim_s: The state's simulated time, s.
            poses: Every robot's (x m, y m, heading rad), by id.
            door_ids: Robots that are doors (the world's Door type); the criteria's doors are too.
        """
        for c in criteria:
            if c.robot in poses:
                self._door(c, sim_s, poses[c.robot])
        doors = door_ids | {c.robot for c in criteria}
        for i, c in enumerate(criteria):
            if c.one_chair_within_m is None or c.x_m is None or c.y_m is None:
                continue
            near = tuple(
                sorted(
                    rid
                    for rid, (x, y, _) in poses.items()
                    if rid not in doors and math.hypot(x - c.x_m, y - c.y_m) <= c.one_chair_within_m
                )
            )
            crowd = self.crowds.setdefault(i, _Crowd())
            if len(near) > crowd.most:
                crowd.most, crowd.when_s, crowd.who = len(near), sim_s, near

    def _door(self, c: DoorCriterion, sim_s: float, pose: tuple[float, float, float]) -> None:
        x, y, h = pose[0], pose[1], math.degrees(pose[2])
        d = self.doors.get(c.robot)
        if d is None:
            self.doors[c.robot] = _Door(x, y, h, last_deg=h, last_x=x, last_y=y)
            return
        step_deg = math.remainder(h - d.last_deg, 360.0)
        d.turn_deg += step_deg
        d.last_deg = h
        away_m = math.hypot(x - d.x0, y - d.y0)
        still = abs(step_deg) <= STILL_DEG and math.hypot(x - d.last_x, y - d.last_y) <= STILL_M
        d.last_x, d.last_y = x, y
        if d.opened_s is None and (away_m >= OPEN_M or abs(d.turn_deg) >= OPEN_DEG):
            d.opened_s = sim_s
        shut = still and away_m <= SHUT_M and abs(math.remainder(d.turn_deg, c.symmetry_deg)) <= SHUT_DEG
        if d.opened_s is not None and d.closed_s is None and shut:
            d.closed_s = sim_s

    def settled(self, criteria: tuple[DoorCriterion, ...]) -> bool:
        """Whether every door has done what it must (opened, closed again): a run that stops when
        its goals are reached waits for this too."""
        return all(self._lines_ok(c)[0] for c in criteria)

    def _lines_ok(self, c: DoorCriterion) -> tuple[bool, list[str]]:
        d = self.doors.get(c.robot)
        checks = [
            ("opened", c.opened, d.opened_s if d else None),
            ("closed again", c.closed_again, d.closed_s if d else None),
        ]
        lines: list[str] = []
        ok = True
        for what, asked, when in checks:
            if not asked:
                continue
            ok &= when is not None
            why = "never seen" if d is None else "it never did"
            done = f" at t={when:.1f} s" if when is not None else f": {why}"
            lines.append(f"{'PASS' if when is not None else 'FAIL'} door {c.robot} {what}{done}")
        return ok, lines

    def verdict(self, criteria: tuple[DoorCriterion, ...]) -> tuple[bool, list[str]]:
        """Whether every door criterion holds, and a line per criterion."""
        ok = True
        lines: list[str] = []
        for i, c in enumerate(criteria):
            good, mine = self._lines_ok(c)
            ok &= good
            lines += mine
            if c.one_chair_within_m is not None:
                crowd = self.crowds.get(i, _Crowd())
                good = crowd.most <= 1
                ok &= good
                where = f"within {c.one_chair_within_m:g} m of ({c.x_m:g}, {c.y_m:g})"
                who = ", ".join(map(str, crowd.who))
                lines.append(
                    f"PASS door {c.robot}: never two chairs {where}"
                    if good
                    else f"FAIL door {c.robot}: chairs {who} {where} at t={crowd.when_s:.1f} s"
                )
        return ok, lines
