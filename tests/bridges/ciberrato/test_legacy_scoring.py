"""The legacy robot state machine and scores (fact sheet sections 7.8 and 7.9)."""

from __future__ import annotations

import math

import pytest
from iw_zenoh.bridges.ciberrato.scoring import Mode, PathLength, RobotGame, StepInput, control_loop, target_at

from iw_zenoh.core.lab import Lab, Target
from tests.support.builders import box_wall

OPEN = Lab("open", 10.0, 10.0, (), (), (Target(8.0, 8.0, 1.0), Target(2.0, 2.0, 1.0)))


def _run(g: RobotGame, now: int, x: float, y: float, **kw: bool) -> None:
    g.step(StepInput(now=now, running=kw.pop("running", True), x=x, y=y, **kw))


def test_a_straight_path_in_an_open_lab_is_its_length() -> None:
    d = PathLength(OPEN, (2.0, 2.0))
    assert d(5.0, 6.0) == pytest.approx(5.0)


def test_the_path_of_a_disc_wraps_round_a_walls_grown_end() -> None:
    lab = Lab("wall", 10.0, 10.0, (box_wall(4.9, 0.0, 5.1, 6.0),))
    d = PathLength(lab, (2.0, 5.0))
    # analytic: tangent from the start to the circle of radius 0.5 round the wall's corner, the
    # arc over it, the wall's 0.2 m top, and the same down to the goal
    c, r = (4.9, 6.0), 0.5
    big = math.dist((2.0, 5.0), c)
    tangent_at = math.atan2(5.0 - c[1], 2.0 - c[0]) % (2 * math.pi) - math.acos(r / big)
    side = math.sqrt(big**2 - r**2) + r * (tangent_at - math.pi / 2)
    assert d(8.0, 5.0) == pytest.approx(2 * side + 0.2, rel=3e-3)
    assert d(8.0, 5.0) > math.dist((2.0, 5.0), (8.0, 5.0)) + 0.5  # not through the wall


def test_a_robot_waits_stopped_then_runs_with_the_simulator() -> None:
    g = RobotGame(OPEN, start=(5.0, 5.0))
    assert g.state == "Stopped"
    _run(g, 0, 5.0, 5.0, running=False)
    assert g.state == "Stopped"
    _run(g, 1, 5.0, 5.0)
    assert g.state == "Running"
    _run(g, 1, 5.0, 5.0, running=False)
    assert g.state == "Stopped"
    assert g.remembered == "Running"


def test_competitive_visits_penalties_and_the_return_home() -> None:
    g = RobotGame(OPEN, start=(2.0, 2.0))
    assert g.pen == 300  # 100 + 100 per target
    _run(g, 1, 5.0, 5.0, visiting_led=True)  # off target: +5 every such cycle
    assert (g.pen, g.score, g.arrival_time) == (305, 405, 1)
    _run(g, 2, 8.0, 8.0, visiting_led=True)  # on target 0
    assert g.visited == [True, False]
    assert g.pen == 205
    assert g.visited_mask == "10"
    _run(g, 3, 8.0, 8.0, visiting_led=True)  # already visited: nothing more
    assert g.pen == 205
    assert g.arrival_time == 1
    _run(g, 4, 2.0, 2.0, visiting_led=True)  # target 1, the start
    assert g.visited == [True, True]
    assert g.pen == 105
    _run(g, 5, 2.0, 2.0, returning_led=True)  # on a target, all visited: start returning
    assert g.state == "Returning"
    assert g.pen == 5
    assert g.score == 105
    _run(g, 6, 2.0, 2.0)
    assert g.returning_time == 1
    assert g.score == 5 + 100


def test_returning_led_away_from_the_targets_finishes_the_robot() -> None:
    g = RobotGame(OPEN, start=(2.0, 2.0))
    _run(g, 1, 5.0, 5.0)  # the first Running step takes it from Stopped to Running
    _run(g, 2, 5.0, 5.0, returning_led=True)
    assert g.finished
    score = g.score
    _run(g, 3, 8.0, 8.0, visiting_led=True)  # a Finished robot scores no more
    assert g.score == score
    assert g.visited == [False, False]


