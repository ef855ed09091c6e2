from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.core import sonarmap
from iw_zenoh.core.sonarmap import Cone, SonarMap


def _map() -> SonarMap:
    return SonarMap(np.zeros((100, 100), dtype=bool), 0.05)


def test_a_reading_marks_its_arc_and_carves_what_is_nearer() -> None:
    m = _map()
    new = m.update([Cone(1.0, 2.5, 0.0, math.radians(7.5), 3.0, 1.0)])
    assert len(new) > 0
    assert np.all(np.abs(np.hypot(new[:, 0] - 1.0, new[:, 1] - 2.5) - 1.0) < 0.06)  # on the arc at 1 m
    assert np.all(np.abs(new[:, 1] - 2.5) < 0.15)  # and inside the 15-degree cone
    r, c = int(2.5 / 0.05), int(1.5 / 0.05)
    assert m.carved_at[r, c] == 1  # half a metre ahead: free
    assert not m.occupied[r, c]


def test_nothing_in_range_only_carves() -> None:
    m = _map()
    assert len(m.update([Cone(1.0, 2.5, 0.0, math.radians(7.5), 2.0, None)])) == 0
    assert not m.occupied.any()
    assert m.carved_at[int(2.5 / 0.05), int(2.9 / 0.05)] == 1


def test_a_cell_seen_free_lately_is_not_marked_and_a_later_view_clears_a_wrong_mark() -> None:
    m = _map()
    m.update([Cone(1.0, 2.5, 0.0, math.radians(7.5), 3.0, 1.0)])
    assert m.occupied[int(2.5 / 0.05), int(2.0 / 0.05)]
    # looking from the side through the same place, the cone reads 2 m: the mark was wrong
    m.update([Cone(2.0, 1.0, math.pi / 2, math.radians(7.5), 3.0, 2.5)])
    assert not m.occupied[int(2.5 / 0.05), int(2.0 / 0.05)]


def test_a_reading_the_map_explains_carves_but_does_not_mark() -> None:
    m = _map()
    assert len(m.update([Cone(1.0, 2.5, 0.0, math.radians(7.5), 3.0, 1.0, mark=False)])) == 0
    assert not m.occupied.any()


def test_known_walls_are_not_marked_again() -> None:
    known = np.zeros((100, 100), dtype=bool)
    known[:, 40:42] = True  # a wall at x = 2.0
    m = SonarMap(known, 0.05)
    assert len(m.update([Cone(1.0, 2.5, 0.0, math.radians(7.5), 3.0, 1.0)])) == 0


def test_a_narrow_cone_near_a_mark_finds_it_though_no_cell_centre_lies_inside() -> None:
    m = SonarMap(np.zeros((40, 40), dtype=bool), 0.05)
    m.occupied[10, 14] = True  # the cell 0.70-0.75 x 0.50-0.55, centre (0.725, 0.525)
    # a 5-degree cone 0.25 m away looking past the centre: it crosses the cell, not its centre
    cone = Cone(0.45, 0.5, math.radians(2.0), math.radians(2.5), 3.0, 0.27)
    assert 0.2 < m.nearest(cone) < 0.3
    assert m.nearest(Cone(0.45, 0.5, math.radians(30.0), math.radians(2.5), 3.0, 0.27)) == math.inf


def _whole_circle(cone: Cone, reach: float, c: float, rows: int, cols: int) -> tuple[int, int, int, int]:
    """The window before it was cut to the cone's sector: the box of the whole circle."""
    return (
        max(0, int((cone.y - reach) / c) - 1),
        min(rows, int((cone.y + reach) / c) + 2),
        max(0, int((cone.x - reach) / c) - 1),
        min(cols, int((cone.x + reach) / c) + 2),
    )


_cone = st.builds(
    Cone,
    x=st.floats(-0.5, 6.5),
    y=st.floats(-0.5, 4.5),
    angle_rad=st.floats(-7.0, 7.0),
    half_rad=st.sampled_from([0.04, 0.3, 0.52, 1.2, 1.6, 3.2]),
    range_m=st.floats(0.3, 3.0),
    distance_m=st.none() | st.floats(0.05, 3.5),
    mark=st.booleans(),
)


@given(ticks=st.lists(st.lists(_cone, max_size=6), min_size=1, max_size=4))
def test_looking_only_at_the_cells_of_the_cones_sector_maps_exactly_as_the_whole_circle(
    ticks: list[list[Cone]],
) -> None:
    known = np.zeros((80, 120), dtype=bool)
    known[30:34, 50:70] = True
    cut, whole = SonarMap(known, 0.05, forget_ticks=2), SonarMap(known, 0.05, forget_ticks=2)
    for cones in ticks:
        got = cut.update(cones)
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(sonarmap, "_window", _whole_circle)
            want = whole.update(cones)
        assert np.array_equal(got, want)
        assert np.array_equal(cut.occupied, whole.occupied)
        assert np.array_equal(cut.confirmed, whole.confirmed)
        assert np.array_equal(cut.carved_at, whole.carved_at)
