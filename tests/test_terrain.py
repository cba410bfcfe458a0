"""Tests of contactnet.terrain: validation, files, exact fast is_safe, generators, meshes, pieces.

height_at / ground_z are in test_terrain_height.py, the edit operations in test_terrain_edits.py.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import pickle
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import shapely
from shapely.geometry import Point

from contactnet import terrain as T
from contactnet.bench.terrain import benchmark_is_safe
from contactnet.robots import load_robot
from contactnet.terrain import Terrain, TerrainError
from contactnet.terrain.locate import PointLocator

REPO_TERRAINS = Path(__file__).resolve().parent.parent / "terrains"
ROBOT = load_robot("solo12").description  # the scenes are checked against the robot they were made for
FOOT_RADIUS_M = ROBOT.foot_radius_m
CANDIDATE_OFFSETS_XY = np.array([(dx, dy) for dx in np.linspace(-0.1, 0.1, 5) for dy in np.linspace(-0.1, 0.1, 5)])


def valid_dict() -> dict[str, Any]:
    """A small terrain with every region shape."""
    return {
        "name": "all_shapes",
        "description": "one of each",
        "start": [0.0, 0.0],
        "goal_x": 1.0,
        "surface_z": 0.0,
        "regions": [
            {"shape": "rect", "center": [0.0, 0.0], "size": [0.6, 0.5], "yaw": 0.0},
            {"shape": "circle", "center": [0.45, 0.1], "radius": 0.1},
            {"shape": "star", "center": [0.65, -0.1], "outer_radius": 0.12, "inner_radius": 0.06, "points": 5,
             "yaw": 0.2},
            {"shape": "polygon", "vertices": [[0.8, 0.0], [1.0, -0.1], [1.1, 0.1], [0.95, 0.05], [0.85, 0.2]]},
            {"shape": "grid", "origin": [1.1, -0.25], "cell": 0.05, "cols": 6, "rows": 10,
             "removed": [[0, 0], [3, 4], [5, 9]]},
        ],
    }


def with_change(path: str, value: Any) -> dict[str, Any]:
    """valid_dict() with one field set (``a.b[2].c``); value DELETE removes it."""
    data = valid_dict()
    keys: list[Any] = []
    for part in path.replace("]", "").replace("[", ".").split("."):
        keys.append(int(part) if part.isdigit() else part)
    target: Any = data
    for key in keys[:-1]:
        target = target[key]
    if value is DELETE:
        del target[keys[-1]]
    else:
        target[keys[-1]] = value
    return data


DELETE = object()
NAN, INF = float("nan"), float("inf")

BAD_DICTS: list[tuple[str, Any, str]] = [
    # (field to change, new value, text the message must contain)
    ("name", DELETE, "name: missing required field"),
    ("start", DELETE, "start: missing required field"),
    ("goal_x", DELETE, "goal_x: missing required field"),
    ("regions", DELETE, "regions: missing required field"),
    ("goalx", 1.0, "goalx: unknown key"),
    ("name", 3, "name: expected a non-empty"),
    ("name", "", "name: expected a non-empty"),
    ("name", "two\nlines", "name: expected a non-empty"),
    ("description", 5, "description: expected a string"),
    ("start", [0.0], "start: expected [x, y]"),
    ("start", "ab", "start: expected [x, y]"),
    ("start", [True, 0.0], "start: expected [x, y]"),
    ("start", [NAN, 0.0], "start: expected [x, y]"),
    ("start", [0.0, INF], "start: expected [x, y]"),
    ("start", [2000.0, 0.0], "start: expected [x, y]"),
    ("start", [0.0, "0"], "start: expected [x, y]"),
    ("start", [5.0, 5.0], "start: [5.0, 5.0] is not on steppable ground"),
    ("goal_x", True, "goal_x: expected a finite number"),
    ("goal_x", "1", "goal_x: expected a finite number"),
    ("goal_x", NAN, "goal_x: expected a finite number"),
    ("goal_x", -INF, "goal_x: expected a finite number"),
    ("goal_x", 10**400, "goal_x: expected a finite number"),
    ("goal_x", 1e4, "goal_x: expected a finite number"),
    ("goal_x", -0.5, "goal_x: must be beyond the start x"),
    ("goal_x", 0.0, "goal_x: must be beyond the start x"),
    ("surface_z", NAN, "surface_z: expected a finite number"),
    ("surface_z", False, "surface_z: expected a finite number"),
    ("regions", {}, "regions: expected a list"),
    ("regions", [], "regions: expected at least one region"),
    ("regions", [{"shape": "circle", "center": [0, 0], "radius": 1}] * 10_001, "regions: expected at most 10000"),
    ("regions[1]", 5, "regions[1]: expected an object"),
    ("regions[1].shape", DELETE, "regions[1].shape: missing required field"),
    ("regions[1].shape", "hexagon", "regions[1].shape: unknown shape \"hexagon\""),
    ("regions[1].shape", 3, "regions[1].shape: unknown shape"),
    ("regions[1].radious", 0.1, "regions[1].radious: unknown key"),
    ("regions[1].yaw", 0.1, "regions[1].yaw: unknown key"),
    ("regions[0].size", [0.1], "regions[0].size: expected 2 numbers"),
    ("regions[0].size", [0.0, 0.1], "regions[0].size: expected 2 numbers"),
    ("regions[0].size", [-1.0, 0.1], "regions[0].size: expected 2 numbers"),
    ("regions[0].size", [2000.0, 0.1], "regions[0].size: expected 2 numbers"),
    ("regions[0].size", [True, 0.1], "regions[0].size: expected 2 numbers"),
    ("regions[0].center", [1e4, 0.0], "regions[0].center: expected [x, y]"),
    ("regions[0].center", DELETE, "regions[0].center: missing required field"),
    ("regions[0].yaw", NAN, "regions[0].yaw: expected a finite yaw"),
    ("regions[0].yaw", True, "regions[0].yaw: expected a finite yaw"),
    ("regions[0]", {"shape": "rect", "center": [999.9, 0.0], "size": [1.0, 1.0]}, "regions[0]: region extends"),
    ("regions[1].radius", 0, "regions[1].radius: expected a radius"),
    ("regions[1].radius", 1e-4, "regions[1].radius: expected a radius"),
    ("regions[1].radius", True, "regions[1].radius: expected a radius"),
    ("regions[1].radius", "0.1", "regions[1].radius: expected a radius"),
    ("regions[1].radius", INF, "regions[1].radius: expected a radius"),
    ("regions[2].points", 2, "regions[2].points: expected an integer in 3..64"),
    ("regions[2].points", 65, "regions[2].points: expected an integer in 3..64"),
    ("regions[2].points", 5.0, "regions[2].points: expected an integer in 3..64"),
    ("regions[2].points", True, "regions[2].points: expected an integer in 3..64"),
    ("regions[2].inner_radius", 0.12, "regions[2].inner_radius: must be smaller than outer_radius"),
    ("regions[2].inner_radius", 0.2, "regions[2].inner_radius: must be smaller than outer_radius"),
    ("regions[2].outer_radius", 0.0, "regions[2].outer_radius: expected a radius"),
    ("regions[3].vertices", [[0, 0], [1, 0]], "regions[3].vertices: expected a list of 3..10000"),
    ("regions[3].vertices", "square", "regions[3].vertices: expected a list of 3..10000"),
    ("regions[3].vertices", [[0, 0]] * 10_001, "regions[3].vertices: expected a list of 3..10000"),
    ("regions[3].vertices", [[0, 0], [1, 0], [0]], "regions[3].vertices[2]: expected [x, y]"),
    ("regions[3].vertices", [[0, 0], [1, 0], [NAN, 1]], "regions[3].vertices[2]: expected [x, y]"),
    ("regions[3].vertices", [[0, 0], [1, 1], [1, 0], [0, 1]], "regions[3].vertices: polygon is not simple"),
    ("regions[3].vertices", [[0, 0], [1, 0], [2, 0]], "regions[3].vertices"),
    ("regions[4].cell", 0.0005, "regions[4].cell: expected a cell size"),
    ("regions[4].cell", -0.05, "regions[4].cell: expected a cell size"),
    ("regions[4].cols", 0, "regions[4].cols: expected an integer"),
    ("regions[4].cols", 1.5, "regions[4].cols: expected an integer"),
    ("regions[4].rows", True, "regions[4].rows: expected an integer"),
    ("regions[4].rows", 100_000, "regions[4].cols: cols * rows = 600000 exceeds 250000"),
    ("regions[4].origin", [999.9, 0.0], "regions[4]: region extends beyond"),
    ("regions[4].removed", "x", "regions[4].removed: expected a list"),
    ("regions[4].removed", [[6, 0]], "regions[4].removed[0]: expected [col, row]"),
    ("regions[4].removed", [[0, 10]], "regions[4].removed[0]: expected [col, row]"),
    ("regions[4].removed", [[-1, 0]], "regions[4].removed[0]: expected [col, row]"),
    ("regions[4].removed", [[0, 0], [0]], "regions[4].removed[1]: expected [col, row]"),
    ("regions[4].removed", [[0.0, 1]], "regions[4].removed[0]: expected [col, row]"),
    ("regions[4].removed", [[True, 1]], "regions[4].removed[0]: expected [col, row]"),
    ("regions[4].removed", [[1, 1], [1, 1]], "regions[4].removed[1]: duplicate cell [1, 1]"),
]


def assert_one_line(err: TerrainError) -> str:
    message = str(err)
    assert "\n" not in message and message.strip() == message
    return message


# ---------------------------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------------------------
def test_valid_dict_loads_with_every_shape() -> None:
    terrain = Terrain.from_dict(valid_dict())
    assert [r["shape"] for r in terrain.regions] == ["rect", "circle", "star", "polygon", "grid"]
    assert terrain.surface_z == 0.0 and terrain.description == "one of each"
    assert terrain.steppable.area > 0.3


@pytest.mark.parametrize(("path", "value", "expected"), BAD_DICTS, ids=[f"{p}={str(v)[:20]}" for p, v, _ in BAD_DICTS])
def test_bad_dict_raises_terrain_error_naming_the_field(path: str, value: Any, expected: str) -> None:
    with pytest.raises(TerrainError) as info:
        Terrain.from_dict(with_change(path, value), source="terrains/bad.json")
    message = assert_one_line(info.value)
    assert message.startswith("terrains/bad.json: "), message
    assert expected in message, message
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize("data", [[], "terrain", 3, None])
def test_top_level_must_be_an_object(data: Any) -> None:
    with pytest.raises(TerrainError, match=r"^<dict>: expected a JSON object at the top level"):
        Terrain.from_dict(data)


def test_defaults_for_optional_fields() -> None:
    data = valid_dict()
    del data["surface_z"], data["description"], data["regions"][0]["yaw"], data["regions"][4]["removed"]
    terrain = Terrain.from_dict(data)
    assert terrain.surface_z == 0.0 and terrain.description == ""
    assert terrain.regions[0]["yaw"] == 0.0 and terrain.regions[4]["removed"] == ()


def test_error_carries_source_and_field() -> None:
    with pytest.raises(TerrainError) as info:
        Terrain.from_dict(with_change("regions[0].size", [0.1]), source="terrains/bad.json")
    assert info.value.source == "terrains/bad.json" and info.value.field_path == "regions[0].size"
    assert str(info.value) == "terrains/bad.json: regions[0].size: expected 2 numbers in [0.001, 1000] m, got [0.1]"


def test_constructor_validates_too() -> None:
    with pytest.raises(TerrainError, match="regions: expected at least one region"):
        Terrain(name="x", start_xy=(0.0, 0.0), goal_x=1.0, regions=[])


FILE_CASES: list[tuple[str, bytes | None, str]] = [
    ("missing.json", None, "cannot read file"),
    ("empty.json", b"", "not valid JSON: Expecting value (line 1, column 1)"),
    ("garbage.json", b"{\n  \"name\": \"x\",\n  oops\n}", "not valid JSON: Expecting property name enclosed in "
                                                        "double quotes (line 3, column 3)"),
    ("list.json", b"[1, 2]", "expected a JSON object at the top level"),
    ("nan.json", b'{"name": "x", "start": [0, 0], "goal_x": NaN, "regions": []}', "goal_x: expected a finite number"),
    ("inf.json", b'{"name": "x", "start": [Infinity, 0], "goal_x": 1, "regions": []}', "start: expected [x, y]"),
    ("dup.json", b'{"name": "x", "name": "y"}', "duplicate key \"name\""),
    ("latin1.json", b'{"name": "caf\xe9"}', "not UTF-8 text"),
]


@pytest.mark.parametrize(("filename", "content", "expected"), FILE_CASES, ids=[c[0] for c in FILE_CASES])
def test_bad_file_raises_terrain_error_naming_the_path(tmp_path: Path, filename: str, content: bytes | None,
                                                        expected: str) -> None:
    path = tmp_path / filename
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(TerrainError) as info:
        Terrain.load(path)
    message = assert_one_line(info.value)
    assert message.startswith(f"{path}: "), message
    assert expected in message, message


def test_directory_is_not_a_terrain_file(tmp_path: Path) -> None:
    with pytest.raises(TerrainError, match="cannot read file"):
        Terrain.load(tmp_path)


# ---------------------------------------------------------------------------------------------
# Round trip and immutability
# ---------------------------------------------------------------------------------------------
def test_save_load_round_trip(tmp_path: Path) -> None:
    terrain = Terrain.from_dict(valid_dict())
    path = tmp_path / "all_shapes.json"
    terrain.save(path)
    text = path.read_text()
    assert text.startswith('{\n  "name": "all_shapes",\n')
    assert json.loads(text) == terrain.to_dict()
    loaded = Terrain.load(path)
    assert loaded == terrain and loaded.source == str(path)
    assert Terrain.from_dict(terrain.to_dict()) == terrain
    assert sorted(p.name for p in tmp_path.iterdir()) == ["all_shapes.json"]  # no temp file left
    terrain.save(path)  # overwrite in place
    assert Terrain.load(path) == terrain
    assert shapely.equals(loaded.steppable, terrain.steppable)


def test_to_dict_normalizes_and_is_idempotent() -> None:
    data = valid_dict()
    data["regions"][4]["removed"] = [[5, 9], [0, 0], [3, 4]]
    data["start"] = [0, 0]
    terrain = Terrain.from_dict(data)
    out = terrain.to_dict()
    assert out["regions"][4]["removed"] == [[0, 0], [3, 4], [5, 9]]
    assert out["start"] == [0.0, 0.0] and isinstance(out["goal_x"], float)
    assert Terrain.from_dict(out).to_dict() == out
    assert terrain != Terrain.from_dict(with_change("goal_x", 0.9))


def test_terrain_is_immutable_and_picklable() -> None:
    terrain = T.stepping_stones()
    with pytest.raises(dataclasses.FrozenInstanceError):
        terrain.name = "other"  # type: ignore[misc]
    with pytest.raises(TypeError):
        terrain.regions[0]["shape"] = "circle"  # type: ignore[index]
    with pytest.raises(ValueError):
        terrain.start_xy[0] = 1.0
    terrain.is_safe(np.zeros((100, 2)), margin=0.01)
    assert pickle.loads(pickle.dumps(terrain)) == terrain
    assert copy.deepcopy(terrain) == terrain


# ---------------------------------------------------------------------------------------------
# is_safe: fast path vs a slow point-by-point shapely reference
# ---------------------------------------------------------------------------------------------
def star_and_circle_terrain() -> Terrain:
    return Terrain.from_dict({
        "name": "stars", "start": [0.0, 0.0], "goal_x": 0.5, "regions": [
            {"shape": "circle", "center": [0.0, 0.0], "radius": 0.3},
            {"shape": "star", "center": [0.55, 0.05], "outer_radius": 0.25, "inner_radius": 0.08, "points": 7,
             "yaw": 0.4},
            {"shape": "circle", "center": [0.95, -0.1], "radius": 0.12},
            {"shape": "star", "center": [1.2, 0.2], "outer_radius": 0.1, "inner_radius": 0.05, "points": 3},
        ]})


TERRAIN_FACTORIES: dict[str, Callable[[], Terrain]] = {
    "random_80_0": lambda: T.random_field(80, 0),
    "random_200_3": lambda: T.random_field(200, 3),
    "stepping_stones": T.stepping_stones,
    "narrow_stones": T.narrow_stones,
    "push_field": T.push_field,
    "stars": star_and_circle_terrain,
    "all_shapes": lambda: Terrain.from_dict(valid_dict()),
}


def query_points(terrain: Terrain, rng: np.random.Generator, n: int = 1500) -> np.ndarray:
    """Uniform points plus points on the 5 cm lattice and next to the geometry's vertices."""
    minx, miny, maxx, maxy = terrain.bounds
    uniform = rng.uniform((minx - 0.05, miny - 0.05), (maxx + 0.05, maxy + 0.05), (n, 2))
    lattice = np.round(uniform[: n // 3] / 0.05) * 0.05
    vertices_xy = shapely.get_coordinates(terrain.steppable)
    near_vertices = vertices_xy[rng.integers(0, len(vertices_xy), n // 3)] + rng.normal(0.0, 1e-4, (n // 3, 2))
    return np.concatenate([uniform, lattice, near_vertices])


@pytest.mark.parametrize("margin", [0.0, FOOT_RADIUS_M, 0.05])
@pytest.mark.parametrize("name", list(TERRAIN_FACTORIES))
def test_is_safe_matches_pointwise_shapely(name: str, margin: float) -> None:
    terrain = TERRAIN_FACTORIES[name]()
    rng = np.random.default_rng([zlib.crc32(name.encode()), round(margin * 1000)])
    points_xy_world = query_points(terrain, rng)
    region = terrain.safe_region(margin)
    expected = np.array([region.covers(Point(p)) for p in points_xy_world])
    safe = terrain.is_safe(points_xy_world, margin=margin)
    assert safe.dtype == bool and safe.shape == (len(points_xy_world),)
    mismatch = np.flatnonzero(safe != expected)
    distances = [region.boundary.distance(Point(points_xy_world[i])) for i in mismatch]
    assert all(d <= 1e-9 for d in distances), (mismatch, distances)
    # small batches take the direct shapely path; they must agree too
    small = np.concatenate([terrain.is_safe(points_xy_world[i:i + 7], margin) for i in range(0, 70, 7)])
    assert np.array_equal(small, safe[:70])


@pytest.mark.parametrize("name", ["random_80_0", "narrow_stones", "stars"])
def test_point_raster_classifies_every_cell_centre_as_shapely(name: str) -> None:
    """The raster asks shapely about one cell per connected component of non-BOUNDARY cells: each such cell
    must get the code its own centre gets from shapely."""
    from contactnet.terrain.locate import _BOUNDARY, _INSIDE, _OUTSIDE, _Frame

    region = TERRAIN_FACTORIES[name]().safe_region(FOOT_RADIUS_M)
    locator = PointLocator.build(region, target_cells=1 << 16)
    frame = _Frame.around(region.bounds, 1 << 16, 1000)
    side = round(locator.clamp_hi + 0.5)
    codes = locator.codes.reshape(side, side)[: frame.n_rows, : frame.n_cols]
    rows, cols = np.nonzero(codes != _BOUNDARY)
    inside = shapely.contains_xy(region, *frame.centres(rows, cols))
    np.testing.assert_array_equal(codes[rows, cols], np.where(inside, _INSIDE, _OUTSIDE))
    assert (codes == _INSIDE).any() and (codes == _OUTSIDE).any() and (codes == _BOUNDARY).any()


@pytest.mark.parametrize("margin", [FOOT_RADIUS_M, 0.04])
def test_safe_region_is_the_steppable_set_eroded_by_margin(margin: float) -> None:
    """Independent of shapely's buffer: safe <=> distance to the holes >= margin (up to arc error)."""
    terrain = star_and_circle_terrain()
    rng = np.random.default_rng(7)
    points_xy_world = query_points(terrain, rng, 1200)
    inside = np.array([terrain.steppable.covers(Point(p)) for p in points_xy_world])
    depth = np.array([terrain.steppable.boundary.distance(Point(p)) for p in points_xy_world])
    safe = terrain.is_safe(points_xy_world, margin=margin)
    clear = np.abs(depth - margin) > 2e-4  # arcs are polygons: 16 segments per quarter circle
    assert np.array_equal(safe[clear], (inside & (depth >= margin))[clear])


def test_is_safe_edge_cases() -> None:
    terrain = T.flat((4.0, 2.0))
    assert terrain.is_safe([0.0, 0.0]).shape == (1,) and terrain.is_safe((0.0, 0.0))[0]
    assert terrain.is_safe(np.zeros((0, 2))).shape == (0,)
    assert terrain.is_safe([[2.0, 0.0]])[0]  # on the boundary: covered
    assert not terrain.is_safe([[2.0, 0.0]], margin=0.01)[0]
    bad = np.array([[np.nan, 0.0], [0.0, np.inf], [-np.inf, 0.0], [1e300, 0.0]] * 20)
    with np.errstate(all="raise"):
        assert not terrain.is_safe(bad).any()
    assert terrain.is_safe(np.zeros((100, 2)), margin=0).all()  # int margin
    for bad_margin in (-0.01, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="margin"):
            terrain.is_safe([0.0, 0.0], margin=bad_margin)
    for bad_shape in (np.zeros(3), np.zeros((4, 3)), np.zeros((2, 2, 2))):
        with pytest.raises(ValueError, match="points_xy"):
            terrain.is_safe(bad_shape)
    assert terrain.safe_region(5.0).is_empty and not terrain.is_safe(np.zeros((100, 2)), margin=5.0).any()


# ---------------------------------------------------------------------------------------------
# Generators
# ---------------------------------------------------------------------------------------------
def nominal_feet_xy(terrain: Terrain) -> np.ndarray:
    """The robot's nominal stance placed at the terrain's start (world x, y)."""
    return terrain.start_xy + ROBOT.foot_nominal_base[:, :2]


@pytest.mark.parametrize("removed", [0, 50, 80, 110, 300])
def test_random_field_has_exactly_300_minus_removed_cells(removed: int) -> None:
    terrain = T.random_field(removed, seed=4)
    grids = [r for r in terrain.regions if r["shape"] == "grid"]
    assert len(grids) == 1 and (grids[0]["cols"], grids[0]["rows"], grids[0]["cell"]) == (30, 10, 0.05)
    assert len({tuple(c) for c in grids[0]["removed"]}) == removed
    platforms_m2 = 2 * 0.5 * 0.5
    assert terrain.steppable.area == pytest.approx(platforms_m2 + (300 - removed) * 0.05**2, rel=1e-9)
    assert terrain.name == f"random_{removed}_4" and terrain.goal_x == pytest.approx(1.75)
    assert terrain.is_safe(nominal_feet_xy(terrain), margin=0.02).all()


def test_random_field_is_deterministic_per_seed() -> None:
    assert T.random_field(80, 1) == T.random_field(80, 1)
    assert T.random_field(80, 1) != T.random_field(80, 2)
    assert T.random_field(80, 1).regions[1]["removed"] != T.random_field(80, 2).regions[1]["removed"]


@pytest.mark.parametrize("removed", [-1, 301, 2.5, True, "80"])
def test_random_field_rejects_bad_removed(removed: Any) -> None:
    with pytest.raises(TerrainError, match="removed"):
        T.random_field(removed, 0)


def test_stepping_stones_shapes() -> None:
    terrain = T.stepping_stones()
    stones = terrain.regions[1:-1]
    shapes = [r["shape"] for r in stones]
    assert len(stones) == 8
    assert (shapes.count("star"), shapes.count("circle"), shapes.count("rect")) == (3, 2, 3)
    assert terrain.regions[0]["shape"] == terrain.regions[-1]["shape"] == "rect"
    stone_geoms = [T.region_geometry(r) for r in stones]
    xs = [g.bounds[0] for g in stone_geoms] + [g.bounds[2] for g in stone_geoms]
    assert 0.8 <= max(xs) - min(xs) <= 1.2
    for geom in stone_geoms:  # 10-20 cm stones (stars measured tip to tip), not touching each other
        assert 0.1 <= max(geom.bounds[2] - geom.bounds[0], geom.bounds[3] - geom.bounds[1]) <= 0.31
    assert len(shapely.get_parts(terrain.steppable)) == 10  # every stone is its own island


@pytest.mark.parametrize("factory", [T.stepping_stones, lambda: T.random_field(80, 0), T.push_field],
                         ids=["stepping_stones", "random_80_0", "push_field"])
def test_every_leg_always_has_safe_candidates(factory: Callable[[], Terrain]) -> None:
    """Along the straight path, each hip's 5 x 5 candidate grid keeps some safe footholds."""
    terrain = factory()
    hips_xy_base = ROBOT.hip_pos_base[:, :2]
    for base_x in np.arange(terrain.start_xy[0], terrain.goal_x, 0.01):
        base_xy = np.array([base_x, terrain.start_xy[1]])
        for hip_xy_base in hips_xy_base:
            candidates_xy = base_xy + hip_xy_base + CANDIDATE_OFFSETS_XY
            assert terrain.is_safe(candidates_xy, margin=FOOT_RADIUS_M).sum() >= 3, (terrain.name, base_x)


def kinematic_walk(terrain: Terrain, reach_m: float = 0.15, step_m: float = 0.005,
                   margin_m: float = 0.5 * FOOT_RADIUS_M, behind_m: float = 0.03) -> float:
    """Greedy acyclic walk along +x. A foot at least ``behind_m`` behind its hip (the furthest behind
    first) steps to its furthest safe candidate ahead (``margin_m`` inside the edges: the planner's
    default) as soon as it has one; otherwise the base advances while every foot stays within
    ``reach_m`` (x) of its hip. Returns the base x reached (stops when stuck)."""
    base_xy = terrain.start_xy.copy()
    hips_xy_base = ROBOT.hip_pos_base[:, :2]
    feet_xy = nominal_feet_xy(terrain)
    for _ in range(10_000):
        if base_xy[0] >= terrain.goal_x:
            break
        hips_xy = base_xy + hips_xy_base
        behind_x = hips_xy[:, 0] - feet_xy[:, 0]
        stepped = False
        for leg in np.argsort(-behind_x):
            if behind_x[leg] < behind_m:
                break
            candidates_xy = hips_xy[leg] + CANDIDATE_OFFSETS_XY
            ok = terrain.is_safe(candidates_xy, margin=margin_m) & (candidates_xy[:, 0] > feet_xy[leg, 0] + 0.02)
            if ok.any():
                feet_xy[leg] = candidates_xy[ok][np.argmax(candidates_xy[ok, 0])]
                stepped = True
                break
        if stepped:
            continue
        if np.all(np.abs(feet_xy[:, 0] - (base_xy[0] + step_m + hips_xy_base[:, 0])) <= reach_m):
            base_xy[0] += step_m
            continue
        break
    return float(base_xy[0])


@pytest.mark.parametrize("factory", [T.stepping_stones, T.narrow_stones])
def test_stone_scenes_are_crossable_by_an_acyclic_walk(factory: Callable[[], Terrain]) -> None:
    terrain = factory()
    assert kinematic_walk(terrain) >= terrain.goal_x


def test_narrow_stones_layout() -> None:
    terrain = T.narrow_stones()
    assert terrain.name == "narrow_stones"
    assert len(terrain.regions) == 5 and all(r["shape"] == "rect" for r in terrain.regions)
    bars = terrain.regions[1:-1]
    widths_x = [r["size"][0] for r in bars]
    lengths_y = [r["size"][1] for r in bars]
    # Narrow against the candidate grid: under the 5 cm spacing plus the planner's two 8 mm edge margins,
    # so for some hip positions a leg has no safe candidate on a bar.
    assert all(0.03 <= w < 0.05 + 2 * 0.008 for w in widths_x) and len(set(widths_x)) == 3
    assert all(length >= 0.3 for length in lengths_y) and len(set(lengths_y)) == 3
    edges = [(r["center"][0] - r["size"][0] / 2, r["center"][0] + r["size"][0] / 2) for r in terrain.regions]
    gaps = [edges[i + 1][0] - edges[i][1] for i in range(len(edges) - 1)]
    assert all(0.05 <= g < 0.2 for g in gaps)
    assert max(gaps[:3]) == gaps[2] and len({round(g, 6) for g in gaps[:3]}) == 3  # uneven, last bar farthest


def test_narrow_stones_map_variants() -> None:
    variant = T.narrow_stones(bar_width_m=0.06, last_gap_m=0.21)
    assert variant.name == "narrow_stones_w6_g21" and variant != T.narrow_stones()
    bars = variant.regions[1:-1]
    assert [r["size"][0] for r in bars] == [0.06] * 3
    last_gap = (bars[2]["center"][0] - 0.03) - (bars[1]["center"][0] + 0.03)
    assert last_gap == pytest.approx(0.21)
    assert T.narrow_stones(last_gap_m=0.2).name == "narrow_stones_g20"
    assert T.narrow_stones(last_gap_m=0.18).regions[1:-1] != bars
    for bad in ({"bar_width_m": 0.0}, {"bar_width_m": "wide"}, {"last_gap_m": -0.1}, {"last_gap_m": float("nan")}):
        with pytest.raises(TerrainError, match="narrow_stones: "):
            T.narrow_stones(**bad)


def test_push_field_keeps_start_clear() -> None:
    terrain = T.push_field()
    grid = np.stack(np.meshgrid(np.linspace(-0.3, 0.3, 61), np.linspace(-0.3, 0.3, 61)), axis=-1).reshape(-1, 2)
    assert terrain.is_safe(grid).all()
    hole_fraction = 1.0 - terrain.steppable.area / (4.0 * 2.0)
    assert 0.12 <= hole_fraction <= 0.18
    assert T.push_field(1) != terrain and T.push_field(0) == terrain


def test_flat() -> None:
    terrain = T.flat()
    assert terrain.steppable.area == pytest.approx(400.0) and terrain.goal_x == 8.0
    assert terrain.is_safe([[8.3, 0.0]], margin=0.02)[0]
    assert T.flat((3.0, 1.0)).goal_x == pytest.approx(1.0)
    with pytest.raises(TerrainError):
        T.flat((0.5, 0.5))


def test_by_name_resolve_and_available(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert T.by_name("stepping_stones") == T.stepping_stones()
    assert T.by_name("random", removed=60, seed=2) == T.random_field(60, 2)
    with pytest.raises(TerrainError, match="needs 'removed'"):
        T.by_name("random")
    with pytest.raises(TerrainError, match="unknown terrain generator"):
        T.by_name("moon")
    assert T.resolve("random", removed=70, seed=1).name == "random_70_1"
    monkeypatch.setenv("CONTACTNET_TERRAINS", str(tmp_path))
    assert T.terrains_dir() == tmp_path and T.available() == []
    T.narrow_stones().save(tmp_path / "mine.json")
    assert T.available() == ["mine"]
    assert T.resolve("mine") == T.narrow_stones()
    assert T.resolve(str(tmp_path / "mine.json")) == T.narrow_stones()
    assert T.resolve("flat") == T.flat()  # generator fallback when no file is shipped
    with pytest.raises(TerrainError, match=r"unknown terrain \"moon\".*flat.*mine.*random"):
        T.resolve("moon")
    with pytest.raises(TerrainError, match="cannot read file"):
        T.resolve("nowhere.json")


def test_main_writes_the_shipped_files(tmp_path: Path) -> None:
    assert T.main(["--out", str(tmp_path)]) == 0
    assert sorted(p.stem for p in tmp_path.glob("*.json")) == sorted(T.SHIPPED)


@pytest.mark.parametrize("path", sorted(REPO_TERRAINS.glob("*.json")), ids=lambda p: p.stem)
def test_shipped_terrain_files(path: Path) -> None:
    terrain = Terrain.load(path)
    assert terrain.is_safe(nominal_feet_xy(terrain), margin=0.02).all()
    if path.stem in T.SHIPPED:  # the file is what the generator makes (regenerate with python -m ...)
        assert terrain == T.SHIPPED[path.stem](), f"{path} is stale: run python -m contactnet.terrain"


def test_all_shipped_files_exist() -> None:
    assert {p.stem for p in REPO_TERRAINS.glob("*.json")} >= set(T.SHIPPED)


# ---------------------------------------------------------------------------------------------
# Geometry for simulation and display
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(TERRAIN_FACTORIES))
def test_mesh_is_watertight_with_the_steppable_top(name: str) -> None:
    terrain = TERRAIN_FACTORIES[name]()
    mesh = terrain.mesh(thickness=0.4)
    area = terrain.steppable.area
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume == pytest.approx(0.4 * area, rel=1e-9)
    top = (mesh.face_normals[:, 2] > 0.999) & (np.abs(mesh.triangles_center[:, 2] - terrain.surface_z) < 1e-12)
    assert mesh.area_faces[top].sum() == pytest.approx(area, rel=1e-9)
    assert mesh.bounds[0][2] == pytest.approx(terrain.surface_z - 0.4)
    assert mesh.bounds[1][2] == pytest.approx(terrain.surface_z)
    assert len(mesh.vertices) < 50_000


def test_mesh_follows_surface_z() -> None:
    terrain = Terrain.from_dict({**valid_dict(), "surface_z": 0.1})
    assert terrain.mesh(0.2).bounds[:, 2] == pytest.approx([-0.1, 0.1])
    with pytest.raises(ValueError, match="thickness"):
        terrain.mesh(0.0)
    with pytest.raises(ValueError, match="thickness"):
        terrain.mesh(float("nan"))


def test_summary_and_render_png(tmp_path: Path) -> None:
    terrain = T.stepping_stones()
    text = terrain.summary()
    assert "stepping_stones" in text and f"{terrain.steppable.area:.4f} m^2" in text
    assert "3 star" in text and "2 circle" in text and "5 rect" in text and "goal_x" in text
    path = terrain.render_png(tmp_path / "out" / "stones.png", dpi=40)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with_feet = terrain.render_png(tmp_path / "feet.png", dpi=40, feet_xy_start=nominal_feet_xy(terrain))
    assert with_feet.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from matplotlib.figure import Figure

    def labels(**kwargs: Any) -> list[str]:
        return [line.get_label() for line in terrain.render(ax=Figure().add_subplot(), **kwargs).lines]

    assert "nominal feet" in labels(feet_xy_start=nominal_feet_xy(terrain)) and "nominal feet" not in labels()


def test_benchmark_rows() -> None:
    rows = benchmark_is_safe(repeats=3, margins=(0.0,), sizes=(1, 100), validation_repeats=0)
    assert len(rows) == 4
    assert {"terrain", "n_points", "is_safe_median_us", "is_safe_p90_us", "shapely_median_us", "speedup"} <= set(rows[0])
    assert all(math.isfinite(r["speedup"]) and r["speedup"] > 0 for r in rows)


def test_replace_revalidates_and_push_field_seed_resolves() -> None:
    terrain = T.stepping_stones()
    renamed = dataclasses.replace(terrain, name="renamed")
    assert renamed.name == "renamed" and shapely.equals(renamed.steppable, terrain.steppable)
    with pytest.raises(TerrainError, match="goal_x"):
        dataclasses.replace(terrain, goal_x=-1.0)
    assert T.resolve("push_field", seed=3) == T.push_field(3)




def test_stone_grid_has_esfal_s_stones_under_the_feet():
    from contactnet.robots import load_robot

    terrain = T.resolve("stone_grid")
    stones = [r for r in terrain.regions if tuple(r["size"]) == (0.11, 0.11)]
    assert len(stones) == 40
    xs = sorted({round(r["center"][0], 6) for r in stones})
    ys = sorted({round(r["center"][1], 6) for r in stones})
    assert np.allclose(np.diff(xs), 0.19) and np.allclose(np.diff(ys), 0.147)
    for name in ("solo12", "go2"):  # a row of stones under each side's feet, a foot radius inside the stone
        feet_y = load_robot(name).description.foot_nominal_base[:, 1]
        assert all(min(abs(y - row) for row in ys) < 0.055 - load_robot(name).description.foot_radius_m
                   for y in feet_y)
    with pytest.raises(T.TerrainError, match="do not fit"):
        T.stone_grid(side_m=0.2)


def test_a_scene_at_another_robot_s_size():
    from contactnet.registry import load_robot, terrain_for

    stairs = T.resolve("stairs")
    big = T.scaled(stairs, 1.5)
    assert big.steppable.area == pytest.approx(2.25 * stairs.steppable.area)
    assert big.goal_x == pytest.approx(1.5 * stairs.goal_x) and np.allclose(big.start_xy, 1.5 * stairs.start_xy)
    assert [z for z, _ in big.levels] == pytest.approx([1.5 * z for z, _ in stairs.levels])
    assert T.scaled(stairs, 1.0) is stairs
    with pytest.raises(T.TerrainError, match="scale"):
        T.scaled(stairs, 0.0)
    solo, go2 = load_robot("solo12"), load_robot("go2")
    field = T.resolve("random", removed=80, seed=3)
    assert terrain_for("random", solo, removed=80, seed=3).to_dict() == field.to_dict()  # the paper's, for Solo12
    go2_field = terrain_for("random", go2, removed=80, seed=3)
    assert go2_field.steppable.area == pytest.approx(go2.description.size_scale ** 2 * field.steppable.area)
    assert terrain_for("random", go2, removed=80, seed=3, scale=1.0).to_dict() == field.to_dict()
    assert terrain_for("stone_grid", go2).to_dict() == T.resolve("stone_grid").to_dict()  # esfal's numbers: Go2's
