"""The pure terrain edit operations (contactnet.terrain.edits): holes, stones, moves, undo, names."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import box

from contactnet.terrain import Terrain, edits, random_field, stepping_stones


@pytest.fixture
def stones() -> dict:
    return stepping_stones().to_dict()


@pytest.fixture
def field() -> dict:
    return random_field(80, 0).to_dict()


def area(data: dict) -> float:
    return Terrain.from_dict(data).steppable.area


def test_punch_in_a_stone_removes_exactly_the_square(stones):
    """Punch inside the start platform: the square's area goes, the platform becomes hole-free
    polygons (the format has no interior rings) whose union is the punched shape."""
    punched = edits.punch_hole(stones, (0.12, 0.12))
    assert area(punched) == pytest.approx(area(stones) - 0.05**2, abs=1e-9)
    square = box(0.10, 0.10, 0.15, 0.15)
    terrain = Terrain.from_dict(punched)
    assert not terrain.is_safe(np.array([[0.125, 0.125]]))[0]
    assert terrain.is_safe(np.array([[0.09, 0.125], [0.16, 0.125]])).all()
    polygons = [r for r in punched["regions"] if r["shape"] == "polygon"]
    assert len(polygons) == 2  # cut in two through the hole
    union = shapely.union_all([shapely.Polygon(p["vertices"]) for p in polygons])
    assert union.symmetric_difference(box(-0.25, -0.25, 0.25, 0.25).difference(square)).area < 1e-12
    assert stones == stepping_stones().to_dict()  # the input is untouched


def test_punch_keeps_round_stones_round(stones):
    circle = next(i for i, r in enumerate(stones["regions"]) if r["shape"] == "circle")
    centre = stones["regions"][circle]["center"]
    punched = edits.punch_hole(stones, (centre[0] + 0.06, centre[1]))  # at the rim
    assert area(punched) < area(stones)
    assert all(r["shape"] != "grid" for r in punched["regions"])


def test_punch_in_a_grid_removes_the_cell_and_fill_restores_it(field):
    grid = field["regions"][1]
    removed = {tuple(c) for c in grid["removed"]}
    col, row = next((c, r) for r in range(grid["rows"]) for c in range(grid["cols"]) if (c, r) not in removed)
    xy = (grid["origin"][0] + (col + 0.5) * grid["cell"], grid["origin"][1] + (row + 0.5) * grid["cell"])
    punched = edits.punch_hole(field, xy)
    assert [r["shape"] for r in punched["regions"]] == [r["shape"] for r in field["regions"]]
    assert [col, row] in punched["regions"][1]["removed"]
    assert edits.fill_hole(punched, xy) == field


def test_fill_in_a_hole_adds_a_square_and_filling_solid_ground_changes_nothing(stones):
    filled = edits.fill_hole(stones, (0.71, 0.41))  # off every stone
    assert area(filled) == pytest.approx(area(stones) + 0.05**2, abs=1e-9)
    assert filled["regions"][-1] == {
        "shape": "rect",
        "center": [0.725, 0.425],
        "size": [0.05, 0.05],
        "yaw": 0.0,
    }
    assert edits.fill_hole(stones, (0.0, 0.0)) == stones


def test_punch_fill_round_trip_restores_the_surface(stones):
    punched = edits.punch_hole(stones, (0.12, 0.12))
    restored = edits.fill_hole(punched, (0.12, 0.12))
    assert area(restored) == pytest.approx(area(stones), abs=1e-9)


def test_a_hole_under_the_start_is_refused(stones):
    data = stones
    for xy in [(0.01, 0.01), (-0.01, 0.01), (0.01, -0.01)]:  # the start (0, 0) is their shared corner
        data = edits.punch_hole(data, xy)
    with pytest.raises(edits.EditError, match="start"):
        edits.punch_hole(data, (-0.01, -0.01))


def test_squares_snap_to_the_lattice(stones):
    assert edits.snap_square(stones, (0.123, -0.001)) == pytest.approx((0.10, -0.05, 0.15, 0.0))
    with pytest.raises(edits.EditError):
        edits.snap_square(stones, (math.nan, 0.0))


@pytest.mark.parametrize("shape", edits.STONE_SHAPES)
def test_add_move_delete_a_stone(stones, shape):
    added = edits.add_stone(stones, shape, (0.7, 0.4))
    index = len(added["regions"]) - 1
    assert added["regions"][index]["shape"] == shape
    assert edits.region_at(added, (0.7, 0.4)) == index
    moved = edits.move_region(added, index, (0.75, 0.45), yaw=0.3)
    (x, y), yaw = edits.region_pose(moved["regions"][index])
    assert (x, y) == pytest.approx((0.75, 0.45))
    assert yaw == pytest.approx(0.0 if shape == "circle" else 0.3)
    assert area(moved) == pytest.approx(area(added), rel=1e-6)
    assert edits.delete_region(moved, index) == stones


def test_moving_a_polygon_keeps_its_area_and_turns_it(stones):
    punched = edits.punch_hole(stones, (0.12, 0.12))
    index = next(i for i, r in enumerate(punched["regions"]) if r["shape"] == "polygon")
    before = shapely.Polygon(punched["regions"][index]["vertices"])
    moved = edits.move_region(punched, index, (2.0, 1.0), yaw=math.pi / 2)
    after = shapely.Polygon(moved["regions"][index]["vertices"])
    assert after.area == pytest.approx(before.area)
    assert (after.centroid.x, after.centroid.y) == pytest.approx((2.0, 1.0))


def test_bad_edits_name_the_problem(stones):
    with pytest.raises(edits.EditError, match="unknown stone shape"):
        edits.add_stone(stones, "hexagon", (0.5, 0.5))
    with pytest.raises(edits.EditError, match="no region"):
        edits.move_region(stones, 99, (0.0, 0.0))
    only_start = {**stones, "regions": stones["regions"][:1]}
    with pytest.raises(edits.EditError, match="last region"):
        edits.delete_region(only_start, 0)
    with pytest.raises(edits.EditError, match="start"):
        edits.delete_region(stones, 0)  # the start platform


def test_undo_history(stones):
    history = edits.EditHistory(stones, limit=3)
    assert not history.can_undo
    states = [stones]
    for k in range(5):
        new = edits.add_stone(history.current, "circle", (0.6 + 0.2 * k, 0.4))
        assert history.apply(new)
        states.append(new)
    assert not history.apply(history.current)  # no change, no undo step
    for expected in reversed(states[-4:-1]):  # only `limit` steps are kept
        assert history.undo() == expected
    with pytest.raises(edits.EditError, match="nothing to undo"):
        history.undo()


@pytest.mark.parametrize(
    "name", ["../evil", "a/b", "a.b", "", ".hidden", "x" * 65, "white space", "..", "C:\\x"]
)
def test_bad_names_are_refused(name):
    with pytest.raises(edits.EditError, match="invalid terrain name"):
        edits.validate_name(name)
