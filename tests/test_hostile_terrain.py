"""Hostile but fair terrains (issue 11, findings 1, 2 and 4 on the library side).

1. A valid 500 x 500 grid with 20,000 cells removed took 43 s to validate: validation is now linear in
   the input. Timing is a benchmark (``contactnet bench terrain``), not an assertion here: the tests
   count the shapely calls (a constant number of vectorized ones for a grid of any size, no union of
   squares) and check the fast paths against slow, obvious references.
2. Such a terrain could not be simulated (PyBullet refuses meshes over ~175,000 triangles): every
   terrain that validates respects one complexity budget (``contactnet.terrain.schema``) and loads
   into the simulator, its mesh cut into chunks PyBullet takes.
3. (Finding 4) A JSON integer of more than 4,300 digits gave a 26-line traceback: every JSON input is
   read with limits, every error is one line, and error messages show a short excerpt of any value.
"""

from __future__ import annotations

import collections
import json
import math
import re
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import shapely

from app.live import editor
from contactnet import cli
from contactnet.bench.terrain import benchmark_validation, large_grid_dict
from contactnet.sim.pybullet_world import Simulator, standing_torques
from contactnet.strict_json import JsonInputError, JsonLimits, loads_strict
from contactnet.terrain import Terrain, TerrainError, resolve, schema, union, validate_terrain_bytes
from contactnet.terrain.mesh import split_mesh
from contactnet.terrain.regions import cells_geometry, outline_corner_count, region_geometry
from contactnet.terrain.schema import (
    MAX_GRID_CELLS,
    MAX_GRID_REGIONS,
    MAX_MESH_FACES,
    MAX_OUTLINE_VERTICES,
    MAX_POLYGON_VERTICES,
    MAX_REGIONS,
    loads_terrain_json,
    show,
)
from contactnet.terrain.union import mesh_face_bound, snap

OVERLAYS = {"union", "union_all", "unary_union", "disjoint_subset_union_all", "coverage_union_all", "box",
            "intersection", "difference", "buffer"}


# ---- helpers ---------------------------------------------------------------------------------------
def terrain_dict(regions: list[dict], start: tuple[float, float] = (0.0, 0.0), goal_x: float = 1.0) -> dict:
    return {"name": "hostile", "start": list(start), "goal_x": goal_x, "regions": regions}


def rect(x: float, y: float, w: float = 0.1, h: float | None = None) -> dict:
    return {"shape": "rect", "center": [x, y], "size": [w, w if h is None else h]}


def grid(cols: int, rows: int, removed: list | None = None, cell: float = 0.05, origin=(0.0, 0.0)) -> dict:
    return {"shape": "grid", "origin": list(origin), "cell": cell, "cols": cols, "rows": rows,
            "removed": removed or []}


def wavy_polygon(x: float, y: float, radius: float, n: int) -> dict:
    angle = np.arange(n) * 2 * math.pi / n
    r = radius * (1 + 0.2 * np.sin(7 * angle))
    return {"shape": "polygon", "vertices": np.column_stack([x + r * np.cos(angle), y + r * np.sin(angle)]).tolist()}


def comb(teeth: int, size: float = 10.0, across: bool = False) -> dict:
    """A comb of thin teeth; two of them, one turned across, cross teeth x teeth x 4 times."""
    width = size / teeth
    xy = [(0.0, -0.1), (size, -0.1)]
    for i in reversed(range(teeth)):
        left, right = i * width, i * width + 0.5 * width
        xy += [(right, 0.0), (right, size), (left, size), (left, 0.0)]
    return {"shape": "polygon", "vertices": [[y, x] if across else [x, y] for x, y in xy]}


@pytest.fixture
def shapely_calls(monkeypatch) -> collections.Counter:
    """Counts the calls of every shapely function made through the ``shapely`` namespace."""
    calls: collections.Counter = collections.Counter()
    for name in dir(shapely):
        function = getattr(shapely, name)
        if name.startswith("_") or isinstance(function, type) or not callable(function):
            continue

        def counted(*args, _function=function, _name=name, **kwargs):
            calls[_name] += 1
            return _function(*args, **kwargs)

        monkeypatch.setattr(shapely, name, counted)
    return calls


