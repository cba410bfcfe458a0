"""The planner's fast paths (issue 15, item 4; issue 30, item 3) against slow, obvious references, on many random
states and terrains, flat and with heights: the ContactNet and fixed-gait plans (``OneLevelWalk``,
``HeightsWalk``), the candidate view, the height checks' batch (``FootholdChecker.usable``) against their
one-by-one form (``evaluate``), and the rasters' scalar and cached lookups against the exact geometry."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely
import shapely.affinity
from helpers import FixedScores, save_random_models, slid_back

from contactnet.bench.planner import planning_contexts
from contactnet.motion.gait import TROT, WALK
from contactnet.motion.ground import support_height
from contactnet.planning import safe_walk
from contactnet.planning.capture import capture_offset
from contactnet.planning.cornered import (
    CORNERED_GRID_SHIFT_CELLS,
    CORNERED_LOOKAHEAD_STEPS,
    CORNERED_MIN_PROGRESS_M,
)
from contactnet.planning.footholds import FootholdChecker
from contactnet.planning.network_input import network_input_one
from contactnet.planning.planner import (
    ContactNetPlanner,
    FixedGaitPlanner,
    PlannedStep,
    PlanningContext,
    touchdown_times_s,
)
from contactnet.planning.ranking import ActionCells, OneLevelWalk
from contactnet.planning.roll import roll_ahead_xy
from contactnet.planning.stand import is_idle
from contactnet.registry import make_planner
from contactnet.terrain import Terrain, random_field, random_heights, resolve
from contactnet.terrain.locate import PointLocator


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    folder = tmp_path_factory.mktemp("models")
    save_random_models(folder)
    return {"walk": folder / "walk.pt", "trot": folder / "trot.pt"}


def _rotation(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s], [s, c]])


def reference_plan(planner: ContactNetPlanner, ctx: PlanningContext, group: int | None = None,
                   seen: dict[str, int] | None = None) -> list[tuple]:
    """``_reference_steps``, then on terrain of one level the first step's landing points without the room for the
    roll slid back (``helpers.slid_back``), as the planner does after its plan."""
    steps = _reference_steps(planner, ctx, group, seen)
    ahead = roll_ahead_xy(planner.robot.foot_radius_m, ctx.vel_cmd_world(), planner.roll)
    if (steps[0][0] is not None and ahead is not None and planner.roll.slide_back_radii > 0.0
            and not planner.footholds.applies(ctx.terrain)):
        points = slid_back(steps[0][3], ctx.terrain, planner, ahead)
        if seen is not None and np.any(points != steps[0][3]):
            seen["slid"] = seen.get("slid", 0) + 1
        steps[0] = (*steps[0][:3], points)
    return steps


def _reference_steps(planner: ContactNetPlanner, ctx: PlanningContext, group: int | None = None,
                     seen: dict[str, int] | None = None, first_grid_shift_xy: np.ndarray | None = None) -> list[tuple]:
    """The plan as the planner's docs define it, the slow and obvious way: numpy state, the network's stable
    ranking of minus its scores, every step's whole candidate grid (small tops' cells centred on terrain with
    heights), and one action at a time down the ranking until its landing points are all safe
    (``Terrain.is_safe``) and, with heights, pass every check of ``FootholdChecker.evaluate``; on terrain with
    heights the first step's ranking puts the actions that move a cornered leg first, and when the first step moves
    no cornered leg forward (and no push moved the grid) the plan made on a first grid one cell further on along
    the heading is taken if its first step does (``first_grid_shift_xy``: that shift). ``group``: the fixed
    gait's first group. Returns (legs, action, rank, footholds) per step, (None, ...) for a step in place (and
    stops there). ``seen["roomed"]`` counts the steps the room for the roll moved to another landing,
    ``seen["shifted"]`` the plans taken on the shifted grid."""
    gait, terrain, checker = planner.gait, ctx.terrain, planner.footholds
    heights = checker.applies(terrain)
    to_world = _rotation(ctx.yaw_rad)
    hips_world = planner.hip_ref_xy_base @ to_world.T
    offsets_world = gait.cell_offsets_xy @ to_world.T
    feet = np.array(ctx.foot_pos_world, dtype=float)[:, :2]
    com, vel = np.array(ctx.com_pos_world, dtype=float), np.array(ctx.com_vel_world, dtype=float)
    base = np.array(ctx.base_xy_world, dtype=float)
    cmd_world = to_world @ ctx.vel_cmd_xy
    shift = cmd_world * gait.step_duration_s
    tops = terrain.ground_z(feet)
    hips_touchdown = planner.hip_xy_base @ to_world.T + cmd_world * touchdown_times_s(gait)[0]
    action_legs, action_cells = gait.action_cells
    feet_now, clear = feet.copy(), np.ones(4, dtype=bool)
    steps = []
    for j in range(gait.steps_per_plan):
        scores = planner.model.scores(network_input_one(feet, com, vel, np.asarray(ctx.vel_cmd_xy, dtype=float),
                                                        ctx.yaw_rad, support_height(terrain, feet)))
        order = list(np.argsort(-np.asarray(scores), kind="stable"))
        if group is not None:
            own = gait.cyclic_order[(group + j) % len(gait.cyclic_order)]
            order = [a for a in order if a // gait.actions_per_group == own]
        grid_base = base + first_grid_shift_xy if j == 0 and first_grid_shift_xy is not None else base
        cells = (grid_base + hips_world)[:, None, :] + offsets_world[None]
        if heights:
            cells = checker.centred(terrain, cells.reshape(-1, 2)).reshape(cells.shape)
            if j == 0:  # a cornered leg: its shin would reach the terrain a few steps of motion ahead
                ahead = base + planner.hip_xy_base @ to_world.T + cmd_world * (
                    CORNERED_LOOKAHEAD_STEPS * gait.step_duration_s)
                clear = checker.stance_clear(terrain, feet, tops, ahead, ctx.yaw_rad)
                forward = to_world[:, 0]
                urgent = [any(not clear[leg] and (cells[leg, cell] - feet[leg]) @ forward >= CORNERED_MIN_PROGRESS_M
                              for leg, cell in zip(action_legs[a], action_cells[a], strict=True)) for a in order]
                order = [a for a, u in zip(order, urgent, strict=True) if u] + [
                    a for a, u in zip(order, urgent, strict=True) if not u]
        chosen, forced = None, False
        if j == 0 and not heights and planner.reach is not None:  # legs left behind go first, if one can step
            look = cmd_world * planner.reach.lookahead_steps * gait.step_duration_s
            behind = np.hypot(*(feet - (base + hips_world + look)).T) > planner.robot.kin_threshold_m
            for rank, action in enumerate(order):
                legs = action_legs[action]
                points = cells[legs, action_cells[action]]
                if behind[legs].any() and terrain.is_safe(points, planner.margin_m).all():
                    chosen = (tuple(int(leg) for leg in legs), int(action), rank, points)
                    if seen is not None:
                        seen["behind"] = seen.get("behind", 0) + 1
                    forced = True
                    break
        for rank, action in enumerate(order):
            if chosen is not None:
                break
            legs = action_legs[action]
            points = cells[legs, action_cells[action]]
            if not terrain.is_safe(points, planner.margin_m).all():
                continue
            if heights:
                checks = checker.evaluate(terrain, legs, points, feet[legs], (base + hips_touchdown)[legs], tops,
                                          ctx.yaw_rad)
                if not all(value.all() for value in checks.values()):
                    continue
            chosen = (tuple(int(leg) for leg in legs), int(action), rank, points)
            break
        # the same legs' first landing with room for the roll ahead, if there is one (with heights: usable too;
        # not on a first step that moves a cornered leg first)
        ahead = roll_ahead_xy(planner.robot.foot_radius_m, cmd_world, planner.roll)
        if heights and (planner.roll is None or not planner.roll.heights or (j == 0 and not clear.all())):
            ahead = None
        if chosen is not None and ahead is not None:
            swing_group = chosen[1] // gait.actions_per_group  # (``group`` is the fixed gait's first group)
            for rank, action in enumerate(order):
                legs = action_legs[action]
                points = cells[legs, action_cells[action]]
                if not (action // gait.actions_per_group == swing_group and terrain.is_safe(points, planner.margin_m).all()
                        and terrain.is_safe(points + np.array(ahead), planner.margin_m).all()):
                    continue
                if heights and not all(value.all() for value in checker.evaluate(
                        terrain, legs, points, feet[legs], (base + hips_touchdown)[legs], tops, ctx.yaw_rad).values()):
                    continue
                if seen is not None and int(action) != chosen[1]:
                    seen["roomed"] = seen.get("roomed", 0) + 1
                chosen = (chosen[0], int(action), rank, points)
                break
        # with a moving command, a useless swing gives way to the first safe step that moves its feet (and then the
        # room for the roll among those), unless a leg left behind chose it (IdleConfig.step_when_moving)
        idle = planner.idle
        if (j == 0 and not heights and chosen is not None and idle is not None and idle.step_when_moving
                and not is_idle(ctx.com_vel_world, ctx.vel_cmd_xy, idle) and not forced):
            def moves(action: int, cells: np.ndarray = cells, min_swing_m: float = idle.min_swing_m) -> bool:
                legs = action_legs[action]
                return bool((np.hypot(*(cells[legs, action_cells[action]] - feet[legs]).T) >= min_swing_m).any())

            def safe(action: int, room: tuple[float, float] = (0.0, 0.0), cells: np.ndarray = cells) -> bool:
                points = cells[action_legs[action], action_cells[action]]
                return bool(terrain.is_safe(points, planner.margin_m).all()
                            and terrain.is_safe(points + np.array(room), planner.margin_m).all())

            if not moves(chosen[1]):
                first = next((int(a) for a in order if moves(a) and safe(a)), None)
                if first is not None:
                    moving_group = first // gait.actions_per_group
                    if ahead is not None:
                        first = next((int(a) for a in order if a // gait.actions_per_group == moving_group and moves(a)
                                      and safe(a, ahead)), first)
                    legs = action_legs[first]
                    chosen = (tuple(int(leg) for leg in legs), first, order.index(first), cells[legs, action_cells[first]])
                    if seen is not None:
                        seen["moved"] = seen.get("moved", 0) + 1
        if chosen is None:
            steps.append((None, None, None, None))
            break
        steps.append(chosen)
        feet[list(chosen[0])] = chosen[3]
        tops = terrain.ground_z(feet)
        com[:2] += shift
        com[2] = support_height(terrain, feet) + ctx.com_height_ref_m
        base += shift
        vel = np.array([cmd_world[0], cmd_world[1], 0.0])
    if first_grid_shift_xy is not None or clear.all() or capture_offset(
            ctx.com_vel_world, ctx.vel_cmd_xy, ctx.yaw_rad, planner.capture, ctx.external_force_xy_world,
            planner._lean_m_per_n) is not None:
        return steps

    def moves_cornered(step: tuple) -> bool:
        return step[0] is not None and any(
            not clear[leg] and (point - feet_now[leg]) @ to_world[:, 0] >= CORNERED_MIN_PROGRESS_M
            for leg, point in zip(step[0], step[3], strict=True))

    own = gait.swing_groups if group is None else [
        gait.swing_groups[gait.cyclic_order[group % len(gait.cyclic_order)]]]
    if moves_cornered(steps[0]) or not any(not clear[leg] for legs in own for leg in legs):
        return steps  # (the fixed gait's turn may be another leg's: no step of a cornered leg to find)
    shift_m = CORNERED_GRID_SHIFT_CELLS * gait.grid_spacing_m
    shifted = _reference_steps(planner, ctx, group, None, to_world[:, 0] * shift_m)
    if not moves_cornered(shifted[0]):
        return steps
    if seen is not None:
        seen["shifted"] = seen.get("shifted", 0) + 1
    return shifted


def _compare(planner, contexts, fixed: bool = False) -> dict[str, int]:
    """Plan every context with the planner and the reference; the same steps. Counts what was seen."""
    seen = {"plans": 0, "deep": 0, "in_place": 0, "roomed": 0, "behind": 0}
    for k, ctx in enumerate(contexts):
        group = planner._next_group if fixed else None
        fast = planner.plan(ctx)
        slow = reference_plan(planner, ctx, group, seen)
        seen["plans"] += 1
        for step, (legs, action, rank, points) in zip(fast, slow, strict=False):
            if action is None:
                assert step.action_index is None, (k, step)
                seen["in_place"] += 1
                break
            assert (step.legs, step.action_index, step.rank, step.discarded) == (legs, action, rank, rank), (k, step)
            np.testing.assert_array_equal(step.footholds_xy_world, points)
            seen["deep"] += rank >= 8
    return seen


FLAT = [("random 0", lambda: random_field(0, 0)), ("random 100", lambda: random_field(100, 1)),
        ("random 220", lambda: random_field(220, 2)), ("stepping_stones", lambda: resolve("stepping_stones")),
        ("narrow_stones", lambda: resolve("narrow_stones"))]


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
@pytest.mark.parametrize("name", ["contactnet", "fixed"])
def test_a_leg_left_behind_goes_first(robot, models, gait, name):
    """Contexts with one foot 8-22 cm behind its place along the heading: ContactNet's first step is the first safe
    action in the ranking moving a leg whose foot will be further than ``kin_threshold_m`` from its hip reference
    two steps of motion on, when there is one (``contactnet.planning.reach``; the reference above); the fixed gait
    keeps its order."""
    planner = make_planner(name, gait, robot, model=models[gait.name])
    rng = np.random.default_rng(7)
    seen = {"plans": 0, "deep": 0, "in_place": 0, "roomed": 0, "behind": 0}
    moved = 0
    for _label, terrain in FLAT[:3]:
        contexts = planning_contexts(gait, terrain(), robot.description, 20, seed=3)
        for ctx in contexts:
            leg = int(rng.integers(4))
            ctx.foot_pos_world[leg, :2] -= rng.uniform(0.08, 0.22) * _rotation(ctx.yaw_rad)[:, 0]
        for key, value in _compare(planner, contexts, fixed=name == "fixed").items():
            seen[key] = seen.get(key, 0) + value
        if name == "contactnet":  # against the plain plan
            moved += sum(_plan_first(None, planner, ctx) != planner.plan(ctx)[0].action_index for ctx in contexts)
    assert seen["plans"] == 60
    if name == "contactnet":
        assert seen["behind"] > 10 and moved > 5, (seen, moved)  # it changed plans
    else:
        assert seen["behind"] == 0


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_a_useless_swing_gives_way_to_a_step_that_moves(robot, gait):
    """With ``IdleConfig.step_when_moving`` and a command that moves: where the ranking's first safe step would put
    its feet down within ``min_swing_m`` of where they are, the first step is the first safe one that moves them
    (with the room for the roll among those), as the reference says. A model of fixed scores, and every foot placed
    on the landing cell of the best-ranked action that moves its leg, so that the first safe step is often useless;
    without the rule those plans keep the useless swing."""
    action_legs, action_cells = gait.action_cells
    seen = {"plans": 0, "deep": 0, "in_place": 0, "roomed": 0, "behind": 0, "moved": 0}
    changed = 0
    for seed, (_label, terrain) in enumerate(FLAT[:3]):
        model = FixedScores(gait, seed)
        planner = ContactNetPlanner(gait, robot.description, model, reach=None)  # (a leg left behind goes first)
        with_rule = dataclasses.replace(planner.idle, step_when_moving=True)
        contexts = planning_contexts(gait, terrain(), robot.description, 40, seed=6)
        order = np.argsort(-model.scores(None), kind="stable")
        for ctx in contexts:
            ctx.vel_cmd_xy[:] = [0.05, 0.0]
            to_world = _rotation(ctx.yaw_rad)
            ctx.com_vel_world[:2] = to_world @ ctx.vel_cmd_xy  # on the command: no capture step
            cells = (np.asarray(ctx.base_xy_world) + planner.hip_ref_xy_base @ to_world.T)[:, None, :] + (
                gait.cell_offsets_xy @ to_world.T)[None]
            placed = set()
            for action in order:  # each foot on its leg's best-ranked landing cell
                for leg, cell in zip(action_legs[action], action_cells[action], strict=True):
                    if leg not in placed:
                        ctx.foot_pos_world[leg, :2] = cells[leg, cell]
                        placed.add(int(leg))
        before = [planner.plan(ctx)[0].action_index for ctx in contexts]
        planner.idle = with_rule
        for key, value in _compare(planner, contexts).items():
            seen[key] = seen.get(key, 0) + value
        changed += sum(b != planner.plan(ctx)[0].action_index for b, ctx in zip(before, contexts, strict=True))
    assert seen["plans"] == 120
    assert seen["moved"] > 5 and changed == seen["moved"], (seen, changed)


def _plan_first(reach, planner, ctx):  # noqa: ANN001, ANN202
    """The first step's action of ``planner`` with ``reach`` (restored after)."""
    planner.reach, kept = reach, planner.reach
    try:
        return planner.plan(ctx)[0].action_index
    finally:
        planner.reach = kept


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
@pytest.mark.parametrize("name", ["contactnet", "fixed"])
def test_one_level_plans_match_the_reference(robot, models, gait, name):
    planner = make_planner(name, gait, robot, model=models[gait.name])
    seen = {"plans": 0, "deep": 0, "in_place": 0, "roomed": 0, "behind": 0}
    for _label, terrain in FLAT:
        for seed in (0, 1):
            contexts = planning_contexts(gait, terrain(), robot.description, 15, seed=seed)
            for key, value in _compare(planner, contexts, fixed=name == "fixed").items():
                seen[key] = seen.get(key, 0) + value
    assert seen["plans"] == 150 and seen["deep"] > 0, seen  # some choices lie deep in the ranking
    assert (seen["roomed"] > 0) == (name == "contactnet"), seen  # the room for the roll moved some landings
    assert (seen.get("slid", 0) > 0) == (name == "contactnet"), seen  # and slid some back (the fixed gait: no room)