def test_collisions_count_rising_edges_and_their_penalties() -> None:
    g = RobotGame(OPEN, start=(2.0, 2.0), wall_penalty=2, robot_penalty=3)
    pen = g.pen
    _run(g, 1, 5.0, 5.0, collision=True, hit_wall=True)
    _run(g, 2, 5.0, 5.0, collision=True, hit_wall=True)  # still touching: no new one
    _run(g, 3, 5.0, 5.0)
    _run(g, 4, 5.0, 5.0, collision=True, hit_wall=True, hit_robot=True)
    assert g.collisions == 2
    assert g.pen == pen + 2 + 5


def test_control_mode_scores_the_cells_of_the_labs_loop() -> None:
    lab = Lab("ring", 6.0, 6.0, (box_wall(2.0, 2.0, 4.0, 4.0),))  # 3 x 3 cells round a block
    loop = control_loop(lab, 1.0, 1.0)
    assert loop is not None
    assert len(loop) == 8
    assert loop[0] == (0, 0)
    assert loop[1] == (1, 0)
    g = RobotGame(lab, mode=Mode.CONTROL, start=(1.0, 1.0))
    assert g.pen == 0
    _run(g, 1, 1.0, 1.0)
    _run(g, 2, 3.0, 1.0)  # the next cell of the loop
    _run(g, 3, 3.2, 1.0)  # still there: once
    _run(g, 4, 5.0, 1.0)
    assert g.score == 20
    _run(g, 5, 5.0, 1.0, collision=True, hit_wall=True)
    assert g.score == 18  # control subtracts penalties
    _run(g, 6, 5.0, 1.0, end_led=True)
    assert g.score == -2
    assert g.finished


def test_control_mode_builds_its_loop_at_the_first_running_step_whatever_the_time() -> None:
    # a robot registered into a running world first runs at Time 300: the legacy simulator built
    # the loop only at Time 0, and such a robot scored nothing for ever
    lab = Lab("ring", 6.0, 6.0, (box_wall(2.0, 2.0, 4.0, 4.0),))
    g = RobotGame(lab, mode=Mode.CONTROL, start=(1.0, 1.0))
    _run(g, 300, 1.0, 1.0, running=False)
    _run(g, 301, 1.2, 1.0)
    _run(g, 302, 3.0, 1.0)
    _run(g, 303, 5.0, 1.0)
    assert g.score == 20


def test_the_control_loop_goes_east_first_whatever_turn_is_free() -> None:
    # an open lab of 3 x 3 cells: from (0, 1) a right turn (south) is free, yet the legacy loop's
    # first cell is the one east of the start
    lab = Lab("open", 6.0, 6.0)
    assert control_loop(lab, 1.0, 3.0) == [(0, 1), (1, 1), (1, 0), (0, 0)]


def test_a_lab_without_a_loop_has_none() -> None:
    lab = Lab("split", 6.0, 2.0, (box_wall(1.9, 0.0, 2.1, 2.0),))
    assert control_loop(lab, 1.0, 1.0) is None


def test_mapping_mode_never_returns_and_starts_from_zero() -> None:
    g = RobotGame(OPEN, mode=Mode.MAPPING, start=(2.0, 2.0))
    assert g.pen == 0
    _run(g, 1, 8.0, 8.0, visiting_led=True)
    _run(g, 2, 2.0, 2.0, visiting_led=True)
    _run(g, 3, 2.0, 2.0, returning_led=True)
    _run(g, 4, 2.0, 2.0, returning_led=True)
    assert g.state == "Running"
    assert g.pen == -400
    _run(g, 5, 2.0, 2.0, end_led=True)
    assert g.finished


def test_the_first_target_holding_the_whole_disc() -> None:
    assert target_at(OPEN, 8.4, 8.0) == 0
    assert target_at(OPEN, 8.6, 8.0) == -1  # the disc sticks out


def test_removal_ends_every_state_and_nothing_scores_after() -> None:
    for last in ("Stopped", "Running", "Finished"):
        g = RobotGame(OPEN, start=(2.0, 2.0))
        if last != "Stopped":
            _run(g, 1, 5.0, 5.0)
        if last == "Finished":
            _run(g, 2, 5.0, 5.0, end_led=True)
        assert g.state == last
        g.step(StepInput(now=3, running=True, x=8.0, y=8.0, removed=True))
        score = g.score
        _run(g, 4, 8.0, 8.0, visiting_led=True)
        assert g.state == "Removed"
        assert g.score == score