def reference_cells(present: np.ndarray, edges_x: np.ndarray, edges_y: np.ndarray):
    """Slow and obvious: GEOS unites one square per present cell."""
    rows, cols = np.nonzero(present)
    return shapely.union_all(shapely.box(edges_x[cols], edges_y[rows], edges_x[cols + 1], edges_y[rows + 1]),
                             grid_size=1e-9)


def parts_and_holes(geometry) -> tuple[int, int]:
    parts = shapely.get_parts(geometry)
    parts = parts[~shapely.is_empty(parts)]
    return len(parts), int(shapely.get_num_interior_rings(parts).sum())


# ---- finding 1: validation is linear -----------------------------------------------------------------
@pytest.fixture(scope="module")
def large_grid() -> dict:
    return large_grid_dict()  # 500 x 500 cells of 2.5 cm, 20,000 removed, start at the centre


def test_the_large_grid_validates_from_its_cells_without_uniting_squares(large_grid, shapely_calls):
    terrain = Terrain.from_json(json.dumps(large_grid).encode(), source="large.json")
    assert not OVERLAYS & set(shapely_calls), shapely_calls  # no box per cell, no union at all
    assert sum(shapely_calls.values()) < 40  # a handful of vectorized calls
    cell = 0.025
    assert terrain.steppable.is_valid
    assert terrain.steppable.area == pytest.approx((500 * 500 - 20_000) * cell**2, rel=1e-9)
    removed = np.array(large_grid["regions"][0]["removed"])
    present = np.ones((500, 500), dtype=bool)
    present[removed[:, 1], removed[:, 0]] = False
    rows, cols = np.nonzero(np.ones((500, 500), dtype=bool))
    centres = np.column_stack([(cols + 0.5) * cell, (rows + 0.5) * cell])
    np.testing.assert_array_equal(terrain.is_safe(centres), present[rows, cols])