#: Nominal foot XY in the base frame of a Solo12-sized robot (the walk only needs four points).
_HIPS_XY_BASE = np.array([[0.19, 0.15], [0.19, -0.15], [-0.19, 0.15], [-0.19, -0.15]])


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_the_compiled_walk_is_a_walk_down_a_stable_sort(gait):
    """``OneLevelWalk.first_safe`` (the compiled walk of ``contactnet.planning.safe_walk``, cells near an outline
    decided by the outline's segments) against the obvious reference: ``np.argsort(kind="stable")`` of the costs, then
    every action's landing points asked of ``Terrain.is_safe`` in that order. Costs with many ties, NaN and
    infinities, whole rankings and one group's, on random grids over holed fields; some landing points must lie in
    raster cells near an outline (decided there by ``near_outline``, not by the raster)."""
    actions, rng, margin = ActionCells.of(gait), np.random.default_rng(5), 0.01
    near = 0
    flat = actions.flat_array
    found_deep = 0
    for terrain in (random_field(100, 1), random_field(220, 2)):
        for k in range(150):
            kind = k % 3
            if kind == 0:
                costs = rng.normal(size=gait.n_actions).astype(np.float32)
            else:
                values = [-np.inf, -1.0, 0.0, 0.5, np.inf, np.nan] if kind == 1 else [0.0, 0.25, 0.5]
                costs = rng.choice(np.array(values, dtype=np.float32), gait.n_actions)
            group = int(rng.integers(len(gait.swing_groups)))
            span = (0, gait.n_actions) if k % 2 else (group * gait.actions_per_group,
                                                      (group + 1) * gait.actions_per_group)
            yaw = rng.uniform(-0.3, 0.3)
            hips_world = np.ascontiguousarray(_HIPS_XY_BASE @ _rotation(yaw).T)
            offsets_world = np.ascontiguousarray(gait.cell_offsets_xy @ _rotation(yaw).T)
            base = [rng.uniform(0.2, 1.8), rng.uniform(-0.1, 0.1)]
            walk = OneLevelWalk(actions, terrain, margin, hips_world, offsets_world, [base])
            found = walk.first_safe(0, costs, span)
            order = span[0] + np.argsort(costs[span[0]:span[1]], kind="stable")
            cells = ((np.array(base) + hips_world)[:, None, :] + offsets_world[None]).reshape(-1, 2)
            safe = terrain.is_safe(cells, margin)
            expected = next(((rank, int(a), cells[flat[a]].tolist()) for rank, a in enumerate(order)
                             if safe[flat[a]].all()), None)
            assert found == expected, (k, found, expected)
            found_deep += found is not None and found[0] >= 8
            near += int(np.count_nonzero(_raster_codes(terrain.safe_locator(margin), cells) == 2))
    assert found_deep > 10 and near > 100, (found_deep, near)


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_the_compiled_walk_with_room_is_the_walk_then_its_group_s_walk(gait):
    """``OneLevelWalk.first_safe_with_room`` (one compiled call) against the obvious reference: the first safe action
    of the stable sort (``Terrain.is_safe``); if a landing point of it lacks the room ahead (that point moved by
    ``ahead`` is not safe), the first action of its swing group, in the same span and order, whose landing points
    and the points ahead of them are all safe, with its rank in the span; else the first safe action. Random
    grids over holed fields, random rooms; both outcomes must occur often."""
    actions, rng, margin = ActionCells.of(gait), np.random.default_rng(8), 0.008
    flat, per_group = actions.flat_array, gait.actions_per_group
    moved = kept = 0
    for terrain in (random_field(100, 1), random_field(200, 3)):
        for k in range(150):
            costs = rng.normal(size=gait.n_actions).astype(np.float32)
            if k % 3 == 0:
                costs[rng.integers(gait.n_actions, size=20)] = np.nan
            group = int(rng.integers(len(gait.swing_groups)))
            span = (0, gait.n_actions) if k % 2 else (group * per_group, (group + 1) * per_group)
            yaw, heading = rng.uniform(-0.3, 0.3), rng.uniform(-np.pi, np.pi)
            ahead = (0.02 * np.cos(heading), 0.02 * np.sin(heading))
            hips_world = np.ascontiguousarray(_HIPS_XY_BASE @ _rotation(yaw).T)
            offsets_world = np.ascontiguousarray(gait.cell_offsets_xy @ _rotation(yaw).T)
            base = [rng.uniform(0.2, 1.8), rng.uniform(-0.1, 0.1)]
            walk = OneLevelWalk(actions, terrain, margin, hips_world, offsets_world, [base])
            found = walk.first_safe_with_room(0, costs, span, ahead, per_group)
            order = span[0] + np.argsort(costs[span[0]:span[1]], kind="stable")
            cells = ((np.array(base) + hips_world)[:, None, :] + offsets_world[None]).reshape(-1, 2)
            safe = terrain.is_safe(cells, margin)
            roomy = safe & terrain.is_safe(cells + np.array(ahead), margin)
            first = next(((rank, int(a)) for rank, a in enumerate(order) if safe[flat[a]].all()), None)
            expected = first
            if first is not None and not roomy[flat[first[1]]].all():
                in_group = [(rank, int(a)) for rank, a in enumerate(order) if a // per_group == first[1] // per_group]
                expected = next(((rank, a) for rank, a in in_group if roomy[flat[a]].all()), first)
            expected = None if expected is None else (*expected, cells[flat[expected[1]]].tolist())
            assert found == expected, (k, found, expected)
            moved += found is not None and found[1] != first[1]
            kept += found is not None and found[1] == first[1] and not roomy[flat[first[1]]].all()
    assert moved > 10 and kept > 3, (moved, kept)


def _raster_codes(locator, points_xy):  # noqa: ANN001, ANN202
    """The `PointLocator` raster's code (0 outside, 1 inside, 2 near an outline) of each point."""
    inv_cell, col0, row0, clamp_hi, side = locator.raster
    col = np.clip(points_xy[:, 0] * inv_cell - col0, 0.0, clamp_hi).astype(int)
    row = np.clip(points_xy[:, 1] * inv_cell - row0, 0.0, clamp_hi).astype(int)
    return locator.codes[col + row * int(side)]


@pytest.mark.parametrize("margin", [0.0, 0.008])
def test_the_compiled_outline_test_is_shapely_s_and_asks_on_the_outline(margin, monkeypatch):
    """``safe_walk._lookup`` (the raster, and the outline's segments in a raster cell near it) against
    ``Terrain.is_safe`` (shapely) on random points, on the outline's vertices and on points along its segments
    (where float rounding puts them on either side): the same answer, or -1 (ask shapely) within 1 nm of the
    outline. Then the walk itself with every landing point on a vertex: it asks shapely, and still takes the
    reference's action."""
    terrain, rng = random_field(120, 4), np.random.default_rng(11)
    locator = terrain.safe_locator(margin)
    outline = locator.outline
    vertices = outline.segments[:, :2]
    along = outline.segments[:, :2] + rng.uniform(0, 1, (len(vertices), 1)) * (outline.segments[:, 2:]
                                                                                 - outline.segments[:, :2])
    points = np.concatenate([rng.uniform((-0.1, -0.35), (1.9, 0.35), (20000, 2)), vertices, along,
                             along + rng.normal(0.0, 2e-9, along.shape)])
    got = np.array([safe_walk._lookup(x, y, locator.raster, locator.codes, outline.entries, outline.row_first)
                    for x, y in points])
    distance = shapely.distance(locator.geometry.boundary, shapely.points(points))
    asked = got < 0
    assert not asked[distance > 1e-9].any()
    assert asked[len(points) - 3 * len(vertices):len(points) - 2 * len(vertices)].all()  # every vertex
    safe = terrain.is_safe(points, margin)
    assert np.array_equal(got[~asked] == safe_walk.SAFE, safe[~asked])
    assert (~asked & (distance < 1e-6)).sum() > 100  # many decided by the segments within a micrometre

    statuses = []
    compiled = safe_walk.first_safe

    def counted(*args):
        statuses.append(compiled(*args)[0])
        return compiled(*args)

    monkeypatch.setattr(safe_walk, "first_safe", counted)
    actions, gait = ActionCells.of(WALK), WALK
    for vertex in vertices[::7]:
        walk = OneLevelWalk(actions, terrain, margin, np.zeros((4, 2)), np.zeros_like(gait.cell_offsets_xy),
                            [vertex.tolist()])
        costs = rng.normal(size=gait.n_actions).astype(np.float32)
        found = walk.first_safe(0, costs, (0, gait.n_actions))
        on_vertex = bool(terrain.is_safe(vertex[None], margin)[0])  # every landing point is the vertex
        assert (found is not None) == on_vertex and (found is None or found[0] == 0), (vertex, found)
    assert statuses.count(safe_walk.ASK) == len(vertices[::7])

    # with room for the roll: every landing point that far before a vertex, so the point ahead asks shapely
    monkeypatch.undo()  # the compiled first_safe again (first_safe_with_room calls it)
    asked_room, with_room = [], safe_walk.first_safe_with_room

    def counted_room(*args):
        status, _, index = with_room(*args)
        asked_room.append(status == safe_walk.ASK and index >= len(actions.leg_cell))
        return with_room(*args)

    monkeypatch.setattr(safe_walk, "first_safe_with_room", counted_room)
    ahead, landing_safe, walks_asked = (0.004, -0.003), 0, 0
    for vertex in vertices[::7]:
        base = [vertex[0] - ahead[0], vertex[1] - ahead[1]]
        landing_safe += bool(terrain.is_safe(np.array([base]), margin)[0])  # else nothing to ask the room of
        walk = OneLevelWalk(actions, terrain, margin, np.zeros((4, 2)), np.zeros_like(gait.cell_offsets_xy), [base])
        costs = rng.normal(size=gait.n_actions).astype(np.float32)
        asked_before = sum(asked_room)
        found = walk.first_safe_with_room(0, costs, (0, gait.n_actions), ahead, gait.actions_per_group)
        assert found == walk.first_safe(0, costs, (0, gait.n_actions))  # every action lands on the same point
        walks_asked += sum(asked_room) > asked_before
    assert walks_asked == landing_safe > 5, (walks_asked, landing_safe)


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_one_level_above_the_surface_and_in_place(robot, models, gait):
    """A terrain whose every top is 5 cm above its surface_z (the feet's support is measured from the tops, and
    over a hole from surface_z), and a terrain where no candidate is safe (steps in place)."""
    raised = random_field(150, 3).to_dict()
    for region in raised["regions"]:
        region["z"] = 0.05
    terrain = Terrain.from_dict(raised)
    assert len(terrain.levels) == 1 and terrain.levels[0][0] != terrain.surface_z
    planner = make_planner("contactnet", gait, robot, model=models[gait.name])
    assert _compare(planner, planning_contexts(gait, terrain, robot.description, 20, seed=4))["plans"] == 20
    islands = Terrain.from_dict({"name": "islands", "start": [0.0, 0.0], "goal_x": 3.0, "regions": [
        {"shape": "circle", "center": [float(x), 0.0], "radius": 0.005} for x in np.arange(0.0, 2.0, 0.4)]})
    seen = _compare(planner, planning_contexts(gait, islands, robot.description, 5, seed=0))
    assert seen["in_place"] == 5


class _Tied:
    """A stand-in model: scores with many ties (and NaN or infinities when asked), so the ranking's tie rule
    matters."""

    def __init__(self, gait, odd: str = "") -> None:
        self.gait, self.n_actions, self.path = gait.name, gait.n_actions, "<tied>"
        self._scores = np.round(np.random.default_rng(3).normal(size=gait.n_actions), 0)
        if odd == "nan":
            self._scores[::7] = np.nan
        elif odd == "inf":  # a few best (+inf) and many worst (-inf): the walk without a sort meets them
            self._scores[::3] = -np.inf
            self._scores[1::11] = np.inf

    def scores(self, u):
        return self._scores


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
@pytest.mark.parametrize("odd", ["", "nan", "inf"], ids=["ties", "nan", "inf"])
def test_ties_and_nan_scores_rank_as_a_stable_sort(robot, gait, odd):
    planner = ContactNetPlanner(gait, robot.description, _Tied(gait, odd))
    for terrain in (random_field(150, 5), random_heights(60, 5)):
        assert _compare(planner, planning_contexts(gait, terrain, robot.description, 15, seed=2))["plans"] == 15


HEIGHTS = [("random_heights 0", lambda: random_heights(0, 0)), ("random_heights 100", lambda: random_heights(100, 1)),
           ("random_heights 12 cm", lambda: random_heights(40, 2, 0.12)), ("stairs", lambda: resolve("stairs")),
           ("raised_stones", lambda: resolve("raised_stones"))]


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
@pytest.mark.parametrize(("name", "room"), [("contactnet", False), ("contactnet", True), ("fixed", False)],
                         ids=["contactnet", "contactnet-room", "fixed"])
def test_plans_with_heights_match_the_reference(robot, models, gait, name, room):
    """The compiled walk with the height checks (``HeightsWalk``) plans what the plain walk down the ranking plans:
    the same actions, ranks and landing points at all three steps, on 120 random states over five terrains with
    heights (the random field with 0 and 100 squares removed and with tops within +-12 cm, the stairs, the raised
    stones), first steps with a cornered leg among them, some planned again on the first grid a cell further on.
    ``room``: with the room for the roll on heights too (``RollConfig(heights=True)``, off by default)."""
    planner = make_planner(name, gait, robot, model=models[gait.name])
    assert isinstance(planner, FixedGaitPlanner) == (name == "fixed")
    if room:
        planner.roll = dataclasses.replace(planner.roll, heights=True)
    seen = {"plans": 0, "deep": 0, "in_place": 0, "roomed": 0}
    for _, terrain in HEIGHTS:
        for seed in (1, 2):
            contexts = planning_contexts(gait, terrain(), robot.description, 12, seed=seed)
            for key, value in _compare(planner, contexts, fixed=name == "fixed").items():
                seen[key] = seen.get(key, 0) + value
    assert seen["plans"] == 120 and seen["deep"] > 0, seen
    assert (seen["roomed"] > 0) == room, seen  # the room for the roll moved some landings
    assert seen.get("shifted", 0) > 0, seen  # some plans taken on the grid a cell further on (a cornered leg)


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_the_candidate_view_marks_the_cells_the_reference_would_take(robot, models, gait):
    """The view (built lazily) shows every used cell's safety as the slow checks see it, flat and with heights."""
    planner = make_planner("contactnet", gait, robot, model=models[gait.name])
    checker = planner.footholds
    for terrain in (random_field(100, 1), random_heights(80, 0), resolve("stairs")):
        for ctx in planning_contexts(gait, terrain, robot.description, 4, seed=6):
            step = planner.plan(ctx)[0]
            view = planner.last_candidates
            safe = terrain.is_safe(view.xy_world, planner.margin_m)
            if checker.applies(terrain):
                hips = ctx.base_xy_world + robot.description.hip_pos_base[:, :2] @ _rotation(ctx.yaw_rad).T + (
                    _rotation(ctx.yaw_rad) @ ctx.vel_cmd_xy * touchdown_times_s(gait)[0])
                feet, tops = ctx.foot_pos_world[:, :2], terrain.ground_z(ctx.foot_pos_world[:, :2])
                checks = checker.evaluate(terrain, view.leg, view.xy_world, feet[view.leg], hips[view.leg], tops,
                                          ctx.yaw_rad)
                safe &= np.logical_and.reduce(list(checks.values()))
            np.testing.assert_array_equal(view.safe, safe)
            if step.action_index is not None:
                assert view.safe[list(view.chosen)].all() and view.rank[list(view.chosen)].min() <= step.rank


@pytest.mark.parametrize("knees", [True, False], ids=["knees", "no-knees"])
def test_the_batched_height_checks_are_the_checks_one_by_one(robot, knees):
    """``usable`` (the planner's batch, with the parts and centres it knows) == every check of ``evaluate``, on
    random landings around random stances (Solo12's knees point both ways; without knee positions the shin is
    checked on both sides of the foot)."""
    description = robot.description if knees else dataclasses.replace(robot.description, knee_pos_base=None)
    rng = np.random.default_rng(11)
    checked = usable_seen = 0
    for terrain in (random_heights(0, 0), random_heights(120, 5), random_heights(60, 7, 0.12), resolve("stairs"),
                    resolve("raised_stones")):  # (tops within +-12 cm: steps past what the swing clears)
        parts = terrain.top_parts()
        checker = FootholdChecker(description)
        b = terrain.bounds
        for _ in range(40):
            yaw = rng.uniform(-0.4, 0.4)
            base = np.array([rng.uniform(b[0] + 0.2, b[2] - 0.2), rng.uniform(-0.1, 0.1)])
            feet = base + robot.description.foot_nominal_base[:, :2] @ _rotation(yaw).T + rng.uniform(-0.05, 0.05, (4, 2))
            hips = base + robot.description.hip_pos_base[:, :2] @ _rotation(yaw).T + rng.uniform(-0.02, 0.02, 2)
            tops = terrain.ground_z(feet)
            legs = rng.integers(0, 4, 30)
            raw = feet[legs] + rng.uniform(-0.15, 0.15, (30, 2))
            landing = checker.centred(terrain, raw)
            at_centre = np.any(landing != raw, axis=1)
            part = parts.part_at(raw)
            every = checker.evaluate(terrain, legs, landing, feet[legs], hips[legs], tops, yaw)
            expected = np.logical_and.reduce(list(every.values()))
            for fast in (checker.usable(terrain, legs, landing, feet[legs], hips[legs], tops, yaw),
                         checker.usable(terrain, legs, landing, feet[legs], hips[legs], tops, yaw, part=part,
                                        at_centre=at_centre)):
                np.testing.assert_array_equal(fast, expected)
            checked += len(legs)
            usable_seen += int(expected.sum())
    assert usable_seen > 0.1 * checked and usable_seen < 0.9 * checked


def test_the_outline_test_holds_for_slanted_long_and_many_segments():
    """``crossings.near_outline`` looks only at a row's segments that may reach the stretch of the ray up to the next
    cell not near the outline: on outlines of every kind (a long slanted edge across many rows and columns, a star's
    spikes, a circle's many short segments, a rotated square hole, holes side by side in one row) its answers are
    shapely's, or ask within 1 nm of the outline; and the cost of a point does not depend on how many segments its
    row has: on the holed field a point near an outline looks at a few of its row's segments."""
    terrain = Terrain.from_dict({"name": "slanted", "start": [0.0, 0.0], "goal_x": 1.0, "regions": [
        {"shape": "polygon", "vertices": [[-0.2, -0.4], [1.3, -0.37], [1.1, 0.41], [-0.17, 0.3]]},
        {"shape": "star", "center": [1.6, 0.0], "outer_radius": 0.3, "inner_radius": 0.08, "points": 7, "yaw": 0.1},
        {"shape": "circle", "center": [2.3, 0.1], "radius": 0.25},
    ]})
    holes = shapely.union_all([shapely.box(0.1 + 0.07 * k, -0.1, 0.13 + 0.07 * k, 0.1) for k in range(12)])
    tilted = shapely.affinity.rotate(shapely.box(2.2, 0.0, 2.35, 0.15), 30.0)
    rng = np.random.default_rng(3)
    for geometry in (terrain.safe_region(0.0), terrain.safe_region(0.0).difference(holes).difference(tilted)):
        locator = PointLocator.build(geometry)
        outline = locator.outline
        along = outline.segments[:, :2] + rng.uniform(0, 1, (len(outline.segments), 1)) * (
            outline.segments[:, 2:] - outline.segments[:, :2])
        b = geometry.bounds
        points = np.concatenate([rng.uniform(b[:2], b[2:], (20000, 2)), outline.segments[:, :2], along,
                                 along + rng.normal(0.0, 1e-6, along.shape),
                                 along + rng.normal(0.0, 2e-9, along.shape)])
        got = np.array([safe_walk._lookup(x, y, locator.raster, locator.codes, outline.entries, outline.row_first)
                        for x, y in points])
        distance = shapely.distance(geometry.boundary, shapely.points(points))
        asked = got < 0
        assert not asked[distance > 1e-9].any()
        exact = shapely.intersects_xy(geometry, points[:, 0], points[:, 1])
        assert np.array_equal(got[~asked] == safe_walk.SAFE, exact[~asked])
        near = (_raster_codes(locator, points) == 2) & ~asked
        assert near.sum() > 200, near.sum()
    # on the field with 100 holes, the entries a point near an outline may look at: far fewer than its row has
    locator = random_field(100, 0).safe_locator(0.008)
    entries, row_first = locator.outline.entries, locator.outline.row_first
    looked, in_row = [], []
    for x, y in rng.uniform((0.0, -0.3), (2.0, 0.3), (20000, 2)):
        col, row = int(x * locator.raster[0] - locator.raster[1]), int(y * locator.raster[0] - locator.raster[2])
        if locator.codes[col + row * int(locator.raster[4])] != 2:
            continue
        row_entries = entries[row_first[row]:row_first[row + 1]]
        end = col + 1
        while locator.codes[end + row * int(locator.raster[4])] == 2:
            end += 1
        x_end = (end + locator.raster[1]) / locator.raster[0]
        looked.append(int(np.count_nonzero((row_entries[:, 4] <= x_end + 1e-9) & (row_entries[:, 5] >= x - 1e-9))))
        in_row.append(len(row_entries))
    assert len(looked) > 100 and np.median(in_row) >= 10 and np.median(looked) <= 4, (np.median(in_row),
                                                                                       np.median(looked))


def test_scalar_and_raster_lookups_are_the_exact_answers():
    """``PointLocator.covers_xy`` (in a cell near an outline the outline's segments decide, shapely on it),
    ``TopParts.part_at`` (a raster, ``CoverLocator``), ``HeightLocator.heights`` with few points next to an outline
    and ``height_xy``: the same answers as shapely, also on the outlines."""
    rng = np.random.default_rng(5)
    for terrain in (random_field(100, 0), random_heights(80, 0), resolve("stairs"), resolve("stepping_stones")):
        b = terrain.bounds
        points = np.column_stack([rng.uniform(b[0] - 0.05, b[2] + 0.05, 4000), rng.uniform(b[1] - 0.05, b[3] + 0.05, 4000)])
        on_edges = np.column_stack([np.round(rng.uniform(b[0], b[2], 1000) / 0.025) * 0.025,
                                    rng.uniform(b[1], b[3], 1000)])  # the squares' edges lie on this grid
        points = np.concatenate([points, on_edges, [[np.nan, 0.0], [np.inf, 0.0]]])
        for margin in (0.0, 0.008):
            locator = terrain.safe_locator(margin)
            segments = locator.outline.segments  # and on the outline: its vertices, points along and next to it
            along = segments[:, :2] + rng.uniform(0, 1, (len(segments), 1)) * (segments[:, 2:] - segments[:, :2])
            near = np.concatenate([points, segments[:, :2], along, along + rng.normal(0.0, 2e-9, along.shape)])
            exact = shapely.intersects_xy(locator.geometry, near[:, 0], near[:, 1])
            np.testing.assert_array_equal([locator.covers_xy(x, y) for x, y in near.tolist()], exact)
        if len(terrain.levels) > 1:
            parts = terrain.top_parts()
            exact = parts.part_at_exact(points)
            np.testing.assert_array_equal(parts.part_at(points), exact)
            np.testing.assert_array_equal([parts.locator.index_xy(x, y) for x, y in points.tolist()], exact)
            heights = terrain.height_locator()
            many = heights.heights(points)  # many points next to outlines: the STRtree
            few = np.concatenate([heights.heights(points[i:i + 3]) for i in range(0, len(points), 3)])
            one = np.array([heights.height_xy(x, y) for x, y in points.tolist()])
            np.testing.assert_array_equal(few, many)
            np.testing.assert_array_equal(one, many)


def test_the_batched_swing_check_at_its_limit(robot):
    """A ridge between lift-off and landing, from below to above what the swing clears (``max_step_m``): the
    batch and the checks one by one agree at every height, and the swing check alone decides some landings."""
    checker = FootholdChecker(robot.description)
    limit = checker.checks.max_step_m
    decided = 0
    for ridge_z in np.arange(limit - 0.02, limit + 0.025, 0.0025):
        terrain = Terrain.from_dict({"name": "ridge", "start": [0.0, 0.0], "goal_x": 1.0, "regions": [
            {"shape": "rect", "center": [0.5, 0.0], "size": [2.0, 1.0]},
            {"shape": "rect", "center": [0.5, 0.16], "size": [2.0, 0.01], "z": float(ridge_z)}]})
        legs = np.zeros(9, dtype=np.intp)  # FL, stepping sideways over the ridge (y 0.16), lift-off at y 0.12
        landing = np.column_stack([np.linspace(0.40, 0.60, 9), np.full(9, 0.20)])
        liftoff = landing - [0.0, 0.08]
        hips = landing + [0.0, -0.03]
        tops = np.zeros(4)
        every = checker.evaluate(terrain, legs, landing, liftoff, hips, tops, 0.0)
        expected = np.logical_and.reduce(list(every.values()))
        np.testing.assert_array_equal(checker.usable(terrain, legs, landing, liftoff, hips, tops, 0.0), expected)
        others = np.logical_and.reduce([value for name, value in every.items() if name != "step"])
        decided += int((others & ~every["step"]).sum())
        assert every["step"].all() == (ridge_z <= limit + 1e-9)
    assert decided > 0


def test_the_hot_path_step_constructor_builds_the_same_step():
    """``PlannedStep.ranked`` (the planners' fast constructor) sets every field, as ``PlannedStep(...)`` does."""
    import dataclasses

    points = np.array([[0.1, 0.2], [0.3, -0.2]])
    fast = PlannedStep.ranked((1, 2), points, 17, 4)
    slow = PlannedStep(legs=(1, 2), footholds_xy_world=points, action_index=17, rank=4, discarded=4)
    assert set(vars(fast)) == {f.name for f in dataclasses.fields(PlannedStep)}
    assert fast == slow and type(fast) is PlannedStep
    with pytest.raises(dataclasses.FrozenInstanceError):
        fast.rank = 0
    assert dataclasses.replace(fast, captured=True).captured
