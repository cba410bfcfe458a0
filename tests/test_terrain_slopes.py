"""Sloped tops (issue 30, item 2): the plane in the terrain JSON, its validation, and the point queries that follow
it (``height_at``, ``ground_z``, ``height_bound``, ``normal_at``, ``is_safe``), against slow obvious references
written here: every region asked on its own with shapely, its plane evaluated from its fields."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import shapely

from contactnet import terrain as T
from contactnet.terrain import Terrain, TerrainError
from contactnet.terrain.geometry import MAX_SAFE_SLOPE_RAD

_SNAP_M = 1e-9


def _terrain(*regions: dict, surface_z: float = 0.0, start=(0.0, 0.0), goal_x: float = 1.0) -> Terrain:
    return Terrain.from_dict({"name": "slopes", "start": list(start), "goal_x": goal_x, "surface_z": surface_z,
                              "regions": list(regions)})


def overlapping_slopes() -> Terrain:
    """A flat platform, a ramp abutting it, a sloped disc and a sloped polygon overlapping flat and sloped tops,
    a raised flat square on a ramp, and a steep (30 degrees) square: every case of the ordering rule."""
    return _terrain(
        {"shape": "rect", "center": [0.0, 0.0], "size": [0.6, 0.6]},
        {"shape": "rect", "center": [0.55, 0.0], "size": [0.5, 0.6], "z": 0.067, "slope_deg": 15.0},
        {"shape": "circle", "center": [0.2, 0.25], "radius": 0.15, "z": 0.03, "slope_deg": 12.0,
         "slope_dir_deg": 135.0},
        {"shape": "polygon", "vertices": [[0.4, -0.1], [0.9, -0.3], [0.8, 0.2]], "z": 0.05, "slope_deg": 8.0,
         "slope_dir_deg": -60.0},
        {"shape": "rect", "center": [0.6, 0.1], "size": [0.1, 0.1], "z": 0.12},
        {"shape": "rect", "center": [-0.5, 0.0], "size": [0.3, 0.3], "z": 0.0, "slope_deg": 30.0,
         "slope_dir_deg": 200.0},
        {"shape": "grid", "origin": [1.0, -0.3], "cell": 0.05, "cols": 6, "rows": 12, "removed": [[2, 3], [4, 7]],
         "z": 0.02, "slope_deg": 5.0, "slope_dir_deg": 90.0},
    )


# ---- slow, obvious references ---------------------------------------------------------------------
def reference_planes(terrain: Terrain) -> list[tuple]:
    """(geometry, z, gradient (gx, gy), centre (x, y), slope rad, order key) of every region, from its fields."""
    planes = []
    for index, region in enumerate(terrain.regions):
        slope = math.radians(region.get("slope_deg", 0.0))
        direction = math.radians(region.get("slope_dir_deg", 0.0))
        gradient = (math.tan(slope) * math.cos(direction), math.tan(slope) * math.sin(direction))
        if region["shape"] == "grid":
            (ox, oy), cell = region["origin"], region["cell"]
            centre = (ox + 0.5 * cell * region["cols"], oy + 0.5 * cell * region["rows"])
        elif region["shape"] == "polygon":
            point = shapely.Polygon(region["vertices"]).centroid
            centre = (point.x, point.y)
        else:
            centre = tuple(region["center"])
        z = region.get("z", terrain.surface_z)
        key = (z, index + 1 if slope else 0)  # the higher z wins, a sloped region over a flat one of the same z
        planes.append((T.region_geometry(region), z, gradient, centre, slope, key))
    return planes


def reference_tops(terrain: Terrain, points_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(height (N,) NaN for none, gradient (N, 2), slope (N,)): the winning region's plane under each point."""
    best = [None] * len(points_xy)
    for plane in reference_planes(terrain):
        geometry = plane[0]
        for i, (x, y) in enumerate(points_xy):
            if shapely.intersects_xy(geometry, x, y) and (best[i] is None or plane[5] > best[i][5]):
                best[i] = plane
    height = np.full(len(points_xy), np.nan)
    gradient = np.zeros((len(points_xy), 2))
    slope = np.zeros(len(points_xy))
    for i, plane in enumerate(best):
        if plane is not None:
            _, z, (gx, gy), (cx, cy), angle, _ = plane
            height[i] = z + gx * (points_xy[i, 0] - cx) + gy * (points_xy[i, 1] - cy)
            gradient[i] = gx, gy
            slope[i] = angle
    return height, gradient, slope


