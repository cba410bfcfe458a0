"""The compiled walk on terrain with heights (``contactnet.planning.heights_walk``, ``heights_lookup``) against the
plain numpy and shapely answers it replaces, on many random states and several terrains with heights: every
landing's verdict against ``Terrain.is_safe`` and ``FootholdChecker.evaluate``, the cornered legs against
``FootholdChecker.stance_clear``, the compiled point lookups against shapely (also on the outlines), and the cache
guard of the compiled code. (The plans themselves against the plain walk down the ranking:
``tests/test_planner_fast.py``.)"""

from __future__ import annotations

import collections
import hashlib
from pathlib import Path

import numpy as np
import pytest
import shapely

from contactnet.motion.gait import TROT, WALK
from contactnet.planning import heights_lookup, heights_walk
from contactnet.planning.cornered import CORNERED_LOOKAHEAD_STEPS, CORNERED_MIN_PROGRESS_M
from contactnet.planning.footholds import FootholdChecker
from contactnet.planning.heights_tables import CompiledHeights
from contactnet.planning.planner import touchdown_times_s
from contactnet.planning.ranking import ActionCells, HeightsWalk
from contactnet.terrain import Terrain, random_heights, resolve


def _shapes() -> Terrain:
    """A floor with stars, circles, rotated rectangles and a polygon at several heights (slanted outlines), and two
    squares of one height touching at a corner (two parts with the same top there)."""
    regions = [{"shape": "rect", "center": [1.0, 0.0], "size": [2.4, 0.8]}]
    rng = np.random.default_rng(2)
    for k, x in enumerate(np.arange(0.15, 1.9, 0.17)):
        y, z = float(rng.uniform(-0.2, 0.2)), round(float(rng.uniform(-0.04, 0.06)), 3)
        shape = k % 4
        if shape == 0:
            regions.append({"shape": "star", "center": [float(x), y], "outer_radius": 0.07, "inner_radius": 0.035,
                            "points": 5, "yaw": float(rng.uniform(0, 1)), "z": z})
        elif shape == 1:
            regions.append({"shape": "circle", "center": [float(x), y], "radius": 0.045, "z": z})
        elif shape == 2:
            regions.append({"shape": "rect", "center": [float(x), y], "size": [0.09, 0.06],
                            "yaw": float(rng.uniform(0, 1.5)), "z": z})
        else:
            regions.append({"shape": "polygon", "z": z, "vertices": [[float(x) - 0.05, y - 0.04],
                                                                     [float(x) + 0.06, y - 0.02],
                                                                     [float(x) + 0.01, y + 0.06]]})
    regions += [{"shape": "rect", "center": [0.6, 0.33], "size": [0.05, 0.05], "z": 0.02},
                {"shape": "rect", "center": [0.65, 0.38], "size": [0.05, 0.05], "z": 0.02}]
    return Terrain.from_dict({"name": "shapes", "start": [0.1, 0.0], "goal_x": 2.0, "regions": regions})


TERRAINS = {"random_heights 0": lambda: random_heights(0, 0), "random_heights 100": lambda: random_heights(100, 1),
            "random_heights 12 cm": lambda: random_heights(40, 2, 0.12), "stairs": lambda: resolve("stairs"),
            "raised_stones": lambda: resolve("raised_stones"), "shapes": _shapes}


def _rotation(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s], [s, c]])


def test_the_kernels_are_recompiled_when_their_lookups_change():
    """numba caches a compiled function by its own file: the walk's kernels inline ``heights_lookup``'s code, so
    ``heights_walk.LOOKUP_SOURCE`` records that file's hash; a change there must be a change in heights_walk.py."""
    source = Path(heights_lookup.__file__).read_bytes()
    assert hashlib.sha256(source).hexdigest()[:16] == heights_walk.LOOKUP_SOURCE, (
        "heights_lookup.py changed: set heights_walk.LOOKUP_SOURCE to its new hash (so that numba recompiles the "
        "kernels that inline it)")