def test_the_work_of_validating_a_grid_does_not_grow_with_its_size(shapely_calls):
    """The same shapely calls, as many of them, for 10,000 and for 160,000 cells: each is vectorized."""
    counts = []
    for side in (100, 400):
        shapely_calls.clear()
        Terrain.from_dict(large_grid_dict(cols=side, rows=side, removed=side * side // 12, cell=0.025))
        counts.append(dict(shapely_calls))
    assert counts[0] == counts[1]
    assert not OVERLAYS & set(counts[0])


def test_stones_on_a_large_grid_are_united_in_a_few_overlays(large_grid, shapely_calls):
    rng = np.random.default_rng(3)
    stones = [rect(float(x), float(y), 0.03) for x, y in rng.uniform(0.5, 12.0, (2000, 2))]
    data = {**large_grid, "regions": large_grid["regions"] + stones}
    terrain = Terrain.from_dict(data)
    assert shapely_calls["union"] <= 3 and shapely_calls["disjoint_subset_union_all"] <= 3, shapely_calls
    grid_only = Terrain.from_dict(large_grid).steppable
    stone_union = shapely.union_all([shapely.box(*snap([x - 0.015, y - 0.015, x + 0.015, y + 0.015]))
                                     for x, y in (s["center"] for s in stones)])
    assert terrain.steppable.symmetric_difference(grid_only.union(stone_union)).area < 1e-12


@pytest.mark.parametrize("seed", range(6))
def test_grid_tracing_matches_geos_on_random_rasters(seed):
    """Random rasters, dense and sparse: parts, holes, validity and the point set equal GEOS's union."""
    rng = np.random.default_rng(seed)
    for _ in range(60):
        rows, cols = rng.integers(1, 22, 2)
        present = rng.random((rows, cols)) < rng.uniform(0.15, 0.9)
        edges_x = snap(rng.uniform(-5, 5) + 0.05 * np.arange(cols + 1))
        edges_y = snap(rng.uniform(-5, 5) + 0.05 * np.arange(rows + 1))
        traced, reference = cells_geometry(present, edges_x, edges_y), reference_cells(present, edges_x, edges_y)
        assert traced.is_valid, shapely.is_valid_reason(traced)
        assert parts_and_holes(traced) == parts_and_holes(reference)
        assert traced.symmetric_difference(reference).area < 1e-15
        rings = sum(1 + len(p.interiors) for p in shapely.get_parts(traced) if not p.is_empty)
        assert shapely.get_num_coordinates(traced) == outline_corner_count(present) + rings  # corners only


@pytest.mark.parametrize("pattern", [
    ["#.", ".#"],  # two cells touching at a corner: two polygons
    ["###", "#.#", "##."],  # a hole touching the outline at a corner... of a C that closes on itself
    ["#.#", ".#.", "#.#"],  # a diagonal cross: five squares
    [".#.", "#.#", ".#."],  # a ring of corner-touching squares around a removed cell
    ["#####", "#...#", "#.#.#", "#...#", "#####"],  # an island in a hole
    ["####", "#..#", "#.##", "##.#"],  # a hole pinched against another
    ["#.#.#", ".#.#.", "#.#.#", ".#.#."],  # a checkerboard
])
def test_grid_tracing_of_pinches_and_nesting(pattern):
    present = np.array([[c == "#" for c in row] for row in pattern[::-1]])
    edges_x, edges_y = np.arange(present.shape[1] + 1) * 0.1, np.arange(present.shape[0] + 1) * 0.1
    traced, reference = cells_geometry(present, edges_x, edges_y), reference_cells(present, edges_x, edges_y)
    assert traced.is_valid and parts_and_holes(traced) == parts_and_holes(reference)
    assert traced.symmetric_difference(reference).area < 1e-15


def test_a_spiral_grid_traces_in_one_piece():
    """The longest path of cells a grid can have (union-find on runs must still converge fast)."""
    side = 201
    present = np.zeros((side, side), dtype=bool)
    lo, hi = 0, side - 1
    while lo <= hi:
        present[lo, lo:hi + 1] = present[lo:hi + 1, hi] = present[hi, lo:hi + 1] = True
        present[lo + 2:hi + 1, lo] = True
        if lo + 2 <= hi:
            present[lo + 2, lo:lo + 3] = True
        lo, hi = lo + 2, hi - 2
    traced = cells_geometry(present, np.arange(side + 1) * 0.02, np.arange(side + 1) * 0.02)
    assert traced.is_valid
    assert traced.area == pytest.approx(present.sum() * 0.02**2)


def test_edge_contacts_match_a_brute_force_count():
    rng = np.random.default_rng(7)
    for _ in range(25):
        regions = [rect(float(x), float(y), float(w)) for x, y, w in rng.uniform((0, 0, 0.05), (1, 1, 0.4), (6, 3))]
        regions += [{"shape": "circle", "center": rng.uniform(0, 1, 2).tolist(), "radius": 0.2}]
        regions += [grid(4, 4, [[1, 1], [2, 2]], cell=0.1, origin=rng.uniform(0, 1, 2).tolist())]
        pieces = [Terrain.from_dict(terrain_dict([r], start=_inside(r), goal_x=5.0)).steppable for r in regions]
        edges, owner = [], []
        for index, piece in enumerate(pieces):
            xy, ring = shapely.get_coordinates(shapely.get_rings(shapely.get_parts(piece)), return_index=True)
            keep = ring[1:] == ring[:-1]
            edges += list(shapely.linestrings(np.stack([xy[:-1][keep], xy[1:][keep]], axis=1)))
            owner += [index] * int(keep.sum())
        brute = sum(1 for a in range(len(edges)) for b in range(a + 1, len(edges))
                    if owner[a] != owner[b] and edges[a].intersects(edges[b]))
        assert union._check_edge_contacts(np.array(pieces, dtype=object), "t") == brute


def _inside(region: dict) -> tuple[float, float]:
    """A point on a region (a grid's first cell must be present)."""
    if region["shape"] == "grid":
        return region["origin"][0] + 0.01, region["origin"][1] + 0.01
    if region["shape"] == "polygon":
        return shapely.Polygon(region["vertices"]).representative_point().coords[0]
    return tuple(region["center"])


def test_overlapping_detailed_regions_are_refused_before_any_overlay(shapely_calls):
    """Two combs crossing a million times would take minutes to unite: refused by counting edge contacts."""
    data = terrain_dict([comb(500), comb(500, across=True)], start=(0.01, -0.05))
    with pytest.raises(TerrainError) as info:
        Terrain.from_dict(data, source="combs.json")
    assert str(info.value).startswith("combs.json: regions: edges of different regions ")
    assert "\n" not in str(info.value)
    assert not OVERLAYS & set(shapely_calls), shapely_calls


@pytest.mark.parametrize("regions, message", [
    ([comb(100), comb(100, across=True)], r"regions: edges of different regions cross or touch in 40\d\d\d pairs; "
                                          r"the limit is 40000"),
    ([rect(float(x), float(y), 0.2) for x, y in np.random.default_rng(1).uniform(0, 1, (5000, 2))],
     r"regions: edges of different regions lie close together in \d+ pairs; the limit is 500000"),
    (large_grid_dict(removed=8000)["regions"] + [comb(2000, size=12.4)],
     r"regions: the outlines are too long for their detail to check where regions cross \(\d+ pieces"),
])
def test_the_edge_contact_limits(monkeypatch, regions, message):
    monkeypatch.setattr(union, "MAX_EDGE_CONTACTS", 40_000)
    with pytest.raises(TerrainError, match=message):
        Terrain.from_dict(terrain_dict(regions, start=(0.01, -0.05)))


def test_stones_lying_in_holes_are_united_correctly():
    """10,000 holes and a stone inside each: kept beside the grid, not overlaid with it."""
    removed, stones = [], []
    for col in range(0, 80, 4):
        for row in range(0, 80, 4):
            if col or row:
                removed += [[col + 1, row + 1], [col + 2, row + 1], [col + 1, row + 2], [col + 2, row + 2]]
                stones.append(rect((col + 2) * 0.025, (row + 2) * 0.025, 0.01))
    stones[5]["size"] = [0.05, 0.05]  # this one touches the grid
    terrain = Terrain.from_dict(terrain_dict([grid(80, 80, removed, cell=0.025)] + stones, (0.0125, 0.0125)))
    reference = shapely.union_all([Terrain.from_dict(terrain_dict([grid(80, 80, removed, cell=0.025)],
                                                                  (0.0125, 0.0125))).steppable]
                                  + [shapely.box(*snap([s["center"][0] - s["size"][0] / 2, s["center"][1] - s["size"][1] / 2,
                                                        s["center"][0] + s["size"][0] / 2, s["center"][1] + s["size"][1] / 2]))
                                     for s in stones])
    assert terrain.steppable.is_valid
    assert terrain.steppable.symmetric_difference(reference).area < 1e-12
    assert parts_and_holes(terrain.steppable) == parts_and_holes(reference)


@pytest.mark.parametrize("seed", range(4))
def test_mixed_regions_unite_like_geos(seed):
    rng = np.random.default_rng(seed)
    regions = [rect(float(x), float(y), float(w)) for x, y, w in rng.uniform((0, 0, 0.05), (3, 3, 0.6), (40, 3))]
    regions += [{"shape": "circle", "center": rng.uniform(0, 3, 2).tolist(), "radius": float(r)}
                for r in rng.uniform(0.05, 0.5, 10)]
    regions += [wavy_polygon(*rng.uniform(0, 3, 2), 0.4, 3000)]
    cells = rng.choice(np.arange(1, 40 * 40), size=300, replace=False)  # cell 0 stays, for _inside
    regions += [grid(40, 40, [[int(i % 40), int(i // 40)] for i in cells], origin=(0.5, 0.5))]
    start = tuple(regions[0]["center"])
    terrain = Terrain.from_dict(terrain_dict(regions, start=start, goal_x=start[0] + 1))
    reference = shapely.union_all([Terrain.from_dict(terrain_dict([r], start=_inside(r), goal_x=5.0)).steppable
                                   for r in regions])
    assert terrain.steppable.is_valid
    assert terrain.steppable.symmetric_difference(reference).area < 1e-9


# ---- the budget: every limit, exactly at it and one over ----------------------------------------------
def test_regions_at_the_limit():
    Terrain.from_dict(terrain_dict([rect(i % 100, i // 100, 0.5) for i in range(MAX_REGIONS)]))


def test_grid_regions_at_the_limit_and_over():
    grids = [grid(3, 3, origin=(i * 0.2, 0.0)) for i in range(MAX_GRID_REGIONS + 1)]
    Terrain.from_dict(terrain_dict(grids[:-1], start=(0.01, 0.01)))
    with pytest.raises(TerrainError, match=rf"^t: regions\[{MAX_GRID_REGIONS}\]: the regions up to here have "
                                           rf"{MAX_GRID_REGIONS + 1} grids; the limit is {MAX_GRID_REGIONS}$"):
        Terrain.from_dict(terrain_dict(grids, start=(0.01, 0.01)), source="t")


def test_grid_cells_of_all_grids_at_the_limit_and_over():
    half = MAX_GRID_CELLS // 2
    first, second = grid(500, half // 500, cell=0.01), grid(500, half // 500, cell=0.01, origin=(0.0, 3.0))
    Terrain.from_dict(terrain_dict([first, second], start=(0.01, 0.01)))
    second["rows"] += 1
    with pytest.raises(TerrainError, match=rf"^t: regions\[1\].rows: the grids up to here have "
                                           rf"{MAX_GRID_CELLS + 500} cells; the limit is {MAX_GRID_CELLS}$"):
        Terrain.from_dict(terrain_dict([first, second], start=(0.01, 0.01)), source="t")


def test_outline_vertices_at_the_limit_and_over():
    """10 polygons of 10,000 vertices: at the outline limit and, at 399,960 faces, just under the mesh's."""
    polygons = [wavy_polygon(3.0 * i, 0.0, 1.0, MAX_POLYGON_VERTICES) for i in range(10)]
    assert 10 * MAX_POLYGON_VERTICES == MAX_OUTLINE_VERTICES
    terrain = Terrain.from_dict(terrain_dict(polygons))
    assert mesh_face_bound(terrain.steppable) == 10 * (4 * MAX_POLYGON_VERTICES - 4) <= MAX_MESH_FACES
    with pytest.raises(TerrainError, match=r"^t: regions\[10\]: the regions up to here have 100004 outline "
                                           r"vertices; the limit is 100000$"):
        Terrain.from_dict(terrain_dict(polygons + [rect(40.0, 0.0)]), source="t")
    # a grid's outline counts its corners: 3 squares apart = 12 corners
    with pytest.raises(TerrainError, match=r"^t: regions\[10\]: the regions up to here have 100012 outline vertices"):
        Terrain.from_dict(terrain_dict(polygons + [grid(5, 1, [[1, 0], [3, 0]], origin=(40, 0))]), source="t")


def test_edge_contacts_exactly_at_the_limit_and_over(monkeypatch):
    data = terrain_dict([comb(20), comb(20, across=True)], start=(0.01, -0.05))
    pieces = np.array([region_geometry(r, transform=snap) for r in Terrain.from_dict(data).regions])  # as united
    contacts = union._check_edge_contacts(pieces, "t")
    assert contacts > 1600  # 20 x 20 teeth, each pair crossing 4 times
    monkeypatch.setattr(union, "MAX_EDGE_CONTACTS", contacts)
    Terrain.from_dict(data)
    monkeypatch.setattr(union, "MAX_EDGE_CONTACTS", contacts - 1)
    with pytest.raises(TerrainError, match=rf"^t: regions: edges of different regions cross or touch in {contacts} "
                                           rf"pairs; the limit is {contacts - 1}$"):
        Terrain.from_dict(data, source="t")


def test_mesh_faces_exactly_at_the_limit_and_over(monkeypatch, large_grid):
    bound = mesh_face_bound(Terrain.from_dict(large_grid).steppable)
    assert 300_000 < bound <= MAX_MESH_FACES
    monkeypatch.setattr(union, "MAX_MESH_FACES", bound)
    Terrain.from_dict(large_grid)
    monkeypatch.setattr(union, "MAX_MESH_FACES", bound - 1)
    with pytest.raises(TerrainError, match=rf"^t: regions: the steppable surface needs up to {bound} mesh faces \(4 "
                                           rf"per outline vertex and per hole\); the limit is {bound - 1}$"):
        Terrain.from_dict(large_grid, source="t")


def test_a_grid_over_the_mesh_budget_is_refused_in_one_line():
    with pytest.raises(TerrainError, match=rf"^big.json: regions: the steppable surface needs up to \d+ mesh faces "
                                           rf"\(4 per outline vertex and per hole\); the limit is {MAX_MESH_FACES}$"):
        Terrain.from_dict(large_grid_dict(removed=32_000), source="big.json")


@pytest.mark.parametrize("name", ["flat", "stepping_stones", "narrow_stones", "push_field", "random_80_0"])
def test_the_face_bound_bounds_the_mesh(name):
    terrain = resolve(name)
    assert len(terrain.mesh().faces) <= mesh_face_bound(terrain.steppable) <= MAX_MESH_FACES


# ---- finding 2: whatever validates simulates ---------------------------------------------------------
def _stands(robot, terrain: Terrain, seconds: float = 0.3) -> int:
    """Load ``terrain`` into a Simulator, stand for ``seconds``; returns the terrain body's links."""
    with Simulator(robot, terrain) as sim:
        links = sim.client.getNumJoints(sim.terrain_id)
        target = robot.joint_standing
        state = sim.state(True)
        for _ in range(round(seconds / sim.config.dt_s)):
            sim.step(standing_torques(state, target))
            state = sim.state(True)
        assert state.foot_contact.all() and not sim.fallen()
    return links


def test_the_large_grid_loads_into_the_simulator(robot, large_grid):
    """266,000 triangles: PyBullet refused them as one shape; now three chunks of one static body."""
    assert _stands(robot, Terrain.from_dict(large_grid)) >= 2


def test_shipped_terrains_stay_one_mesh_of_one_body(robot):
    with Simulator(robot, resolve("push_field")) as sim:
        assert sim.client.getNumJoints(sim.terrain_id) == 0


def test_mesh_chunks_cover_the_mesh_and_fit_pybullet(large_grid):
    terrain = Terrain.from_dict(large_grid)
    mesh = terrain.mesh()
    assert len(mesh.faces) <= mesh_face_bound(terrain.steppable) <= MAX_MESH_FACES
    chunks = split_mesh(mesh.vertices, mesh.faces, max_faces=100_000, max_vertices=100_000)
    assert len(chunks) >= 3 and all(len(f) <= 100_000 and len(v) <= 100_000 for v, f in chunks)

    def triangles(vertices, faces):
        return {tuple(sorted(map(tuple, vertices[face].round(12)))) for face in faces}

    assert sum(len(f) for _, f in chunks) == len(mesh.faces)
    assert set().union(*(triangles(v, f) for v, f in chunks)) == triangles(np.asarray(mesh.vertices), mesh.faces)
    assert mesh.is_watertight  # the tiles the top was triangulated in leave no seam


@pytest.mark.slow
def test_terrains_at_the_budget_limits_load_into_the_simulator(robot):
    at_outline_and_faces = terrain_dict([wavy_polygon(3.0 * i, 0.0, 1.0, MAX_POLYGON_VERTICES) for i in range(10)])
    at_regions = terrain_dict([rect(0.4 * (i % 100), 0.4 * (i // 100), 0.398) for i in range(MAX_REGIONS)])
    at_grid_regions = terrain_dict([grid(50, 50, [[i % 50, 20]], cell=0.025, origin=(1.25 * (i % 10), 1.25 * (i // 10)))
                                    for i in range(MAX_GRID_REGIONS)], start=(0.6, 0.6))
    abutting = terrain_dict([rect(0.1 * i, 0.0, 0.1, 1.0) for i in range(7000)], start=(3.5, 0.0),
                            goal_x=10.0)  # about 49,000 edge contacts
    for data in (at_outline_and_faces, at_regions, at_grid_regions, abutting):
        _stands(robot, Terrain.from_dict(data), seconds=0.05)


# ---- finding 4 and JSON with limits -------------------------------------------------------------------
HUGE = 10**5000


@pytest.mark.parametrize("field, value", [
    ("goal_x", HUGE), ("start", [HUGE, 0]), ("name", HUGE), ("surface_z", -HUGE), ("description", HUGE),
    ("regions", [{"shape": "grid", "origin": [0, 0], "cell": 0.1, "cols": HUGE, "rows": 2}]),
    ("regions", [{"shape": "grid", "origin": [0, 0], "cell": 0.1, "cols": 2, "rows": 2, "removed": [[HUGE, 0]]}]),
    ("regions", [{"shape": "star", "center": [0, 0], "outer_radius": 1, "inner_radius": 0.5, "points": HUGE}]),
    ("regions", [{"shape": "rect", "center": [0, 0], "size": [1, 1], HUGE: 1}]),
    ("regions", [{"shape": "rect", "center": [0, 0], "size": [1, 1], "k" * 100_000: 1}]),
    ("regions", [{"shape": "polygon", "vertices": [[0, 0], [1, 0], [HUGE, 1]]}]),
], ids=["goal_x", "start", "name", "surface_z", "description", "cols", "removed", "points", "key", "long key",
        "vertex"])  # (pytest cannot print a 5,000-digit int)
def test_hostile_python_values_give_one_short_line(field, value):
    data = terrain_dict([rect(0.0, 0.0, 1.0)])
    data[field] = value
    with pytest.raises(TerrainError) as info:
        Terrain.from_dict(data, source="api")
    text = str(info.value)
    assert text.startswith("api: ") and "\n" not in text and len(text) < 250


def test_show_is_short_and_safe_for_any_value():
    nested: list = []
    inner = nested
    for _ in range(100_000):
        inner.append([])
        inner = inner[0]
    for value in (HUGE, -HUGE, [HUGE], {HUGE: 1}, "x" * 10**6, list(range(10**6)), nested, object(),
                  np.arange(10**6), float("nan"), 2**190):
        assert len(show(value)) <= 60
    assert show([5.0, 5.0]) == "[5.0, 5.0]" and show({"a": [1, None, True]}) == '{"a": [1, null, true]}'
    assert show(HUGE) == "<an integer of about 5001 digits>" and show(2**190) == str(2**190)


def _big_integer_file(tmp_path):
    path = tmp_path / "huge.json"
    path.write_text('{"name": "x", "start": [0, 0], "goal_x": ' + "9" * 5000 + ', "regions": []}')
    return path


def test_terrain_check_with_a_5000_digit_integer_exits_2_with_one_line(tmp_path, capsys):
    path = _big_integer_file(tmp_path)
    assert cli.main(["terrain", "check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err == (f"contactnet: error: {path}: a number of 5000 characters (999999999999999999999999...); "
                   "the limit is 40\n")


def test_simulate_with_a_5000_digit_integer_exits_2_with_one_line(tmp_path, capsys):
    path = _big_integer_file(tmp_path)
    assert cli.main(["simulate", "--terrain", str(path), "--gait", "walk", "--planner", "heuristic"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"contactnet: error: {path}: a number of 5000 characters")


@pytest.mark.parametrize("content, message", [
    (b'{"a": ' * 9 + b"1" + b"}" * 9, "JSON nested deeper than 8 levels"),
    (b"[" + b"0," * 2_000_000 + b"0]", "more than 2000000 JSON values"),
    (b'{"goal_x": 1' + b"0" * 45 + b"}", "a number of 46 characters"),
    (b'{"goal_x": 0.' + b"0" * 45 + b"1}", "a number of 48 characters"),
    (b'{"name": "x", "name": "y"}', 'duplicate key "name" in a JSON object'),
    (b'{"name": "caf\xe9"}', "not UTF-8 text (byte 13)"),
    (b'{"name": ', "not valid JSON: Expecting value (line 1, column 10)"),
    (b"[" * 100_000, "JSON nested deeper than 8 levels"),
])
def test_terrain_json_is_read_with_limits(content, message):
    with pytest.raises(TerrainError) as info:
        loads_terrain_json(content, "t.json")
    assert str(info.value) == f"t.json: {message}" or str(info.value).startswith(f"t.json: {message}")
    assert "\n" not in str(info.value) and info.value.source == "t.json"


def test_terrain_files_and_uploads_are_read_with_limits(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 50 + "]" * 50)
    with pytest.raises(TerrainError, match=rf"^{re.escape(str(path))}: JSON nested deeper than 8 levels$"):
        Terrain.load(path)
    with pytest.raises(editor.EditError, match=r"^upload.json: a number of 5000 characters"):
        editor.parse_upload(_big_integer_file(tmp_path).read_bytes(), source="upload.json")
    with pytest.raises(TerrainError, match=r"^up: 1001 bytes of JSON; the limit is 1000 bytes$"):
        validate_terrain_bytes(b" " * 1001, source="up", max_bytes=1000)


def test_a_long_number_inside_a_string_is_fine():
    data = loads_terrain_json(b'{"description": "' + b"1" * 500 + b'", "goal_x": 1.5}', "t")
    assert data == {"description": "1" * 500, "goal_x": 1.5}


def test_strict_json_fast_path_reads_like_the_checked_one():
    """Without a long run of number characters anywhere, numbers are converted by the C parser alone."""
    rng = np.random.default_rng(0)
    values = {"i": rng.integers(-10**6, 10**6, 50).tolist(), "f": rng.normal(size=50).tolist(), "e": [1e300, -2.5e-300],
              "s": ["eeee", "1e5", ""], "n": [None, True, False]}
    text = json.dumps(values)
    limits = JsonLimits(max_number_chars=30)
    assert loads_strict(text, "t", limits) == values
    padded = json.dumps({**values, "s": values["s"] + ["9" * 40]})  # the string trips the scan: the checked path
    assert loads_strict(padded, "t", limits)["s"][-1] == "9" * 40
    with pytest.raises(JsonInputError, match="a number of 31 characters"):
        loads_strict("[" + "1" * 31 + "]", "t", limits)


# ---- what the API calls -------------------------------------------------------------------------------
def test_validate_terrain_bytes_in_worker_threads(large_grid):
    content = json.dumps(large_grid).encode()
    with ThreadPoolExecutor(4) as pool:
        terrains = list(pool.map(lambda _: validate_terrain_bytes(content, source="up.json"), range(4)))
    assert all(t == terrains[0] for t in terrains) and terrains[0].name == large_grid["name"]
    assert editor.parse_upload(content, max_bytes=len(content)) == terrains[0].to_dict()


def test_store_writes_a_validated_terrain_without_validating_it_again(tmp_path, monkeypatch):
    terrain = resolve("stepping_stones")
    mine = Terrain.from_dict({**terrain.to_dict(), "name": "mine"})
    monkeypatch.setattr(Terrain, "__post_init__", lambda self: pytest.fail("validated again"))
    path = editor.TerrainStore(tmp_path).save(mine, "mine")
    monkeypatch.undo()
    assert Terrain.load(path) == mine


def test_the_benchmark_rows():
    rows = benchmark_validation(repeats=1)
    assert [r["terrain"] for r in rows] == ["validate 500x500 grid, 20k removed", "mesh 500x500 grid, 20k removed"]
    assert all(r["median_s"] > 0 for r in rows)
    start = time.perf_counter()
    validate_terrain_bytes(json.dumps(large_grid_dict()).encode())
    assert time.perf_counter() - start < 30  # it took 43 s: a sanity bound, not the 1 s target (see the benchmark)


def test_the_budget_is_named_in_the_schema():
    for name in ("MAX_REGIONS", "MAX_GRID_REGIONS", "MAX_GRID_CELLS", "MAX_POLYGON_VERTICES", "MAX_OUTLINE_VERTICES",
                 "MAX_EDGE_CONTACTS", "MAX_MESH_FACES", "MAX_FILE_BYTES", "TERRAIN_JSON_LIMITS"):
        assert getattr(schema, name)