def query_points(terrain: Terrain, rng: np.random.Generator, n: int = 600) -> np.ndarray:
    minx, miny, maxx, maxy = terrain.bounds
    uniform = rng.uniform((minx - 0.05, miny - 0.05), (maxx + 0.05, maxy + 0.05), (n, 2))
    rings = shapely.get_rings(shapely.get_parts(np.array([p[0] for p in reference_planes(terrain)], dtype=object)))
    ring = rings[rng.integers(0, len(rings), n // 2)]
    on_outline = shapely.get_coordinates(shapely.line_interpolate_point(ring, rng.uniform(0, 1, n // 2),
                                                                        normalized=True))
    around = on_outline + rng.normal(0.0, 0.01, on_outline.shape)
    return np.concatenate([uniform, around])


def _near_outline(terrain: Terrain, points_xy: np.ndarray, tolerance_m: float) -> np.ndarray:
    boundary = shapely.union_all([p[0].boundary for p in reference_planes(terrain)])
    return shapely.dwithin(boundary, shapely.points(points_xy), tolerance_m)


# ---- the queries against the references -----------------------------------------------------------------
def test_height_at_ground_z_and_normal_follow_the_plane_of_the_winning_top() -> None:
    terrain = overlapping_slopes()
    assert terrain.sloped and len(terrain.levels) == 7
    points = query_points(terrain, np.random.default_rng(3))
    expected, gradient, _ = reference_tops(terrain, points)
    away = ~_near_outline(terrain, points, 1e-6)  # on an outline itself both answers are a region's top there
    got = terrain.height_at(points)
    np.testing.assert_array_equal(np.isnan(got[away]), np.isnan(expected[away]))
    np.testing.assert_allclose(got[away], expected[away], atol=1e-9, equal_nan=True)
    np.testing.assert_allclose(terrain.ground_z(points)[away], np.where(np.isnan(expected), 0.0, expected)[away],
                               atol=1e-9)
    np.testing.assert_allclose(terrain.height_bound(points)[away], expected[away], atol=1e-9, equal_nan=True)
    normals = terrain.normal_at(points)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)
    reference_normal = np.column_stack([-gradient, np.ones(len(points))])
    reference_normal /= np.linalg.norm(reference_normal, axis=1, keepdims=True)
    np.testing.assert_allclose(normals[away], reference_normal[away], atol=1e-12)
    np.testing.assert_allclose(terrain.gradient_at(points)[away], gradient[away], atol=1e-12)
    assert terrain.height_at(points[0]).shape == () and terrain.normal_at(points[0]).shape == (3,)


def test_is_safe_leaves_out_tops_steeper_than_the_friction_allows_and_the_edges_of_every_top() -> None:
    terrain = overlapping_slopes()
    points = query_points(terrain, np.random.default_rng(4))
    expected, _, slope = reference_tops(terrain, points)
    for margin in (0.0, 0.01):
        got = terrain.is_safe(points, margin)
        near = _near_outline(terrain, points, margin + 1e-6)
        on_top = ~np.isnan(expected)
        reference = on_top & (slope <= MAX_SAFE_SLOPE_RAD)
        np.testing.assert_array_equal(got[~near], reference[~near])
        assert not got[on_top & (slope > MAX_SAFE_SLOPE_RAD)].any()
    assert math.degrees(MAX_SAFE_SLOPE_RAD) == pytest.approx(21.8, abs=0.05)


def test_the_mesh_tilts_a_sloped_top_and_keeps_its_outline() -> None:
    terrain = _terrain({"shape": "rect", "center": [0.0, 0.0], "size": [0.6, 0.6]},
                       {"shape": "rect", "center": [0.55, 0.0], "size": [0.5, 0.6], "z": 0.125 * math.tan(
                           math.radians(15.0)) * 2, "slope_deg": 15.0})
    mesh = terrain.mesh(thickness=0.1)
    tops = mesh.vertices[mesh.vertices[:, 2] > -0.05]
    np.testing.assert_allclose(tops[:, 2], terrain.height_at(tops[:, :2] - np.sign(tops[:, :2] - [0.55, 0]) * 1e-6),
                               atol=1e-6)
    assert tops[:, 2].max() == pytest.approx(terrain.top_z_range()[1])
    assert terrain.top_z_range()[1] == pytest.approx(terrain.regions[1]["z"] + 0.25 * math.tan(math.radians(15.0)))
    assert mesh.bounds[0, 2] == pytest.approx(min(0.0, terrain.top_z_range()[0]) - 0.1)


# ---- the file format -------------------------------------------------------------------------------------
def test_old_files_load_unchanged_and_slopes_survive_a_round_trip(tmp_path: Path) -> None:
    for name in ("stairs", "stepping_stones", "raised_stones"):
        before = T.resolve(name)
        assert not before.sloped and all("slope_deg" not in r for r in before.to_dict()["regions"])
    terrain = overlapping_slopes()
    path = tmp_path / "slopes.json"
    terrain.save(path)
    again = Terrain.load(path)
    assert again == terrain and again.sloped
    assert again.to_dict()["regions"][1]["slope_deg"] == 15.0 and again.to_dict()["regions"][1]["slope_dir_deg"] == 0.0
    points = query_points(terrain, np.random.default_rng(1), 200)
    np.testing.assert_array_equal(again.height_at(points), terrain.height_at(points))


@pytest.mark.parametrize(("fields", "message"), [
    ({"slope_deg": 61}, r"regions\[0\]\.slope_deg: expected a slope in \[0, 60\] degrees, got 61"),
    ({"slope_deg": -1}, r"regions\[0\]\.slope_deg: expected a slope in \[0, 60\] degrees, got -1"),
    ({"slope_deg": True}, r"regions\[0\]\.slope_deg: expected a slope"),
    ({"slope_deg": float("nan")}, r"regions\[0\]\.slope_deg: expected a slope"),
    ({"slope_dir_deg": 30}, r"regions\[0\]\.slope_dir_deg: given without slope_deg"),
    ({"slope_deg": 10, "slope_dir_deg": "up"}, r"regions\[0\]\.slope_dir_deg: expected a direction"),
    ({"slope_deg": 10, "slope_dir_deg": 400}, r"regions\[0\]\.slope_dir_deg: expected a direction"),
    ({"slope_deg": 45, "z": 0.3}, r"regions\[0\]\.slope_deg: the sloped top spans z .* within 0.5 m of surface_z"),
])
def test_bad_slopes_are_refused_naming_the_field(fields: dict, message: str) -> None:
    with pytest.raises(TerrainError, match=message):
        _terrain({"shape": "rect", "center": [0.0, 0.0], "size": [0.6, 0.6], **fields})


def test_a_sloped_grid_or_polygon_is_centred_as_documented() -> None:
    terrain = overlapping_slopes()
    grid = terrain.regions[6]
    centre = (grid["origin"][0] + 0.15, grid["origin"][1] + 0.3)
    assert float(terrain.height_at(np.array(centre))) == pytest.approx(0.02, abs=1e-12)


# ---- the ramps generator -----------------------------------------------------------------------------------
def test_ramps_rise_and_fall_by_their_slopes_and_tilt_across() -> None:
    terrain = T.ramps()
    assert terrain.name == "ramps" and terrain.sloped
    slopes = sorted({round(math.degrees(a), 6) for a in terrain.level_slope_rad()})
    assert slopes == [0.0, 10.0, 15.0]
    x = np.linspace(0.0, terrain.goal_x, 2000)
    along = terrain.height_at(np.column_stack([x, np.zeros_like(x)]))
    assert np.all(np.isfinite(along)) and along.max() == pytest.approx(0.3 * math.tan(math.radians(15.0)), abs=1e-6)
    assert np.abs(np.diff(along)).max() <= math.tan(math.radians(15.0)) * (x[1] - x[0]) + 1e-6  # no riser on y = 0
    across = terrain.regions[-2]
    assert across["slope_dir_deg"] == 90.0
    cx = across["center"][0]
    assert float(terrain.height_at(np.array([cx, 0.2]))) == pytest.approx(0.2 * math.tan(math.radians(10.0)))
    shipped = Terrain.load(T.terrains_dir() / "ramps.json")
    assert shipped == terrain
    assert T.scaled(terrain, 2.0).level_slope_rad().max() == pytest.approx(terrain.level_slope_rad().max())


def test_the_top_view_shades_a_sloped_top(tmp_path: Path) -> None:
    path = T.ramps().render_png(tmp_path / "ramps.png", dpi=40)
    assert path.stat().st_size > 1000
