"""Terrain.height_at and Terrain.ground_z against a slow, obvious point-by-point shapely reference."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import shapely
from shapely.geometry import Point

from contactnet import terrain as T
from contactnet.terrain import Terrain

SNAP_TOLERANCE_M = 1e-9
"""The steppable union snaps coordinates to a 1e-9 m grid, so the fast answer may differ from the
region-by-region reference only this close to an edge (e.g. at x = 0.25 + 7 * 0.05 = 0.6000000000000001)."""


def lifted(terrain: Terrain, surface_z: float) -> Terrain:
    """The same terrain with its regions' tops (and nominal level) at ``surface_z``."""
    return Terrain.from_dict({**terrain.to_dict(), "surface_z": surface_z})


def all_shapes() -> Terrain:
    return Terrain.from_dict({
        "name": "all_shapes", "start": [0.0, 0.0], "goal_x": 1.0, "surface_z": -0.03, "regions": [
            {"shape": "rect", "center": [0.0, 0.0], "size": [0.6, 0.5], "yaw": 0.3},
            {"shape": "circle", "center": [0.45, 0.1], "radius": 0.1},
            {"shape": "star", "center": [0.65, -0.1], "outer_radius": 0.12, "inner_radius": 0.06, "points": 5,
             "yaw": 0.2},
            {"shape": "polygon",
             "vertices": [[0.8, 0.0], [1.0, -0.1], [1.1, 0.1], [0.95, 0.05], [0.85, 0.2]]},
            {"shape": "grid", "origin": [1.1, -0.25], "cell": 0.05, "cols": 6, "rows": 10,
             "removed": [[0, 0], [3, 4], [5, 9], [2, 4], [3, 5]]},
        ]})


TERRAINS: dict[str, Callable[[], Terrain]] = {
    "random_80_0_at_0.25": lambda: lifted(T.random_field(80, 0), 0.25),
    "random_200_3": lambda: T.random_field(200, 3),
    "stepping_stones": T.stepping_stones,
    "push_field_at_-0.1": lambda: lifted(T.push_field(), -0.1),
    "all_shapes": all_shapes,
}


def reference_heights(terrain: Terrain, points_xy: np.ndarray, outside: float) -> np.ndarray:
    """Slow and obvious: a point has a top, at ``surface_z``, when one of the terrain's regions covers it."""
    regions = [T.region_geometry(r) for r in terrain.regions]
    return np.array([terrain.surface_z if any(g.covers(Point(p)) for g in regions) else outside
                     for p in points_xy], dtype=float)