@pytest.mark.parametrize("name", list(TERRAINS))
def test_the_compiled_lookups_answer_as_shapely(robot, name):
    """``part_at`` and ``height_at`` (the rasters, and next to an outline the regions the cell touches, a point in a
    polygon decided by exact orientation signs) give shapely's answers: random points, the outlines' vertices, points
    a few ulps off them and points on their edges' lines. Undecided answers (which the walk asks of shapely) are
    rare."""
    terrain = TERRAINS[name]()
    tables = CompiledHeights(FootholdChecker(robot.description), 0.008).tables(terrain)
    parts = terrain.top_parts()
    rng = np.random.default_rng(7)
    b = terrain.bounds
    vertices = shapely.get_coordinates(shapely.get_rings(shapely.get_parts(parts.polygons)))
    start, end = vertices[:-1], vertices[1:]
    on_edges = start + rng.uniform(0, 1, (len(start), 1)) * (end - start)  # on (or within rounding of) a segment
    points = np.concatenate([
        np.column_stack([rng.uniform(b[0] - 0.05, b[2] + 0.05, 3000), rng.uniform(b[1] - 0.05, b[3] + 0.05, 3000)]),
        vertices, np.nextafter(vertices, np.inf), np.nextafter(vertices, -np.inf), on_edges])
    part_exact = parts.part_at_exact(points)
    height_exact = terrain.height_at(points)
    undecided = 0
    for (x, y), part, height in zip(points.tolist(), part_exact, height_exact, strict=True):
        found = heights_lookup.part_at(x, y, tables.rasters, tables.cover_codes, tables.part_ints, tables.part_coords,
                                       tables.part_tops)
        if found == heights_lookup.UNDECIDED:
            undecided += 1
        else:
            assert found == part, (x, y)
        z, decided = heights_lookup.height_at(x, y, tables.rasters, tables.height_codes, tables.code_z,
                                              tables.region_ints, tables.region_coords, tables.region_tops)
        if decided:
            assert z == height or (z != z and height != height), (x, y)
        else:
            undecided += 1
        assert parts.locator.index_xy(x, y) == part
    assert undecided <= 0.02 * len(points), undecided


def _random_state(robot, gait, terrain, rng):
    """A walking state over the terrain, as the planner's: feet around their nominal stance, a heading, a command."""
    description = robot.description
    b = terrain.bounds
    base = np.array([rng.uniform(b[0] + 0.25, b[2] - 0.25), rng.uniform(-0.08, 0.08)])
    yaw = float(rng.uniform(-0.35, 0.35))
    feet = base + description.foot_nominal_base[:, :2] @ _rotation(yaw).T + rng.uniform(-0.05, 0.05, (4, 2))
    return base, yaw, feet, rng.uniform(-0.12, 0.12, 2)


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_every_landing_is_decided_as_the_numpy_checks_decide(robot, gait, monkeypatch):
    """Each action walked on its own (a ranking of one): the compiled walk finds it exactly when its landing points
    (a small top's cells at its centre) are all safe (``Terrain.is_safe``) and pass every check of
    ``FootholdChecker.evaluate``, lands them on those very floats with the tops under them, and finds the same
    cornered legs as ``FootholdChecker.stance_clear``; on random states over six terrains with heights. Some
    questions go back to shapely (``ASK``)."""
    description, margin = robot.description, 0.5 * robot.description.foot_radius_m
    checker = FootholdChecker(description)
    compiled = CompiledHeights(checker, margin)
    actions = ActionCells.of(gait)
    hip_xy_base = np.array(description.hip_pos_base[:, :2], dtype=float)
    touchdown_s = float(touchdown_times_s(gait)[0])
    lookahead_s = CORNERED_LOOKAHEAD_STEPS * gait.step_duration_s
    asked = collections.Counter()
    answer = HeightsWalk._answer

    def counted(self, step, kind, index):
        asked[kind] += 1
        return answer(self, step, kind, index)

    monkeypatch.setattr(HeightsWalk, "_answer", counted)
    rng = np.random.default_rng(3)
    seen = collections.Counter()
    for name, make in TERRAINS.items():
        terrain = make()
        walk = HeightsWalk(actions, terrain, margin, compiled, hip_xy_base, touchdown_s, lookahead_s,
                           CORNERED_MIN_PROGRESS_M)
        for _ in range(10):
            base, yaw, feet, cmd = _random_state(robot, gait, terrain, rng)
            to_world = _rotation(yaw)
            hips_world = np.ascontiguousarray(description.foot_nominal_base[:, :2] @ to_world.T)
            offsets_world = np.ascontiguousarray(gait.cell_offsets_xy @ to_world.T)
            cmd_world = to_world @ cmd
            bases = [base.tolist()]
            tops = walk.start(hips_world, offsets_world, bases, yaw, bases, cmd_world.tolist(), feet.tolist(),
                              (float(to_world[0, 0]), float(to_world[1, 0])))
            assert tops == terrain.ground_z(feet).tolist()
            # The reference: every landing point, numpy's checks.
            cells = (base + hips_world)[:, None, :] + offsets_world[None]
            cells = checker.centred(terrain, cells.reshape(-1, 2))
            legs = np.repeat(np.arange(4), gait.cells_per_leg)
            hips = base + (hip_xy_base @ to_world.T + cmd_world * touchdown_s)
            checks = checker.evaluate(terrain, legs, cells, feet[legs], hips[legs], np.array(tops), yaw)
            usable = terrain.is_safe(cells, margin) & np.logical_and.reduce(list(checks.values()))
            ahead = base + hip_xy_base @ to_world.T + cmd_world * lookahead_s
            cornered = ~checker.stance_clear(terrain, feet, np.array(tops), ahead, yaw)
            costs = np.zeros(gait.n_actions, dtype=np.float32)
            for action in range(gait.n_actions):
                found = walk.first_usable(0, costs, (action, action + 1))
                flats = actions.flat[action]
                assert (found is not None) == bool(usable[flats].all()), (name, action)
                if found is not None:
                    rank, chosen, points, landing_tops = found
                    assert (rank, chosen) == (0, action)
                    assert points == cells[flats].tolist()
                    assert landing_tops == terrain.ground_z(cells[flats]).tolist()
                np.testing.assert_array_equal(np.zeros(4, dtype=bool) if walk.cornered is None else walk.cornered,
                                              cornered)
            seen["landings"] += len(cells)
            seen["usable"] += int(usable.sum())
            seen["cornered"] += int(cornered.any())
    assert seen["usable"] > 0.2 * seen["landings"] and seen["usable"] < 0.8 * seen["landings"], seen
    assert seen["cornered"] > 0 and sum(asked.values()) > 0, (seen, asked)


