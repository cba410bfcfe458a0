"""Terrains with tops at several heights (issue 13, item 1): the ``z`` of regions, ``height_at``, ``is_safe``,
the levels, meshes, the top view and the generators ``stairs``, ``raised_stones`` and ``random_heights``.

The fast queries are checked against slow, obvious shapely references: the highest ``z`` of the regions
covering a point, and "inside one level shrunk by the margin" with the levels built region by region
(union of the regions at z minus union of the regions above z).
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import shapely
from shapely.geometry import Point

from contactnet import cli
from contactnet import terrain as T
from contactnet.terrain import Terrain, TerrainError, edits, levels
from contactnet.terrain.schema import MAX_HEIGHT_OFFSET_M, pretty_json
from contactnet.terrain.union import mesh_face_bound

REPO_TERRAINS = Path(__file__).resolve().parent.parent / "terrains"
SNAP_TOLERANCE_M = 1e-9
"""Regions are snapped to a 1e-9 m grid before they are united, so fast and reference answers may differ
this close to an outline."""
ERODE_TOLERANCE_M = 1e-8
"""The reference shrinks levels it built its own way (other vertices, the same arcs): answers may differ
this close to the shrunk outline."""
MARGINS_M = (0.0, 0.008, 0.016)


# ---- terrains ------------------------------------------------------------------------------------
def overlapping() -> Terrain:
    """Every shape, at several heights, overlapping: a grid above a platform (its holes show the platform),
    a star over the grid, a circle inside the star, a hidden rect, a polygon at the grid's height, a circle
    partly under the platform."""
    return Terrain.from_dict({
        "name": "overlapping", "start": [0.0, 0.0], "goal_x": 1.0, "surface_z": 0.02, "regions": [
            {"shape": "rect", "center": [0.3, 0.0], "size": [1.0, 0.5], "yaw": 0.0},
            {"shape": "grid", "origin": [0.3, -0.2], "cell": 0.05, "cols": 8, "rows": 8, "z": 0.06,
             "removed": [[0, 0], [3, 4], [5, 6], [2, 4], [3, 5], [7, 7]]},
            {"shape": "star", "center": [0.55, 0.05], "outer_radius": 0.15, "inner_radius": 0.07, "points": 5,
             "yaw": 0.2, "z": 0.12},
            {"shape": "circle", "center": [0.55, 0.05], "radius": 0.04, "z": 0.2},
            {"shape": "rect", "center": [0.55, 0.05], "size": [0.02, 0.02], "yaw": 0.3, "z": 0.1},
            {"shape": "polygon", "vertices": [[0.6, -0.3], [0.9, -0.25], [0.85, 0.0], [0.7, -0.1]], "z": 0.06},
            {"shape": "circle", "center": [0.85, 0.25], "radius": 0.1, "z": -0.1},
            {"shape": "rect", "center": [1.2, 0.0], "size": [0.3, 0.3], "yaw": 0.1, "z": 0.02},
        ]})


def lifted_random_heights() -> Terrain:
    """random_heights(200, 3, 5 cm) with the nominal level and every top 0.2 m higher."""
    data = T.random_heights(200, 3, 0.05).to_dict()
    regions = [{**r, "z": r.get("z", 0.0) + 0.2} for r in data["regions"]]
    return Terrain.from_dict({**data, "surface_z": 0.2, "regions": regions})


TERRAINS: dict[str, Callable[[], Terrain]] = {
    "stairs": T.stairs,
    "raised_stones": T.raised_stones,
    "random_heights_80_0": lambda: T.random_heights(80, 0),
    "random_heights_lifted": lifted_random_heights,
    "overlapping": overlapping,
}


def region_tops(terrain: Terrain) -> list[tuple[Any, float]]:
    return [(T.region_geometry(r), r.get("z", terrain.surface_z)) for r in terrain.regions]


# ---- slow, obvious references ---------------------------------------------------------------------
def reference_heights(terrain: Terrain, points_xy: np.ndarray, outside: float = np.nan) -> np.ndarray:
    """The highest z of the regions covering each point (region by region, shapely's own test)."""
    heights = np.full(len(points_xy), -np.inf)
    for geometry, top_z in region_tops(terrain):
        covered = shapely.intersects_xy(geometry, points_xy[:, 0], points_xy[:, 1])
        heights[covered] = np.maximum(heights[covered], top_z)
    return np.where(np.isneginf(heights), outside, heights)


def reference_levels(terrain: Terrain) -> list[tuple[float, Any]]:
    """(z, union of the regions at z minus union of the regions above z), highest first; GEOS at the union's
    1e-9 m precision, so that cells meant to abut (x = 1.15 and 1.1500000000000001) leave no crack."""
    tops = region_tops(terrain)
    result = []
    for top_z in sorted({z for _, z in tops}, reverse=True):
        here = shapely.union_all([g for g, z in tops if z == top_z], grid_size=SNAP_TOLERANCE_M)
        above = [g for g, z in tops if z > top_z]
        if above:
            here = shapely.difference(here, shapely.union_all(above, grid_size=SNAP_TOLERANCE_M),
                                      grid_size=SNAP_TOLERANCE_M)
        result.append((top_z, here))
    return result


@functools.cache
def reference_levels_of(name: str) -> list[tuple[float, Any]]:
    """:func:`reference_levels` of ``TERRAINS[name]`` (slow: computed once per test session)."""
    return reference_levels(TERRAINS[name]())


def reference_safe(terrain: Terrain, points_xy: np.ndarray, margin: float,
                   levels_: list[tuple[float, Any]] | None = None) -> tuple[np.ndarray, Any]:
    """(inside one level shrunk by ``margin``, the boundary of those shrunk levels)."""
    pieces = reference_levels(terrain) if levels_ is None else levels_
    shrunk = [piece if margin == 0 else piece.buffer(-margin, quad_segs=16) for _, piece in pieces]
    safe = np.zeros(len(points_xy), dtype=bool)
    for piece in shrunk:
        safe |= shapely.intersects_xy(piece, points_xy[:, 0], points_xy[:, 1])
    return safe, shapely.union_all([p.boundary for p in shrunk])


def outlines(terrain: Terrain) -> Any:
    return shapely.union_all([g.boundary for g, _ in region_tops(terrain)])


def query_points(terrain: Terrain, rng: np.random.Generator, n: int = 1500) -> np.ndarray:
    """Uniform points, points next to the regions' vertices, and points on and around every outline (risers
    included) at distances around the margins."""
    minx, miny, maxx, maxy = terrain.bounds
    uniform = rng.uniform((minx - 0.05, miny - 0.05), (maxx + 0.05, maxy + 0.05), (n, 2))
    rings = shapely.get_rings(shapely.get_parts(np.array([g for g, _ in region_tops(terrain)], dtype=object)))
    vertices_xy = shapely.get_coordinates(rings)
    near_vertices = vertices_xy[rng.integers(0, len(vertices_xy), n // 3)] + rng.normal(0.0, 1e-4, (n // 3, 2))
    ring = rings[rng.integers(0, len(rings), n)]
    on_outline = shapely.get_coordinates(shapely.line_interpolate_point(ring, rng.uniform(0, 1, n), normalized=True))
    distance = rng.choice([0.0, 1e-7, 0.004, 0.008 - 1e-6, 0.008 + 1e-6, 0.016 - 1e-6, 0.016 + 1e-6, 0.03], n)
    angle = rng.uniform(0, 2 * math.pi, n)
    around = on_outline + distance[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    return np.concatenate([uniform, near_vertices, on_outline, around])


def assert_equal_except_near(points_xy: np.ndarray, got: np.ndarray, expected: np.ndarray, boundary: Any,
                             tolerance: float) -> None:
    differ = np.flatnonzero(~((got == expected) | (np.isnan(got) & np.isnan(expected))))
    shapely.prepare(boundary)
    near = shapely.dwithin(boundary, shapely.points(points_xy[differ]), tolerance)
    for i in differ[~near][:1]:
        raise AssertionError((points_xy[i], got[i], expected[i], boundary.distance(Point(points_xy[i]))))


# ---- height_at, ground_z, is_safe against the references -------------------------------------------
@pytest.mark.parametrize("name", list(TERRAINS))
def test_height_at_is_the_highest_top_covering_each_point(name: str) -> None:
    terrain = TERRAINS[name]()
    assert len(terrain.levels) > 1
    points_xy = query_points(terrain, np.random.default_rng(sum(map(ord, name))))
    heights = terrain.height_at(points_xy)
    assert heights.dtype == np.float64 and heights.shape == (len(points_xy),)
    assert_equal_except_near(points_xy, heights, reference_heights(terrain, points_xy), outlines(terrain),
                             SNAP_TOLERANCE_M)
    assert np.isnan(heights).any() or name == "stairs"
    assert set(np.unique(heights[~np.isnan(heights)])) <= {z for z, _ in terrain.levels} | {
        r.get("z", terrain.surface_z) for r in terrain.regions}
    small = np.concatenate([terrain.height_at(points_xy[i:i + 7]) for i in range(0, 140, 7)])
    np.testing.assert_array_equal(small, heights[:140])
    singles = np.array([terrain.height_at(p) for p in points_xy[-40:]])
    np.testing.assert_array_equal(singles, heights[-40:])
    np.testing.assert_array_equal(terrain.height_at(points_xy, outside=-7.0), np.where(np.isnan(heights), -7.0,
                                                                                       heights))


@pytest.mark.parametrize("name", list(TERRAINS))
def test_ground_z_is_the_top_else_the_nominal_level(name: str) -> None:
    terrain = TERRAINS[name]()
    points_xy = query_points(terrain, np.random.default_rng(7))
    np.testing.assert_array_equal(terrain.ground_z(points_xy), terrain.height_at(points_xy, outside=terrain.surface_z))
    bad = np.array([[np.nan, 0.0], [0.0, np.inf], [-np.inf, 0.0], [1e300, 0.0]] * 10)
    with np.errstate(all="raise"):
        assert np.isnan(terrain.height_at(bad)).all()
        np.testing.assert_array_equal(terrain.ground_z(bad), terrain.surface_z)
    assert terrain.height_at(np.zeros((0, 2))).shape == (0,)
    with pytest.raises(ValueError, match="points_xy"):
        terrain.height_at(np.zeros((3, 3)))


@pytest.mark.parametrize("margin", MARGINS_M)
@pytest.mark.parametrize("name", list(TERRAINS))
def test_is_safe_means_on_a_top_away_from_its_edges(name: str, margin: float) -> None:
    terrain = TERRAINS[name]()
    points_xy = query_points(terrain, np.random.default_rng(sum(map(ord, name)) + int(margin * 1000)))
    safe = terrain.is_safe(points_xy, margin)
    expected, boundary = reference_safe(terrain, points_xy, margin, reference_levels_of(name))
    tolerance = ERODE_TOLERANCE_M if margin else SNAP_TOLERANCE_M
    assert_equal_except_near(points_xy, safe.astype(float), expected.astype(float),
                             shapely.union_all([boundary, outlines(terrain)]), tolerance)
    assert safe.any() and not safe.all()
    if margin == 0:  # on a top <=> has a top (up to the snapping of the outlines)
        has_top = ~np.isnan(terrain.height_at(points_xy))
        assert_equal_except_near(points_xy, safe.astype(float), has_top.astype(float), outlines(terrain),
                                 SNAP_TOLERANCE_M)


@pytest.mark.parametrize("margin", [0.008, 0.016])
def test_a_point_next_to_a_riser_is_unsafe_on_both_sides(margin: float) -> None:
    terrain = T.stairs()
    risers_x = [0.25, 0.45, 0.65, 1.05, 1.25, 1.45]
    for x in risers_x:
        for side in (-1.0, 1.0):
            near = np.array([[x + side * 0.5 * margin, y] for y in (-0.1, 0.0, 0.1)])
            far = np.array([[x + side * 2.0 * margin, y] for y in (-0.1, 0.0, 0.1)])
            assert not terrain.is_safe(near, margin).any(), (x, side)
            assert terrain.is_safe(far, margin).all(), (x, side)
            assert terrain.is_safe(near, 0.0).all()
    upper = terrain.height_at(np.array([[x, 0.0] for x in risers_x]))
    np.testing.assert_allclose(upper, [0.05, 0.1, 0.15, 0.15, 0.1, 0.05])  # on the riser: the upper top
    below = terrain.height_at(np.array([[0.25 - 1e-6, 0.0], [0.25 + 1e-6, 0.0], [1.45 + 1e-6, 0.0]]))
    np.testing.assert_allclose(below, [0.0, 0.05, 0.0])


def test_levels_partition_the_steppable_set() -> None:
    for name, factory in TERRAINS.items():
        terrain = factory()
        tops = [z for z, _ in terrain.levels]
        assert tops == sorted(set(tops), reverse=True), name
        pieces = [geometry for _, geometry in terrain.levels]
        assert sum(p.area for p in pieces) == pytest.approx(terrain.steppable.area, rel=1e-9, abs=1e-12), name
        union = shapely.union_all(pieces)
        assert union.symmetric_difference(terrain.steppable).area < 1e-12, name
        reference = [(z, piece) for z, piece in reference_levels_of(name) if piece.area > 0]
        assert [z for z, _ in reference] == tops, name
        for (_, piece), (_, ref_piece) in zip(terrain.levels, reference, strict=True):
            assert piece.symmetric_difference(ref_piece).area < 1e-9 * ref_piece.length, name


def test_the_overlapping_terrain_hides_covered_tops() -> None:
    terrain = overlapping()
    assert [z for z, _ in terrain.levels] == [0.2, 0.12, 0.06, 0.02, -0.1]  # the hidden rect at 0.1: no level
    heights = terrain.height_at([[0.55, 0.05], [0.55 + 0.1, 0.05], [0.3 + 0.175, -0.2 + 0.225], [0.85, 0.32],
                                 [0.78, 0.2]])
    np.testing.assert_array_equal(heights, [0.2, 0.12, 0.02, -0.1, 0.02])  # the grid's hole shows the platform


# ---- one level: today's behaviour ----------------------------------------------------------------------
def test_a_terrain_at_one_height_has_one_level_and_answers_as_before() -> None:
    data = T.random_field(80, 0).to_dict()
    raised = Terrain.from_dict({**data, "regions": [{**r, "z": 0.1} for r in data["regions"]]})
    plain = T.random_field(80, 0)
    assert len(raised.levels) == 1 and raised.levels[0][0] == 0.1 and raised.levels[0][1] is raised.steppable
    points_xy = query_points(plain, np.random.default_rng(3))
    has_top = plain.is_safe(points_xy)
    np.testing.assert_array_equal(raised.height_at(points_xy), np.where(has_top, 0.1, np.nan))
    np.testing.assert_array_equal(raised.ground_z(points_xy), np.where(has_top, 0.1, 0.0))
    for margin in (0.0, 0.016):
        np.testing.assert_array_equal(raised.is_safe(points_xy, margin), plain.is_safe(points_xy, margin))
        eroded = plain.steppable if margin == 0 else shapely.buffer(plain.steppable, -margin, quad_segs=16)
        np.testing.assert_array_equal(plain.is_safe(points_xy, margin),
                                      shapely.intersects_xy(eroded, points_xy[:, 0], points_xy[:, 1]))
    mesh = raised.mesh(0.2)
    assert mesh.is_watertight and mesh.bounds[:, 2] == pytest.approx([-0.2, 0.1])


@pytest.mark.parametrize("path", sorted(REPO_TERRAINS.glob("*.json")), ids=lambda p: p.stem)
def test_files_round_trip_byte_identical(path: Path) -> None:
    """Every shipped file, old ones without heights included, reads and writes back byte for byte."""
    text = path.read_text()
    terrain = Terrain.load(path)
    assert pretty_json(terrain.to_dict()) + "\n" == text
    has_z = ['"z"' in json.dumps(r) for r in json.loads(text)["regions"]]
    assert ["z" in r for r in terrain.to_dict()["regions"]] == has_z
    assert any(has_z) == (path.stem in ("stairs", "raised_stones", "ramps"))


def test_z_is_written_only_for_regions_that_had_one() -> None:
    data = {"name": "some", "start": [0.0, 0.0], "goal_x": 1.0, "regions": [
        {"shape": "rect", "center": [0.0, 0.0], "size": [0.5, 0.5]},
        {"shape": "circle", "center": [0.4, 0.0], "radius": 0.1, "z": 0},
        {"shape": "rect", "center": [0.8, 0.0], "size": [0.5, 0.5], "z": 0.05}]}
    terrain = Terrain.from_dict(data)
    out = terrain.to_dict()
    assert ["z" in r for r in out["regions"]] == [False, True, True]
    assert out["regions"][1]["z"] == 0.0 and isinstance(out["regions"][1]["z"], float)
    assert Terrain.from_dict(out) == terrain and Terrain.from_dict(out).to_dict() == out
    assert [z for z, _ in terrain.levels] == [0.05, 0.0]


# ---- validation of "z" ------------------------------------------------------------------------------
BAD_Z: list[tuple[Any, float, str]] = [
    ("0.1", 0.0, "expected a finite top height within 0.5 m of surface_z (0), in [-0.5, 0.5] m, got \"0.1\""),
    (True, 0.0, "got true"),
    (None, 0.0, "got null"),
    ([0.1], 0.0, "got [0.1]"),
    (float("nan"), 0.0, "got NaN"),
    (float("inf"), 0.0, "got Infinity"),
    (0.5000001, 0.0, "in [-0.5, 0.5] m, got 0.5000001"),
    (-0.51, 0.0, "got -0.51"),
    (0.71, 0.2, "within 0.5 m of surface_z (0.2), in [-0.3, 0.7] m, got 0.71"),
    (-0.31, 0.2, "in [-0.3, 0.7] m"),
]


@pytest.mark.parametrize(("z", "surface_z", "expected"), BAD_Z, ids=[f"{v!r}@{s}" for v, s, _ in BAD_Z])
def test_a_bad_z_is_refused_naming_the_field(z: Any, surface_z: float, expected: str) -> None:
    data = overlapping().to_dict()
    data["surface_z"] = surface_z
    data["regions"] = [{k: v for k, v in r.items() if k != "z"} for r in data["regions"]]
    data["regions"][3]["z"] = z
    with pytest.raises(TerrainError) as info:
        Terrain.from_dict(data, source="terrains/bad.json")
    message = str(info.value)
    assert message.startswith("terrains/bad.json: regions[3].z: expected a finite top height"), message
    assert expected in message and "\n" not in message
    assert info.value.field_path == "regions[3].z"


@pytest.mark.parametrize(("z", "surface_z"), [(0.5, 0.0), (-0.5, 0.0), (0.7, 0.2), (-0.3, 0.2), (0, 0.0)])
def test_z_at_the_limits_is_accepted(z: float, surface_z: float) -> None:
    data = {"name": "edge", "start": [0.0, 0.0], "goal_x": 1.0, "surface_z": surface_z, "regions": [
        {"shape": "rect", "center": [0.0, 0.0], "size": [0.5, 0.5]},
        {"shape": "rect", "center": [0.5, 0.0], "size": [0.5, 0.5], "z": z}]}
    terrain = Terrain.from_dict(data)
    assert float(terrain.height_at([0.5, 0.0])) == z and float(terrain.height_at([0.25, 0.0])) == max(z, surface_z)
    assert MAX_HEIGHT_OFFSET_M == 0.5


def test_z_in_a_file_and_in_the_allowed_keys(tmp_path: Path) -> None:
    path = tmp_path / "nan.json"
    path.write_text('{"name": "x", "start": [0, 0], "goal_x": 1, "regions": [{"shape": "circle", "center": [0, 0], '
                    '"radius": 1, "z": NaN}]}')
    with pytest.raises(TerrainError, match=r"nan.json: regions\[0\].z: expected a finite top height .* got NaN$"):
        Terrain.load(path)
    with pytest.raises(TerrainError, match=r"regions\[0\].zz: unknown key \"zz\"; allowed keys: center, radius, "
                                           r"shape, slope_deg, slope_dir_deg, z$"):
        Terrain.from_dict({"name": "x", "start": [0, 0], "goal_x": 1, "regions": [
            {"shape": "circle", "center": [0, 0], "radius": 1, "zz": 0.1}]})


# ---- generators ----------------------------------------------------------------------------------------
def tread_rects(terrain: Terrain) -> list[tuple[float, float, float]]:
    """(x centre, depth along x, z) of the regions, in order."""
    return [(r["center"][0], r["size"][0], r.get("z", terrain.surface_z)) for r in terrain.regions]


def test_stairs_go_up_then_down_with_5_cm_risers_and_20_cm_treads() -> None:
    terrain = T.stairs()
    rects = tread_rects(terrain)
    xs = [x for x, _, _ in rects]
    assert xs == sorted(xs) and all(r["shape"] == "rect" and r["yaw"] == 0.0 for r in terrain.regions)
    tops = [z for _, _, z in rects]
    risers = np.diff(tops)
    assert np.all(np.abs(risers) >= 0.05 - 1e-12) and np.allclose(np.abs(risers), 0.05)
    peak = int(np.argmax(tops))
    assert np.all(risers[:peak] > 0) and np.all(risers[peak:] < 0)  # up, then down
    assert tops[0] == 0.0 and tops[-1] == 0.0 and max(tops) == pytest.approx(0.15)
    treads = [depth for _, depth, _ in rects[1:-1]]
    assert treads[:peak - 1] == [0.2] * (peak - 1) and treads[peak:] == [0.2] * (len(treads) - peak)
    for (x0, d0, _), (x1, d1, _) in zip(rects, rects[1:], strict=False):  # abutting: no gap, no overlap
        assert x0 + d0 / 2 == pytest.approx(x1 - d1 / 2, abs=1e-12)
    # a flat start platform around the start and a flat landing around the goal
    start = np.stack(np.meshgrid(np.linspace(-0.25, 0.249, 11), np.linspace(-0.25, 0.25, 11)), -1).reshape(-1, 2)
    np.testing.assert_array_equal(terrain.height_at(start), 0.0)  # (at x = 0.25, the first riser: the tread)
    landing = start + [terrain.goal_x + 0.1005, 0.0]  # the landing: from 15 cm before the goal to 35 cm after it
    np.testing.assert_array_equal(terrain.height_at(landing), 0.0)
    assert terrain.goal_x - 0.15 == pytest.approx(rects[-1][0] - 0.25)
    assert T.stairs(riser_m=0.08).name == "stairs_r8" and np.allclose(
        np.abs(np.diff([z for _, _, z in tread_rects(T.stairs(riser_m=0.08))])), 0.08)
    assert len(T.stairs(steps=5).regions) == 2 + 9


@pytest.mark.parametrize("kwargs", [{"riser_m": 0.0}, {"riser_m": "5"}, {"tread_m": float("nan")}, {"steps": 0},
                                    {"steps": 2.0}, {"steps": 11, "riser_m": 0.05}, {"top_m": -1.0}])
def test_stairs_refuse_bad_arguments(kwargs: dict[str, Any]) -> None:
    with pytest.raises(TerrainError, match="^stairs: "):
        T.stairs(**kwargs)


def test_raised_stones_spread_their_tops_over_6_cm() -> None:
    terrain = T.raised_stones()
    assert terrain == T.raised_stones(0) and terrain.name == "raised_stones"
    tops = np.array([r["z"] for r in terrain.regions[1:-1]])
    assert len(tops) == 8 and np.all(np.abs(tops) <= 0.06) and tops.max() == 0.06 and tops.min() == -0.06
    assert len(set(tops.tolist())) == 8
    assert "z" not in terrain.regions[0] and "z" not in terrain.regions[-1]
    stones = T.stepping_stones()
    assert shapely.equals(terrain.steppable, stones.steppable) and terrain.goal_x == stones.goal_x
    other = T.raised_stones(1)
    assert other.name == "raised_stones_1" and other == T.raised_stones(1)
    assert sorted(r["z"] for r in other.regions[1:-1]) == sorted(tops.tolist())
    assert [r["z"] for r in other.regions[1:-1]] != tops.tolist()
    assert T.resolve("raised_stones", seed=1) == other and T.by_name("raised_stones", seed=1) == other
    with pytest.raises(TerrainError, match="^raised_stones: seed"):
        T.raised_stones(-1)


@pytest.mark.parametrize(("removed", "seed", "height_m"), [(80, 0, 0.03), (110, 4, 0.03), (80, 1, 0.05), (0, 2, 0.0)])
def test_random_heights_is_the_random_field_with_tops_within_h(removed: int, seed: int, height_m: float) -> None:
    terrain = T.random_heights(removed, seed, height_m)
    field = T.random_field(removed, seed)
    assert shapely.equals(terrain.steppable, field.steppable) and terrain.goal_x == field.goal_x
    grid = next(r for r in field.regions if r["shape"] == "grid")
    (ox, oy), cell = grid["origin"], grid["cell"]
    removed_centres = np.array([[ox + (c + 0.5) * cell, oy + (r + 0.5) * cell] for c, r in grid["removed"]])
    if removed:
        assert np.isnan(terrain.height_at(removed_centres)).all()
    squares = terrain.regions[1:-1]
    assert len(squares) == 300 - removed and all(r["size"] == (0.05, 0.05) for r in squares)
    tops = np.array([r["z"] for r in squares])
    assert np.all(np.abs(tops) <= height_m) and np.all(np.round(tops, 3) == tops)
    if height_m:
        assert tops.max() > 0.8 * height_m and tops.min() < -0.8 * height_m and tops.std() > 0.4 * height_m
    centres = np.array([r["center"] for r in squares])
    np.testing.assert_array_equal(terrain.height_at(centres), tops)
    assert terrain == T.random_heights(removed, seed, height_m)
    expected_name = f"random_heights_{removed}_{seed}" + ("" if height_m == 0.03 else f"_h{100 * height_m:g}")
    assert terrain.name == expected_name
    assert T.resolve("random_heights", removed=removed, seed=seed, height_m=height_m) == terrain


def test_random_heights_names_and_errors() -> None:
    assert T.by_name("random_heights", removed=80) == T.random_heights(80, 0)
    assert T.resolve("random_heights", removed=80, seed=0) == T.random_heights(80, 0, 0.03)
    with pytest.raises(TerrainError, match="random_heights: the random field needs 'removed'"):
        T.resolve("random_heights")
    for bad in (-0.01, 0.6, float("nan"), "3"):
        with pytest.raises(TerrainError, match="^random_heights: height_m"):
            T.random_heights(80, 0, bad)  # type: ignore[arg-type]
    with pytest.raises(TerrainError, match="^random_heights: removed"):
        T.random_heights(301, 0)
    with pytest.raises(TerrainError, match=r"unknown terrain \"moon\".*random_heights.*stairs"):
        T.resolve("moon")
    assert {"stairs", "raised_stones"} <= set(T.SHIPPED) and T.resolve("stairs") == T.stairs()


# ---- meshes and the top view ----------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(TERRAINS))
def test_the_mesh_is_a_closed_prism_per_top_down_to_below_the_lowest(name: str) -> None:
    terrain = TERRAINS[name]()
    thickness = 0.08
    mesh = terrain.mesh(thickness)
    bottom_z = min(terrain.surface_z, terrain.levels[-1][0]) - thickness
    assert mesh.bounds[0][2] == pytest.approx(bottom_z) and mesh.bounds[1][2] == pytest.approx(terrain.levels[0][0])
    bodies = mesh.split(only_watertight=False)
    assert all(body.is_watertight and body.is_winding_consistent for body in bodies)
    assert len(bodies) == sum(len(shapely.get_parts(g)) for _, g in terrain.levels)
    expected_volume = sum(g.area * (z - bottom_z) for z, g in terrain.levels)
    assert mesh.volume == pytest.approx(expected_volume, rel=1e-9)
    up = mesh.face_normals[:, 2] > 0.999
    for top_z, geometry in terrain.levels:
        at = up & (np.abs(mesh.triangles_center[:, 2] - top_z) < 1e-12)
        assert mesh.area_faces[at].sum() == pytest.approx(geometry.area, rel=1e-9)
    assert len(mesh.faces) <= sum(mesh_face_bound(g) for _, g in terrain.levels)


def test_the_top_view_colours_tops_by_height(tmp_path: Path) -> None:
    from matplotlib.figure import Figure

    def face_colours(terrain: Terrain) -> tuple[set[tuple[float, ...]], int]:
        figure = Figure()
        ax = terrain.render(ax=figure.add_subplot())
        return {tuple(np.round(p.get_facecolor(), 4)) for p in ax.patches}, len(figure.axes)

    colours, axes = face_colours(T.stairs())
    assert len(colours) == 4 and axes == 2  # one colour per height, and a colour bar
    colours, axes = face_colours(T.random_field(80, 0))
    assert len(colours) == 1 and axes == 1
    assert T.raised_stones().render_png(tmp_path / "raised.png", dpi=40).read_bytes()[:4] == b"\x89PNG"


def test_the_simulator_loads_the_stairs(robot) -> None:  # noqa: ANN001 - the conftest fixture
    from contactnet.sim.pybullet_world import Simulator, standing_torques

    with Simulator(robot, T.stairs()) as sim:
        state = sim.state(True)
        for _ in range(round(0.3 / sim.config.dt_s)):
            sim.step(standing_torques(state, robot.joint_standing))
            state = sim.state(True)
        assert state.foot_contact.all() and not sim.fallen()
        import pybullet

        low, high = sim.client.getAABB(sim.terrain_id)
        assert high[2] == pytest.approx(0.15, abs=3e-3) and low[2] < -0.3  # (PyBullet pads its boxes)
        assert pybullet is not None


# ---- the complexity budget with heights -------------------------------------------------------------------
def rect(x: float, y: float, w: float, z: float | None = None) -> dict[str, Any]:
    region = {"shape": "rect", "center": [x, y], "size": [w, w]}
    return region if z is None else {**region, "z": z}


def test_level_limits_are_named_in_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    stones = {"name": "s", "start": [0.0, 0.0], "goal_x": 1.0, "regions": [
        rect(0.0, 0.0, 0.5), *[rect(0.06 * i, 0.0, 0.08, z=0.01 * i) for i in range(1, 8)]]}
    Terrain.from_dict(stones)
    monkeypatch.setattr(levels, "MAX_LEVEL_PAIRS", 3)
    with pytest.raises(TerrainError, match=r"^s.json: regions: regions at different heights: more than 3 pairs"):
        Terrain.from_dict(stones, source="s.json")
    monkeypatch.setattr(levels, "MAX_LEVEL_PAIRS", 1000)
    monkeypatch.setattr(levels, "MAX_LEVEL_CUT_VERTICES", 10)
    with pytest.raises(TerrainError, match=r"^s.json: regions: regions at different heights overlap in too much "
                                           r"detail \(the higher ones cut the lower ones with \d+ vertices\); the "
                                           r"limit is 10$"):
        Terrain.from_dict(stones, source="s.json")
    monkeypatch.setattr(levels, "MAX_LEVEL_CUT_VERTICES", 1000)
    monkeypatch.setattr(levels, "MAX_MESH_FACES", 50)
    with pytest.raises(TerrainError, match=r"^s.json: regions: the tops at 8 heights need up to \d+ mesh faces"):
        Terrain.from_dict(stones, source="s.json")


def test_a_detailed_region_above_many_heights_is_refused() -> None:
    """A raised grid full of holes over 100 stones at 100 heights: each height would be cut by the grid."""
    rng = np.random.default_rng(0)
    cells = rng.permutation(120 * 120)[:3000]
    grid = {"shape": "grid", "origin": [-0.3, -0.3], "cell": 0.025, "cols": 120, "rows": 120, "z": 0.2,
            "removed": np.column_stack([cells % 120, cells // 120]).tolist()}
    stones = [rect(float(x), float(y), 0.04, z=0.001 * i) for i, (x, y) in enumerate(rng.uniform(0, 2.5, (100, 2)))]
    data = {"name": "deep", "start": [0.0, 0.0], "goal_x": 1.0, "regions": [grid, *stones]}
    try:
        Terrain.from_dict(data)
    except TerrainError as err:
        assert "overlap in too much detail" in str(err) and "\n" not in str(err)
    else:
        raise AssertionError("expected the level budget to refuse the raised grid")
    same_height = {**data, "regions": [grid, *[{**s, "z": 0.0} for s in stones]]}  # one cut, by one grid
    assert len(Terrain.from_dict(same_height).levels) == 2


# ---- the command line and the edits --------------------------------------------------------------------------
def test_the_cli_passes_height(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["terrain", "check", "random_heights", "--removed", "80", "--seed", "1", "--height", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "random_heights_80_1_h5" in out and "tops " in out
    with pytest.raises(SystemExit) as info:
        cli.main(["terrain", "check", "random_heights", "--removed", "80", "--height", "0.7"])
    assert info.value.code == 2
    assert cli.main(["terrain", "list"]) == 0
    listed = capsys.readouterr().out.split("\n")
    assert "stairs" in listed and "raised_stones" in listed and any("--height" in line for line in listed)
    args = cli.build_parser().parse_args(["simulate", "--terrain", "random_heights", "--removed", "80", "--height",
                                          "0.04", "--gait", "walk", "--planner", "heuristic"])
    assert args.height == 0.04


def test_edits_keep_heights() -> None:
    data = T.raised_stones().to_dict()
    stone = data["regions"][2]  # a rect stone
    punched = edits.punch_hole(data, stone["center"])
    pieces = [r for r in punched["regions"] if r["shape"] == "polygon"]
    assert pieces and all(r["z"] == stone["z"] for r in pieces)
    stairs = T.stairs().to_dict()
    assert edits.region_at(stairs, (0.25, 0.0)) == 1  # on the riser: the tread above
    assert edits.region_at(stairs, (0.0, 0.0)) == 0
    overlaid = overlapping().to_dict()
    assert edits.region_at(overlaid, (0.55, 0.05)) == 3  # the circle at 0.2 over the star, the hidden rect, the grid


@pytest.mark.slow
def test_many_heights_validate_and_answer() -> None:
    """10,000 stones at 10,000 heights, and 7,000 abutting strips at alternating heights (49,000 edge contacts):
    both within the budget (the cost grows with how much heights overlap, not with how many there are)."""
    stones = [rect(0.4 * (i % 100), 0.4 * (i // 100), 0.398, z=round(-0.4 + 0.8 * i / 10_000, 6))
              for i in range(10_000)]
    strips = [{"shape": "rect", "center": [0.1 * i, 0.0], "size": [0.1, 1.0], "z": 0.05 * (i % 2)}
              for i in range(7000)]
    for regions, start in ((stones, (0.0, 0.0)), (strips, (3.5, 0.0))):
        terrain = Terrain.from_dict({"name": "many", "start": list(start), "goal_x": 10.0, "regions": regions})
        points_xy = np.array([[0.1 * i + (0.0 if regions is strips else 0.05), 0.0] for i in range(40)]) + [start[0], 0]
        heights = terrain.height_at(points_xy)
        np.testing.assert_array_equal(heights, reference_heights(terrain, points_xy))
        safe = terrain.is_safe(np.column_stack([points_xy[:, 0] + 0.045, points_xy[:, 1]]), 0.008)
        assert not safe.any() if regions is strips else safe.sum() >= 1


@pytest.mark.parametrize("name", ["random_heights", "stairs", "raised_stones"])
def test_height_bound_is_an_upper_bound_exact_away_from_the_outlines(name):
    """``height_bound`` (the footholds' obstacle lookups): never below ``height_at``, the same away from the tops'
    outlines, and different only within a raster cell (a few mm) of one."""
    terrain = T.resolve(name, removed=80, seed=1) if name == "random_heights" else T.resolve(name)
    minx, miny, maxx, maxy = terrain.bounds
    points = np.random.default_rng(5).uniform([minx - 0.05, miny - 0.05], [maxx + 0.05, maxy + 0.05], (20_000, 2))
    exact = terrain.height_at(points, outside=-np.inf)
    bound = terrain.height_bound(points, outside=-np.inf)
    assert np.all(bound >= exact)
    outlines = shapely.union_all([shapely.boundary(geometry) for _, geometry in terrain.levels])
    distance = shapely.distance(outlines, shapely.points(points))
    far = distance > 0.01
    assert far.sum() > 10_000
    np.testing.assert_array_equal(bound[far], exact[far])
    near = (bound != exact).nonzero()[0]
    assert len(near) and np.all(distance[near] < 0.005)
    one_level = T.resolve("stepping_stones")  # one level: the same as height_at
    np.testing.assert_array_equal(one_level.height_bound(points), one_level.height_at(points))