def grid_points(terrain: Terrain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centres of removed cells, centres of present cells, cell corners and edge midpoints) of the grids."""
    removed, present, edges = [], [], []
    for region in terrain.regions:
        if region["shape"] != "grid":
            continue
        (ox, oy), cell = region["origin"], region["cell"]
        holes = {tuple(c) for c in region["removed"]}
        for col in range(region["cols"]):
            for row in range(region["rows"]):
                centre = (ox + (col + 0.5) * cell, oy + (row + 0.5) * cell)
                (removed if (col, row) in holes else present).append(centre)
        corner_x = ox + cell * np.arange(region["cols"] + 1)
        corner_y = oy + cell * np.arange(region["rows"] + 1)
        mid_x = ox + cell * (np.arange(region["cols"]) + 0.5)
        mid_y = oy + cell * (np.arange(region["rows"]) + 0.5)
        for xs, ys in ((corner_x, corner_y), (corner_x, mid_y), (mid_x, corner_y)):
            edges.extend(np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2))
    return (np.reshape(removed, (-1, 2)), np.reshape(present, (-1, 2)), np.reshape(edges, (-1, 2)))


def query_points(terrain: Terrain, rng: np.random.Generator, n: int = 1500) -> np.ndarray:
    """Uniform points (many over holes), grid cell corners and edge midpoints, points next to the vertices."""
    minx, miny, maxx, maxy = terrain.bounds
    uniform = rng.uniform((minx - 0.05, miny - 0.05), (maxx + 0.05, maxy + 0.05), (n, 2))
    vertices_xy = shapely.get_coordinates(terrain.steppable)
    near_vertices = vertices_xy[rng.integers(0, len(vertices_xy), n // 3)]
    near_vertices = near_vertices + rng.normal(0.0, 1e-4, (n // 3, 2))
    return np.concatenate([uniform, grid_points(terrain)[2], near_vertices])


def assert_matches_reference(terrain: Terrain, points_xy: np.ndarray, heights: np.ndarray,
                             expected: np.ndarray) -> None:
    same = (heights == expected) | (np.isnan(heights) & np.isnan(expected))
    for i in np.flatnonzero(~same):
        distance = terrain.steppable.boundary.distance(Point(points_xy[i]))
        assert distance <= SNAP_TOLERANCE_M, (points_xy[i], heights[i], expected[i], distance)


@pytest.mark.parametrize("name", list(TERRAINS))
def test_height_at_matches_the_region_by_region_reference(name: str) -> None:
    terrain = TERRAINS[name]()
    points_xy = query_points(terrain, np.random.default_rng(sum(map(ord, name))))
    heights = terrain.height_at(points_xy)
    assert heights.dtype == np.float64 and heights.shape == (len(points_xy),)
    assert_matches_reference(terrain, points_xy, heights, reference_heights(terrain, points_xy, np.nan))
    assert np.isnan(heights).any() and (heights == terrain.surface_z).any()  # both holes and tops were asked
    assert set(np.unique(heights[~np.isnan(heights)])) == {terrain.surface_z}
    # the same raster as is_safe at margin 0, and small batches (direct shapely path) agree with large ones
    np.testing.assert_array_equal(~np.isnan(heights), terrain.is_safe(points_xy, 0.0))
    small = np.concatenate([terrain.height_at(points_xy[i:i + 7]) for i in range(0, 70, 7)])
    np.testing.assert_array_equal(small, heights[:70])
    singles = np.array([terrain.height_at(p) for p in points_xy[:40]])
    np.testing.assert_array_equal(singles, heights[:40])


@pytest.mark.parametrize("name", list(TERRAINS))
def test_ground_z_is_the_top_where_steppable_else_the_nominal_level(name: str) -> None:
    terrain = TERRAINS[name]()
    points_xy = query_points(terrain, np.random.default_rng(sum(map(ord, name)) + 1))
    ground = terrain.ground_z(points_xy)
    assert ground.dtype == np.float64 and ground.shape == (len(points_xy),)
    expected = reference_heights(terrain, points_xy, terrain.surface_z)
    assert_matches_reference(terrain, points_xy, ground, expected)
    np.testing.assert_array_equal(ground, terrain.height_at(points_xy, outside=terrain.surface_z))
    assert np.isfinite(terrain.ground_z(np.array([[np.nan, 0.0], [0.0, np.inf], [1e300, 0.0]]))).all()


def test_random_field_holes_cells_and_edges() -> None:
    """The paper's field: every removed cell is a hole, every present cell a top, edges as the reference."""
    terrain = lifted(T.random_field(80, 0), 0.25)
    removed, present, edges = grid_points(terrain)
    assert len(removed) == 80 and len(present) == 220
    assert np.isnan(terrain.height_at(removed)).all()
    np.testing.assert_array_equal(terrain.height_at(removed, outside=-1.0), -1.0)
    np.testing.assert_array_equal(terrain.height_at(present), 0.25)
    np.testing.assert_array_equal(terrain.ground_z(removed), 0.25)
    np.testing.assert_array_equal(terrain.ground_z(present), 0.25)
    heights = terrain.height_at(edges)
    assert_matches_reference(terrain, edges, heights, reference_heights(terrain, edges, np.nan))
    # corners where four holes meet, or a hole meets the outside, have nothing to stand on; the seam
    # between the start platform and the field (x = 0.25, exactly representable) is covered
    assert np.isnan(heights).any()
    seam_xy = np.column_stack([np.full(11, 0.25), np.linspace(-0.25, 0.25, 11)])
    np.testing.assert_array_equal(terrain.height_at(seam_xy), 0.25)


@pytest.mark.parametrize("name", list(TERRAINS))
def test_the_steppable_outline_itself_has_a_top(name: str) -> None:
    """Points exactly on the union's vertices are on its boundary, which counts as steppable."""
    terrain = TERRAINS[name]()
    vertices_xy = shapely.get_coordinates(terrain.steppable)
    np.testing.assert_array_equal(terrain.height_at(vertices_xy), terrain.surface_z)


def test_height_at_edges_holes_shapes_and_bad_input() -> None:
    terrain = lifted(T.flat((4.0, 2.0)), 0.1)
    on_edge = terrain.height_at([[2.0, 0.0], [-2.0, 1.0], [0.0, -1.0]])
    np.testing.assert_array_equal(on_edge, 0.1)  # the boundary is steppable, as in is_safe
    assert np.isnan(terrain.height_at([[2.0 + 1e-9, 0.0], [0.0, 1.0 + 1e-9]])).all()
    single = terrain.height_at((0.3, 0.2))
    assert isinstance(single, np.ndarray) and single.shape == () and single.dtype == np.float64
    assert float(single) == 0.1 and np.isnan(terrain.height_at([5.0, 0.0]))
    assert terrain.ground_z([5.0, 0.0]).shape == () and float(terrain.ground_z([5.0, 0.0])) == 0.1
    assert terrain.height_at(np.zeros((0, 2))).shape == (0,)
    assert terrain.ground_z(np.zeros((0, 2))).shape == (0,)
    bad = np.array([[np.nan, 0.0], [0.0, np.inf], [-np.inf, 0.0], [1e300, 0.0]] * 20)
    with np.errstate(all="raise"):
        assert np.isnan(terrain.height_at(bad)).all()
        np.testing.assert_array_equal(terrain.height_at(bad, outside=-5.0), -5.0)
    for bad_shape in (np.zeros(3), np.zeros((4, 3)), np.zeros((2, 2, 2))):
        with pytest.raises(ValueError, match="points_xy"):
            terrain.height_at(bad_shape)
        with pytest.raises(ValueError, match="points_xy"):
            terrain.ground_z(bad_shape)


def test_stepping_stones_between_the_stones() -> None:
    terrain = T.stepping_stones()
    heights = terrain.height_at([[0.0, 0.0], [0.7, 0.4], [0.37, 0.12], [0.25, 0.3]])
    assert heights[0] == 0.0 and np.isnan(heights[1]) and heights[2] == 0.0 and np.isnan(heights[3])
