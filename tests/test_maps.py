from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.core.lab import Beacon, Grid, GridPosition, Lab, Scene, Target, Wall
from iw_zenoh.errors import MapError
from iw_zenoh.maps import (
    check_grid,
    grid_to_xml,
    lab_to_xml,
    load_grid,
    load_lab,
    load_parameters,
    parse_grid,
    parse_lab,
    parse_parameters,
    row_walls,
)

MAPS = Path(__file__).resolve().parents[1] / "maps"


@pytest.mark.parametrize(
    "name",
    [
        "liacc.xml",
        "thesis_example.xml",
        "hospital.xml",
        *[f"ciberrato/{p.name}" for p in sorted((MAPS / "ciberrato").glob("*[Ll]ab*.xml"))],
        "ciberrato/Ciber2001Final.xml",
    ],
)
def test_every_shipped_lab_loads(name: str) -> None:
    lab = load_lab(MAPS / name)
    assert lab.walls
    assert Scene(lab).free_space.area > 0


@pytest.mark.parametrize(
    ("lab", "grid"),
    [
        ("hospital.xml", "hospital-grid.xml"),
        ("ciberrato/C1-lab.xml", "ciberrato/C1-grid.xml"),
        ("ciberrato/Ciber2009_FinalLab.xml", "ciberrato/Ciber2009_FinalGrid.xml"),
    ],
)
def test_shipped_grids_fit_their_labs(lab: str, grid: str) -> None:
    g = load_grid(MAPS / grid, load_lab(MAPS / lab))
    assert g.positions


def test_the_hospital_floor_has_rooms_doorways_and_starts() -> None:
    lab = load_lab(MAPS / "hospital.xml")
    assert len(lab.targets) >= 6  # one per room
    grid = load_grid(MAPS / "hospital-grid.xml", lab)
    assert len(grid.positions) >= 20
    # a 1.0 m door leaf fits every doorway: the corridor walls leave gaps >= 1.0 m
    scene = Scene(lab)
    for x in (5.0, 15.0, 25.0, 35.0):
        for y in (7.9, 11.1):
            assert not scene.wall_union.intersects(__import__("shapely").box(x - 0.5, y - 0.05, x + 0.5, y + 0.05))


def test_c1_rows_become_45_walls_as_in_the_legacy_simulator() -> None:
    assert len(load_lab(MAPS / "ciberrato/C1-lab.xml").walls) == 45


def test_row_patterns_follow_the_legacy_rules() -> None:
    (v,) = row_walls(4, "     |")
    assert v.corners[0] == pytest.approx((2 * 6 / 3 - 0.1, 4.0))
    (h,) = row_walls(3, "--+--+  ")
    xs = [c[0] for c in h.corners]
    assert (min(xs), max(xs)) == pytest.approx((0.0, 4.0))
    assert row_walls(3, "      --+--") == []  # still open when the pattern ends: lost, as in Ciber-Rato


def test_parameters_keep_defaults_and_legacy_quirks() -> None:
    p = parse_parameters(
        b'<Parameters CycleTime="80" GPS="On" CompassSensor="on" CollisionLatency="3" collisionLatency="2"/>'
    )
    assert p.cycle_time_ms == 80
    assert p.gps is True
    assert p.compass_sensor is False  # only exactly "On" is on
    assert p.collision_latency == 2  # the lower-case spelling is the one read
    assert p.sim_time == 1800
    assert load_parameters(MAPS / "ciberrato/C1-config.xml").collision_wall_penalty == 5


def _refused(xml: str) -> MapError:
    with pytest.raises(MapError) as e:
        parse_lab(xml.encode(), "bad.xml")
    return e.value