@pytest.mark.parametrize("costs", ["ties", "nan", "inf"])
def test_the_walk_orders_as_a_stable_sort(robot, costs):
    """The compiled walk's order (no sort: batches of the cheapest actions, a pass each) is
    ``np.argsort(kind="stable")``'s, NaN last and -0 equal to +0, with many ties and infinities: knowing each
    action's verdict (walked alone), the walk over the whole ranking finds the first usable action of the stable
    order, at its position, also deep in it (beyond a batch)."""
    gait = TROT
    description, margin = robot.description, 0.5 * robot.description.foot_radius_m
    checker = FootholdChecker(description)
    actions = ActionCells.of(gait)
    terrain = random_heights(60, 5)
    walk = HeightsWalk(actions, terrain, margin, CompiledHeights(checker, margin),
                       np.array(description.hip_pos_base[:, :2], dtype=float), float(touchdown_times_s(gait)[0]))
    rng = np.random.default_rng(11)
    deep = 0
    for _ in range(30):
        base, yaw, feet, cmd = _random_state(robot, gait, terrain, rng)
        to_world = _rotation(yaw)
        hips_world = np.ascontiguousarray(description.foot_nominal_base[:, :2] @ to_world.T)
        offsets_world = np.ascontiguousarray(gait.cell_offsets_xy @ to_world.T)
        bases = [base.tolist()]
        if costs == "ties":
            values = rng.choice(np.array([0.0, -0.0, 0.25, 0.5], dtype=np.float32), gait.n_actions)
        else:
            values = rng.normal(size=gait.n_actions).astype(np.float32)
            values[rng.integers(0, gait.n_actions, 40)] = np.nan if costs == "nan" else np.inf
            values[rng.integers(0, gait.n_actions, 10)] = -np.inf
        args = (hips_world, offsets_world, bases, yaw, bases, (to_world @ cmd).tolist(), feet.tolist(),
                (float(to_world[0, 0]), float(to_world[1, 0])))
        walk.start(*args)
        alone = [walk.first_usable(0, values, (a, a + 1)) is not None for a in range(gait.n_actions)]
        if walk.cornered is not None:
            continue  # (the cornered legs' actions go first: the other tests)
        walk.start(*args)
        found = walk.first_usable(0, values, (0, gait.n_actions))
        order = np.argsort(values, kind="stable")
        expected = next(((rank, int(a)) for rank, a in enumerate(order) if alone[a]), None)
        assert (found if found is None else found[:2]) == expected
        deep += expected is not None and expected[0] >= 8
    assert deep > 0
