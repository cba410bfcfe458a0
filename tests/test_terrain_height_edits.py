"""The height edits (contactnet.terrain.height_edits): a stone's top, a grid cell raised or lowered, the
schema's bound, and undo/redo through EditHistory."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from contactnet.terrain import Terrain, raised_stones, random_field, random_heights, stepping_stones
from contactnet.terrain.edits import EditError, EditHistory
from contactnet.terrain.height_edits import cell_square, raise_cell, region_top_z, set_region_height


@pytest.fixture
def stones() -> dict:
    return raised_stones().to_dict()


@pytest.fixture
def field() -> dict:
    return random_field(80, 0).to_dict()


def free_cell_centre(grid: dict) -> tuple[tuple[float, float], list[int]]:
    """The centre of a cell still in the grid, and that cell."""
    removed = {tuple(c) for c in grid.get("removed", [])}
    col, row = next((c, r) for r in range(grid["rows"]) for c in range(grid["cols"]) if (c, r) not in removed)
    (ox, oy), cell = grid["origin"], grid["cell"]
    return (ox + (col + 0.5) * cell, oy + (row + 0.5) * cell), [col, row]


def without_region(data: dict, index: int) -> dict:
    out = copy.deepcopy(data)
    del out["regions"][index]
    return out


def test_set_region_height_moves_that_top_only(stones):
    index = 3
    before = copy.deepcopy(stones)
    raised = set_region_height(stones, index, 0.08)
    assert raised["regions"][index]["z"] == 0.08
    assert region_top_z(raised, index) == 0.08
    assert without_region(raised, index) == without_region(stones, index)  # every other region as it was
    assert {k: v for k, v in raised["regions"][index].items() if k != "z"} == {
        k: v for k, v in stones["regions"][index].items() if k != "z"}
    assert stones == before  # the input is untouched
    terrain = Terrain.from_dict(raised)
    centre = stones["regions"][index]["center"]
    assert float(terrain.height_at(centre)) == pytest.approx(0.08)


def test_set_region_height_on_a_region_without_z(stones):
    assert "z" not in stones["regions"][0]  # the start platform, at surface_z
    assert set_region_height(stones, 0, 0.0) == stones  # asked to stay at surface_z: nothing changes
    lowered = set_region_height(stones, 0, -0.02)
    assert lowered["regions"][0]["z"] == -0.02
    assert float(Terrain.from_dict(lowered).height_at((0.0, 0.0))) == pytest.approx(-0.02)


def test_set_region_height_refuses_out_of_bounds_naming_the_field(stones):
    for z in (0.51, -0.6, float("nan"), float("inf"), "high", True):
        with pytest.raises(EditError, match=r"regions\[2\]\.z") as info:
            set_region_height(stones, 2, z)
        assert "\n" not in str(info.value)
    assert "within 0.5 m of surface_z" in str(pytest.raises(EditError, set_region_height, stones, 2, 0.7).value)
    set_region_height(stones, 2, 0.5)  # the bound itself is allowed
    with pytest.raises(EditError, match="no region 99"):
        set_region_height(stones, 99, 0.01)


def test_the_bound_follows_surface_z():
    data = stepping_stones().to_dict()
    data["surface_z"] = 1.0
    assert set_region_height(data, 1, 1.4)["regions"][1]["z"] == 1.4
    with pytest.raises(EditError, match=r"regions\[1\]\.z: \+0\.400 m is out of range"):
        set_region_height(data, 1, 0.4)


def test_raise_a_grid_cell_cuts_it_out_and_adds_a_rect(field):
    grid = field["regions"][1]
    xy, cell = free_cell_centre(grid)
    raised = raise_cell(field, xy, 0.03)
    assert len(raised["regions"]) == len(field["regions"]) + 1
    new_grid = raised["regions"][1]
    assert cell in new_grid["removed"] and len(new_grid["removed"]) == len(grid["removed"]) + 1
    assert {k: v for k, v in new_grid.items() if k != "removed"} == {k: v for k, v in grid.items() if k != "removed"}
    rect = raised["regions"][-1]
    assert rect["shape"] == "rect" and rect["z"] == 0.03 and rect["size"] == [0.05, 0.05]
    assert rect["center"] == pytest.approx(xy)
    assert raised["regions"][0] == field["regions"][0] and raised["regions"][2] == field["regions"][2]
    before, after = Terrain.from_dict(field), Terrain.from_dict(raised)
    assert after.steppable.area == pytest.approx(before.steppable.area, abs=1e-9)  # the same ground
    assert float(after.height_at(xy)) == pytest.approx(0.03)
    points = np.random.default_rng(0).uniform((-0.3, -0.3), (2.3, 0.3), (20_000, 2))
    outside_cell = np.abs(points - xy).max(axis=1) > 0.026
    assert np.array_equal(after.height_at(points[outside_cell], outside=-1.0),
                          before.height_at(points[outside_cell], outside=-1.0))  # nothing else moved
    # the cell is now its own rect: raising it again changes only its z
    again = raise_cell(raised, (xy[0] + 0.01, xy[1] - 0.01), 0.01)
    assert len(again["regions"]) == len(raised["regions"])
    assert again["regions"][-1]["z"] == 0.04  # rounded: no 0.04000000000000001
    lowered = raise_cell(again, xy, -0.07)
    assert lowered["regions"][-1]["z"] == -0.03
    assert float(Terrain.from_dict(lowered).height_at(xy)) == pytest.approx(-0.03)


def test_raise_a_cell_of_random_heights_changes_its_z():
    data = random_heights(80, 0).to_dict()
    index = 5
    square = data["regions"][index]
    assert square["size"] == [0.05, 0.05]
    raised = raise_cell(data, square["center"], 0.01)
    assert raised["regions"][index]["z"] == pytest.approx(square["z"] + 0.01, abs=1e-9)
    assert without_region(raised, index) == without_region(data, index)
    assert cell_square(data, square["center"])[0] == index


def test_raise_cell_refuses_platforms_stones_and_holes(stones, field):
    with pytest.raises(EditError, match="set its stone height instead"):
        raise_cell(stones, (0.0, 0.0), 0.01)  # the platform
    with pytest.raises(EditError, match="set its stone height instead"):
        raise_cell(stones, stones["regions"][1]["center"], 0.01)  # a stone
    with pytest.raises(EditError, match="no ground at"):
        raise_cell(field, (0.3, 3.0), 0.01)
    grid = field["regions"][1]
    col, row = grid["removed"][0]
    hole = (grid["origin"][0] + (col + 0.5) * 0.05, grid["origin"][1] + (row + 0.5) * 0.05)
    with pytest.raises(EditError, match="no ground at"):
        raise_cell(field, hole, 0.01)


def test_raise_cell_refuses_out_of_bounds_naming_the_field(field):
    xy, _ = free_cell_centre(field["regions"][1])
    with pytest.raises(EditError, match=r"regions\[3\]\.z: \+0\.600 m is out of range") as info:
        raise_cell(field, xy, 0.6)  # the new rect would be regions[3]
    assert "\n" not in str(info.value)
    raised = raise_cell(field, xy, 0.45)
    with pytest.raises(EditError, match=r"regions\[3\]\.z"):
        raise_cell(raised, xy, 0.1)
    with pytest.raises(EditError, match="finite height step"):
        raise_cell(field, xy, float("nan"))


def test_undo_and_redo_of_height_edits(stones, field):
    history = EditHistory(stones)
    assert history.apply(set_region_height(history.current, 4, 0.1))
    assert history.apply(set_region_height(history.current, 4, 0.12))
    assert not history.apply(set_region_height(history.current, 4, 0.12))  # no change, no step
    assert history.undo()["regions"][4]["z"] == 0.1
    assert history.undo() == stones
    assert history.redo()["regions"][4]["z"] == 0.1
    assert history.redo()["regions"][4]["z"] == 0.12
    assert not history.can_redo

    grid_history = EditHistory(field)
    xy, _ = free_cell_centre(field["regions"][1])
    grid_history.apply(raise_cell(grid_history.current, xy, 0.02))
    grid_history.apply(raise_cell(grid_history.current, xy, -0.01))
    assert grid_history.current["regions"][-1]["z"] == 0.01
    grid_history.undo()
    assert grid_history.current["regions"][-1]["z"] == 0.02
    assert grid_history.undo() == field
    assert grid_history.redo()["regions"][-1]["z"] == 0.02