@pytest.mark.parametrize(
    ("xml", "line", "element", "reason"),
    [
        (
            '<Lab Width="10" Height="10">\n<Wall><Corner X="1" Y="1"/><Corner X="2" Y="1"/></Wall></Lab>',
            2,
            "Wall",
            "at least 3 corners",
        ),
        (
            '<Lab Width="10" Height="10">\n\n<Wall><Corner X="1" Y="1"/><Corner X="two" Y="1"/><Corner X="2" Y="2"/></Wall></Lab>',
            3,
            "Corner",
            "not a number",
        ),
        (
            '<Lab Width="10" Height="10">\n<Wall><Corner X="1" Y="1"/><Corner X="3" Y="3"/><Corner X="3" Y="1"/><Corner X="1" Y="3"/></Wall></Lab>',
            2,
            "Wall",
            "crosses itself",
        ),
        (
            '<Lab Width="10" Height="10">\n<Wall><Corner X="8" Y="8"/><Corner X="12" Y="8"/><Corner X="12" Y="9"/></Wall></Lab>',
            2,
            "Wall",
            "outside the lab",
        ),
        (
            '<Lab Width="10" Height="10">\n<Wall><Corner X="nan" Y="1"/><Corner X="2" Y="1"/><Corner X="2" Y="2"/></Wall></Lab>',
            2,
            "Corner",
            "finite",
        ),
        ('<Lab Width="10" Height="10">\n<Beacon X="11" Y="1"/></Lab>', 2, "Beacon", "outside the lab"),
        ('<Lab Width="10" Height="10">\n<Door X="1"/></Lab>', 2, "Door", "unknown element"),
        (
            '<Lab Width="10" Height="10">\n<Wall><Corner X="1" Y="1"/><!-- c -->\n<Point X="2" Y="1"/></Wall></Lab>',
            3,
            "Point",
            "a <Wall> holds only <Corner> elements",
        ),
        ('<Lab Width="10" Height="10">\n<Wall>', 2, "document", "not well-formed"),
        ("<Grid/>", 1, "Grid", "must be <Lab>"),
        ('<!DOCTYPE Lab [<!ENTITY big "x">]><Lab Name="&big;"/>', 1, "document", "DOCTYPE"),
    ],
)
def test_broken_labs_are_refused_with_file_line_element_and_reason(
    xml: str, line: int, element: str, reason: str
) -> None:
    err = _refused(xml)
    assert err.source == "bad.xml"
    assert err.line == line
    assert err.element == element
    assert reason in str(err)
    assert str(err).startswith(f"bad.xml:{line}: <{element}>")


def test_external_entities_are_never_read(tmp_path: Path) -> None:
    secret = tmp_path / "secret.txt"
    secret.write_text("TOPSECRET")
    xml = f'<!DOCTYPE Lab [<!ENTITY s SYSTEM "file://{secret}">]><Lab Name="&s;"/>'
    err = _refused(xml)
    assert "TOPSECRET" not in str(err)


def test_a_grid_position_inside_a_wall_is_refused() -> None:
    lab = Lab("l", 10.0, 10.0, (Wall(((4, 4), (6, 4), (6, 6), (4, 6))),))
    with pytest.raises(MapError, match="position 2 .* inside wall 0"):
        check_grid(lab, Grid((GridPosition(1, 1), GridPosition(5, 5))), "g.xml")


def test_a_grid_dir_out_of_range_is_refused() -> None:
    with pytest.raises(MapError, match="Dir=200"):
        parse_grid(b'<Grid><Position X="1" Y="1" Dir="200"/></Grid>')


def test_a_grid_holds_only_positions() -> None:
    with pytest.raises(MapError, match="a <Grid> holds only <Position> elements") as e:
        parse_grid(b'<Grid><!-- a comment is fine --><Position X="1" Y="1"/><Pose X="1" Y="1"/></Grid>')
    assert e.value.element == "Pose"


def test_missing_files_say_so(tmp_path: Path) -> None:
    with pytest.raises(MapError, match="cannot read it"):
        load_lab(tmp_path / "nope.xml")


coord = st.floats(0.0, 10.0, allow_nan=False)


@st.composite
def labs(draw: st.DrawFn) -> Lab:
    walls = []
    for _ in range(draw(st.integers(0, 4))):
        x = draw(st.floats(0.0, 8.0))
        y = draw(st.floats(0.0, 8.0))
        w = draw(st.floats(0.01, 2.0))
        h = draw(st.floats(0.01, 2.0))
        walls.append(Wall(((x, y), (x + w, y), (x + w, y + h), (x, y + h)), draw(st.floats(0.1, 5.0))))
    beacons = tuple(Beacon(draw(coord), draw(coord), draw(st.floats(0.0, 5.0))) for _ in range(draw(st.integers(0, 2))))
    targets = tuple(Target(draw(coord), draw(coord), draw(st.floats(0.1, 3.0))) for _ in range(draw(st.integers(0, 2))))
    name = draw(st.text(st.characters(min_codepoint=32, max_codepoint=0x2FF, exclude_characters="\x7f"), max_size=20))
    return Lab(name, 10.0, 10.0, tuple(walls), beacons, targets)


@given(labs())
def test_a_lab_round_trips_through_xml(lab: Lab) -> None:
    assert parse_lab(lab_to_xml(lab)) == lab


@given(st.lists(st.tuples(coord, coord, st.floats(-180.0, 180.0)), max_size=6))
def test_a_grid_round_trips_through_xml(rows: list[tuple[float, float, float]]) -> None:
    grid = Grid(tuple(GridPosition(*r) for r in rows))
    assert parse_grid(grid_to_xml(grid)) == grid


def test_legacy_serialisation_puts_height_before_width() -> None:
    xml = lab_to_xml(Lab("L", 28.0, 14.0), legacy=True)
    assert xml.startswith(b'<Lab Name="L" Height="14" Width="28"')
