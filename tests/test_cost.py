"""Tests of the ranking cost (contactnet.planning.cost) and of the OraclePlanner that uses it."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest
from shapely.geometry import MultiPoint, Point

from contactnet import registry
from contactnet.frames import rotate_xy, rotation_2d
from contactnet.motion.cost_weights import TROT_WEIGHTS, WALK_WEIGHTS, CostWeights
from contactnet.motion.gait import TROT, WALK
from contactnet.motion.support_polygon import hull_area_centroid, support_distance
from contactnet.motion.trajopt import TrajectoryOptimizer, TrajoptConfig, TrajoptProblem
from contactnet.planning.cost import (
    TERM_NAMES,
    CostBreakdown,
    CostState,
    RankingCost,
    kin_penalty,
    nominal_state,
    predicted_state,
)
from contactnet.planning.cost_study import greedy_rollout
from contactnet.planning.oracle import OraclePlanner
from contactnet.planning.planner import PlanningContext
from contactnet.robots import load_robot
from contactnet.terrain import Terrain, flat

SOLO12 = load_robot("solo12").description
FOOT_RADIUS_M = SOLO12.foot_radius_m
# Solo12's nominal foot xy in the base frame; FL, FR, HL, HR
HIPS = np.asarray(SOLO12.foot_nominal_base[:, :2])
HIPS_MEASURED = np.array([[0.1946, 0.14695], [0.1946, -0.14695], [-0.1946, 0.14695], [-0.1946, -0.14695]])
STAB, KIN, CENT, AREA = (TERM_NAMES.index(n) for n in ("stab", "kin", "cent", "area"))
CENTRE_CELL = {WALK.name: 12, TROT.name: 4}


def test_nominal_feet_match_the_robot(robot):
    np.testing.assert_allclose(robot.foot_nominal_base[:, :2], HIPS_MEASURED, atol=1e-4)


@pytest.fixture(scope="module", autouse=True)
def one_torch_thread():
    """The batched solver's Cholesky runs in torch; on a shared 2-core machine two threads are several
    times slower than one (oversubscription), so this module runs with one and restores the setting."""
    torch = pytest.importorskip("torch")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


@pytest.fixture(scope="module")
def costs() -> dict[str, RankingCost]:
    return {g.name: RankingCost(g, SOLO12) for g in (WALK, TROT)}


def reference_evaluate(cost: RankingCost, state: CostState) -> CostBreakdown:
    """``RankingCost.evaluate``, plainly: one optimizer ``solve`` per choice (the actions, then standing), shapely
    polygons, Python loops."""
    config = TrajoptConfig(n_nodes=cost.gait.nodes_per_step, dt_s=cost.gait.node_dt_s, solver="auto")
    opt = TrajectoryOptimizer(cost.model, config, cost.trajopt_weights)  # casadi + piqp, one at a time
    w = cost.weights
    gait = cost.gait
    t0 = time.perf_counter()
    rot = rotation_2d(state.yaw_rad)
    feet_now = np.asarray(state.foot_pos_world, dtype=float)
    hips_now = [np.asarray(state.base_xy_world) + rot @ cost.hip_ref_xy_base[leg] for leg in range(4)]
    grid_base = np.asarray(state.base_xy_world) + cost.grid_lead_s * np.asarray(state.vel_cmd_world)
    n = gait.nodes_per_step
    terms, success, coms, footholds, solutions = [], [], [], [], []
    opt_time = 0.0
    for index in range(cost.n_choices):
        if index == gait.stand_index:
            legs, offsets = (), np.zeros((0, 2))
        else:
            legs, offsets = gait.decode(index).legs, gait.decode(index).offsets_xy
        contact = gait.step_contact(legs)
        feet = np.repeat(feet_now[None], n, axis=0)
        for leg, offset in zip(legs, offsets, strict=True):
            landing = grid_base + rot @ cost.hip_ref_xy_base[leg] + rot @ offset
            for k in range(gait.n_stance_pre + gait.n_swing, n):
                feet[k, leg] = (landing[0], landing[1], state.ground_z)
        problem = TrajoptProblem(
            x0=state.x0(),
            contact=contact,
            foot_pos_world=feet,
            com_vel_ref_xy=np.asarray(state.vel_cmd_world, dtype=float),
            com_height_ref_m=float(state.com_height_ref_m),
            yaw_ref_rad=float(state.yaw_rad),
            com_xy_ref_start=state.com_xy_ref_start,
        )
        ts = time.perf_counter()
        sol = opt.solve(problem, warm_start=False)
        opt_time += time.perf_counter() - ts
        solutions.append(sol)
        success.append(sol.success)
        coms.append(sol.x[:, 0:3])
        footholds.append(feet[-1, :, 0:2])
        com_xy = sol.x[:, 0:2]
        stab = kin = 0.0
        for k in range(n):
            stance = [leg for leg in range(4) if contact[k, leg]]
            hull = MultiPoint([tuple(feet[k, leg, 0:2]) for leg in stance]).convex_hull
            stab += max(hull.distance(Point(*com_xy[j])) for j in (k, k + 1))
            for leg in stance:
                worst = 0.0
                for j in (k, k + 1):
                    if w.kin_hip_path == "optimized":
                        hip = hips_now[leg] + (com_xy[j] - com_xy[0])
                    else:
                        hip = hips_now[leg] + j * gait.node_dt_s * np.asarray(state.vel_cmd_world)
                    worst = max(worst, float(np.hypot(*(feet[k, leg, 0:2] - hip))))
                if worst > cost.kin_threshold_m:
                    kin += 1.0 + (worst - cost.kin_threshold_m) / w.kin_ramp_m
        final = MultiPoint([tuple(feet[-1, leg, 0:2]) for leg in range(4)]).convex_hull
        cent = final.centroid.distance(Point(*com_xy[-1]))
        short = sum(max(0.0, 1.0 - float(np.hypot(*(feet[-1, leg, 0:2] - feet_now[leg, 0:2]))) / w.short_swing_m)
                    for leg in legs)
        terms.append([sol.cost, stab, kin, cent, final.area, float(len(legs)), short])
    breakdown = cost._finish(
        np.array(terms, dtype=float), np.array(success), np.array(coms), np.array(footholds), solutions
    )
    breakdown.optimizer_s = opt_time
    breakdown.total_s = time.perf_counter() - t0
    return breakdown


def point_line_distance(p, a, b) -> float:
    p, a, b = (np.asarray(v, dtype=float) for v in (p, a, b))
    d = b - a
    return abs(d[0] * (p[1] - a[1]) - d[1] * (p[0] - a[0])) / np.hypot(*d)


# ---- geometry ---------------------------------------------------------------------------------


def test_support_distance_hand_made_cases():
    feet = HIPS.copy()
    fl, fr, hl, hr = feet
    all4 = np.ones(4, dtype=bool)
    assert support_distance([0.0, 0.0], feet, all4) == 0.0
    assert support_distance([0.1946, 0.0], feet, all4) == 0.0  # on an edge
    assert support_distance([0.3, 0.0], feet, all4) == pytest.approx(0.3 - 0.1946)
    corner = [0.3, -0.2]
    assert support_distance(corner, feet, all4) == pytest.approx(np.hypot(0.3 - 0.1946, -0.2 + 0.14695))
    # triangle FL FR HR (HL swings): its hypotenuse is the diagonal FL-HR
    no_hl = np.array([True, True, False, True])
    assert support_distance([0.05, -0.02], feet, no_hl) == 0.0
    outside = [-0.05, 0.05]
    assert support_distance(outside, feet, no_hl) == pytest.approx(point_line_distance(outside, fl, hr))
    # two feet: a segment (trot, FR-HL in stance); off the middle, then beyond an end
    pair = np.array([False, True, True, False])
    p = [0.03, 0.03]
    assert support_distance(p, feet, pair) == pytest.approx(point_line_distance(p, fr, hl))
    assert support_distance([0.3, -0.2], feet, pair) == pytest.approx(np.hypot(0.3 - 0.1946, -0.2 + 0.14695))
    on_segment = 0.25 * fr + 0.75 * hl
    assert support_distance(on_segment, feet, pair) == pytest.approx(0.0, abs=1e-12)
    # one foot: a point; none: no support
    one = np.array([True, False, False, False])
    assert support_distance([0.0, 0.0], feet, one) == pytest.approx(np.hypot(*fl))
    assert support_distance([0.0, 0.0], feet, np.zeros(4, dtype=bool)) == np.inf


def test_support_distance_matches_shapely_on_random_configurations():
    rng = np.random.default_rng(3)
    n = 400
    feet = HIPS + rng.normal(0.0, 0.06, (n, 4, 2))
    feet[:40, 3] = feet[:40, :3].mean(axis=1)  # a foot inside the others' triangle
    feet[40:60, 2] = 0.5 * (feet[40:60, 0] + feet[40:60, 1])  # collinear feet
    stance = rng.random((n, 4)) < 0.75
    stance[:60] = True
    points = rng.normal(0.0, 0.15, (n, 2))
    got = support_distance(points, feet, stance)
    for i in range(n):
        legs = np.flatnonzero(stance[i])
        if len(legs) == 0:
            assert got[i] == np.inf
            continue
        hull = MultiPoint([tuple(feet[i, leg]) for leg in legs]).convex_hull
        assert got[i] == pytest.approx(hull.distance(Point(points[i])), abs=1e-12)


def test_hull_area_and_centroid():
    rect = np.array([[0.2, 0.15], [0.2, -0.15], [-0.2, 0.15], [-0.2, -0.15]]) + [0.1, -0.05]
    for order in ([0, 1, 2, 3], [0, 3, 1, 2], [2, 0, 3, 1]):  # any order: self-intersecting ones too
        area, centroid = hull_area_centroid(rect[order])
        assert area == pytest.approx(0.4 * 0.3)  # positive whatever the orientation
        np.testing.assert_allclose(centroid, [0.1, -0.05], atol=1e-12)
    # one point inside the triangle of the others: the hull is that triangle
    tri = np.array([[0.0, 0.0], [0.3, 0.0], [0.0, 0.3], [0.05, 0.05]])
    area, centroid = hull_area_centroid(tri)
    assert area == pytest.approx(0.5 * 0.3 * 0.3)
    np.testing.assert_allclose(centroid, [0.1, 0.1], atol=1e-12)
    rng = np.random.default_rng(5)
    for feet in rng.normal(0.0, 0.15, (100, 4, 2)):
        hull = MultiPoint([tuple(f) for f in feet]).convex_hull
        area, centroid = hull_area_centroid(feet)
        assert area == pytest.approx(hull.area, abs=1e-12)
        np.testing.assert_allclose(centroid, [hull.centroid.x, hull.centroid.y], atol=1e-9)


def test_kin_penalty_is_a_hinge_with_a_jump():
    thr, ramp = 0.10, 0.02
    assert kin_penalty(thr - 1e-6, thr, ramp) == 0.0
    assert kin_penalty(thr, thr, ramp) == 0.0
    assert kin_penalty(thr + 1e-6, thr, ramp) == pytest.approx(1.0, abs=1e-4)
    assert kin_penalty(thr + 0.01, thr, ramp) == pytest.approx(1.5)


# ---- cost terms through RankingCost --------------------------------------------------------------


def constant_com(n_actions: int, xy, z: float = 0.215) -> np.ndarray:
    com = np.zeros((n_actions, 9, 3))
    com[..., 0:2] = xy
    com[..., 2] = z
    return com


@pytest.mark.parametrize(
    ("com_xy", "expected"),
    [
        ((0.05, -0.02), lambda: 0.0),  # inside the swing triangle
        ((-0.05, 0.05), lambda: 4 * point_line_distance((-0.05, 0.05), HIPS[0], HIPS[3])),  # outside it
    ],
)
def test_stab_walk_triangle(costs, com_xy, expected):
    rc = costs["walk"]
    state = nominal_state(SOLO12, (0.0, 0.0))
    a = WALK.encode(2, (CENTRE_CELL["walk"],))  # HL swings and lands back on its hip reference
    feet = rc._foot_plans(state)[..., 0:2]
    terms = rc.geometric_terms(state, constant_com(WALK.n_choices, com_xy), feet)
    # inside the four-foot rectangle at nodes 0-2 and 7; the 4 swing nodes see the triangle FL FR HR
    assert terms[a, 0] == pytest.approx(expected(), abs=1e-12)


def test_stab_trot_segment_and_cent_area(costs):
    rc = costs["trot"]
    state = nominal_state(SOLO12, (0.0, 0.0))
    c = CENTRE_CELL["trot"]
    a = TROT.encode(0, (c, c))  # FL + HR swing, FR-HL stance, both land back on their hips
    feet = rc._foot_plans(state)[..., 0:2]
    p = (0.03, 0.03)
    terms = rc.geometric_terms(state, constant_com(TROT.n_choices, p), feet)
    assert terms[a, 0] == pytest.approx(4 * point_line_distance(p, HIPS[1], HIPS[2]))
    assert terms[a, 2] == pytest.approx(np.hypot(*p))  # V_cent: to the rectangle's centre
    assert terms[a, 3] == pytest.approx(4 * 0.1946 * 0.14695)  # V_area of the nominal rectangle
    far = (0.3, -0.2)  # beyond FR: outside everything, 8 nodes at the same corner distance
    terms = rc.geometric_terms(state, constant_com(TROT.n_choices, far), feet)
    assert terms[a, 0] == pytest.approx(8 * np.hypot(0.3 - 0.1946, -0.2 + 0.14695))


@pytest.mark.parametrize("excess", [-0.002, 0.002])
def test_kin_threshold_just_below_and_above(costs, excess):
    rc = costs["walk"]
    w = rc.weights
    offsets = np.zeros((4, 2))
    offsets[0, 0] = rc.kin_threshold_m + excess  # FL ahead of its hip
    state = nominal_state(SOLO12, (0.0, 0.0), foot_offsets_xy=offsets)
    result = rc.evaluate(state)
    # HR steps within its inner 3 x 3 cells (never a violation itself); FL stays in stance for all 8 nodes
    hr_actions = [WALK.encode(3, (ix * 5 + iy,)) for ix in range(1, 4) for iy in range(1, 4)]
    expected = 0.0 if excess < 0 else 8 * (1.0 + excess / w.kin_ramp_m)
    np.testing.assert_allclose(result.terms[hr_actions, KIN], expected, atol=1e-9)
    assert np.all(result.V[hr_actions] > w.kin * expected - 1.0)
    fl_home = WALK.encode(0, (CENTRE_CELL["walk"],))  # FL steps back under its hip after 3 stance nodes
    assert result.terms[fl_home, KIN] == pytest.approx(3 / 8 * expected)


def test_weights_combine_the_terms(costs):
    result = costs["walk"].evaluate(nominal_state(SOLO12, (0.1, 0.0)))
    w = costs["walk"].weights
    expected = result.terms @ np.array([w.opt, w.stab, w.kin, w.cent, -w.area, w.swing, w.short])
    np.testing.assert_allclose(result.V, expected, rtol=1e-12)
    assert result.success.all()
    assert result.com_traj_world.shape == (101, 9, 3)  # 100 actions, then standing
    assert np.all(result.terms[:, AREA] > 0)


# ---- fast path against the reference loop ---------------------------------------------------------


def moving_state(gait_name: str) -> CostState:
    rng = np.random.default_rng(11 if gait_name == "walk" else 12)
    state = nominal_state(SOLO12, (0.08, 0.03), yaw_rad=0.3, foot_offsets_xy=rng.uniform(-0.04, 0.04, (4, 2)))
    return dataclasses.replace(
        state,
        com_pos_world=state.com_pos_world + [0.01, -0.005, 0.003],
        com_vel_world=np.array([0.06, 0.04, 0.01]),
        rpy=np.array([0.02, -0.01, 0.31]),
        ang_vel_world=np.array([0.05, -0.1, 0.02]),
        base_xy_world=np.array([0.012, -0.004]),
        com_xy_ref_start=np.array([0.02, 0.0]),
    )


@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
@pytest.mark.parametrize("hip_path", ["reference", "optimized"])
def test_fast_cost_matches_the_reference_loop(gait, hip_path):
    rc = RankingCost(gait, SOLO12, CostWeights(kin_hip_path=hip_path))
    state = moving_state(gait.name)
    fast = rc.evaluate(state)
    ref = reference_evaluate(rc, state)
    assert fast.success.all() and ref.success.all()
    np.testing.assert_allclose(fast.terms, ref.terms, rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(fast.V, ref.V, rtol=1e-4, atol=2e-3)
    np.testing.assert_array_equal(fast.ranking()[:10], ref.ranking()[:10])
    np.testing.assert_allclose(fast.footholds_xy_world, ref.footholds_xy_world, atol=1e-12)
    np.testing.assert_allclose(fast.com_traj_world, ref.com_traj_world, atol=1e-4)


def test_candidates_sit_on_the_grid_around_the_current_hips(costs):
    state = moving_state("walk")
    footholds = costs["walk"].candidate_footholds(state)
    hips = state.base_xy_world + rotate_xy(HIPS, state.yaw_rad)
    expected = WALK.candidates_world(hips, state.yaw_rad)  # (4, 25, 2)
    for leg in range(4):
        np.testing.assert_allclose(footholds[leg * 25 : leg * 25 + 25, leg], expected[leg], atol=1e-12)
        others = [i for i in range(4) if i != leg]
        np.testing.assert_allclose(
            footholds[leg * 25 : leg * 25 + 25][:, others], np.broadcast_to(state.foot_pos_world[others, :2],
                                                                           (25, 3, 2)))


def test_failed_optimizations_tie_at_the_bottom(costs, monkeypatch):
    rc = RankingCost(WALK, SOLO12)
    original = rc.optimizer.solve_batch
    failed = [5, 0, 42]

    def with_failures(problems):
        solutions = original(problems)
        for i in failed:
            solutions[i] = dataclasses.replace(solutions[i], success=False, status="infeasible", cost=np.inf)
        return solutions

    monkeypatch.setattr(rc.optimizer, "solve_batch", with_failures)
    result = rc.evaluate(nominal_state(SOLO12, (0.1, 0.0)))
    assert not result.success[failed].any() and result.success.sum() == 98  # 101 choices
    assert np.all(result.V[failed] == rc.weights.failure_cost)
    assert np.isnan(result.terms[failed]).all()
    np.testing.assert_array_equal(result.ranking()[-3:], sorted(failed))
    assert np.all(result.V[result.success] < 1e3)


def test_tuned_weights_keep_greedy_stepping_sustainable():
    walk = greedy_rollout(RankingCost(WALK, SOLO12, WALK_WEIGHTS), nominal_state(SOLO12, (0.1, 0.0)), 12)
    assert walk["worst_foot_hip_m"] < 0.15  # from standing the front feet lag once, then a steady crawl
    assert all(walk["sequence"].count(leg) >= 2 for leg in ("FL", "FR", "HL", "HR"))
    trot = greedy_rollout(RankingCost(TROT, SOLO12, TROT_WEIGHTS), nominal_state(SOLO12, (0.1, 0.0)), 12)
    assert trot["kin"] == 0.0 and trot["repeats"] == 0.0  # the diagonal pairs alternate


# ---- the oracle ------------------------------------------------------------------------------------


def context(terrain: Terrain, gait=WALK, foot_offsets_xy=None, vel=(0.1, 0.0)) -> PlanningContext:
    feet = np.zeros((4, 3))
    feet[:, 0:2] = HIPS + (0.0 if foot_offsets_xy is None else foot_offsets_xy)
    feet[:, 2] = terrain.surface_z + FOOT_RADIUS_M
    return PlanningContext(
        com_pos_world=np.array([0.0, 0.0, terrain.surface_z + 0.215]),
        com_vel_world=np.array([vel[0], vel[1], 0.0]),
        yaw_rad=0.0,
        foot_pos_world=feet,
        hip_ref_xy_base=HIPS,
        base_xy_world=np.zeros(2),
        vel_cmd_xy=np.array(vel),
        terrain=terrain,
        gait=gait,
        com_height_ref_m=0.215,
    )


def test_state_from_context():
    terrain = Terrain.from_dict({"name": "raised", "start": [0, 0], "goal_x": 1.0, "surface_z": 0.1,
                                 "regions": [{"shape": "rect", "center": [0, 0], "size": [2, 2]}]})
    ctx = context(terrain)
    state = CostState.from_context(ctx, FOOT_RADIUS_M)
    np.testing.assert_allclose(state.foot_pos_world[:, 2], 0.1)  # contact points, not ball centres
    assert state.com_height_ref_m == pytest.approx(0.315)
    assert state.ground_z == pytest.approx(0.1)
    np.testing.assert_allclose(state.vel_cmd_world, [0.1, 0.0])
    np.testing.assert_allclose(state.x0()[:3], [0.0, 0.0, 0.315])


def test_oracle_plans_three_steps_from_predicted_states():
    planner = OraclePlanner(WALK, SOLO12)
    ctx = context(flat())
    steps = planner.plan(ctx)
    assert len(steps) == WALK.steps_per_plan
    assert all(s.rank == 0 and s.discarded == 0 and s.safe for s in steps)
    first = planner.last_costs
    assert first.V.shape == (101,) and steps[0].action_index == int(first.ranking()[0])
    # step 2 is chosen from the state predicted one step horizon later: its grid moved with the body
    state2 = predicted_state(planner.last_state, steps[0].footholds_xy_world, steps[0].legs,
                             WALK.step_duration_s)
    np.testing.assert_allclose(state2.base_xy_world, [0.1 * 0.32, 0.0])
    action = WALK.decode(steps[1].action_index)
    expected = state2.base_xy_world + HIPS[list(action.legs)] + action.offsets_xy
    np.testing.assert_allclose(steps[1].footholds_xy_world, expected, atol=1e-12)


def grid_terrain_with_hole(hole_xy: np.ndarray) -> Terrain:
    """5 cm cells, the one centred on hole_xy removed."""
    cols, rows = 30, 24
    origin = np.asarray(hole_xy) - 0.025 - 0.05 * np.array([15, 12])
    return Terrain.from_dict({
        "name": "hole", "start": [0.0, 0.0], "goal_x": 0.5,
        "regions": [{"shape": "grid", "origin": origin.tolist(), "cell": 0.05, "cols": cols, "rows": rows,
                     "removed": [[15, 12]]}],
    })


@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
def test_oracle_skips_the_cheapest_action_over_a_hole(gait):
    planner = OraclePlanner(gait, SOLO12)
    costs = planner.cost.evaluate(CostState.from_context(context(flat(), gait), FOOT_RADIUS_M))
    best = int(costs.ranking()[0])
    leg = gait.decode(best).legs[0]
    terrain = grid_terrain_with_hole(costs.footholds_xy_world[best, leg])
    steps = planner.plan(context(terrain, gait))
    np.testing.assert_allclose(planner.last_costs.V, costs.V)
    # the first safe action of the ranking, found plainly
    swing, _ = gait.action_table
    expected_rank = next(
        rank for rank, a in enumerate(costs.ranking())
        if terrain.is_safe(costs.footholds_xy_world[a, swing[a]], planner.margin_m).all()
    )
    step = steps[0]
    assert expected_rank > 0
    assert step.rank == expected_rank and step.discarded == expected_rank
    assert step.action_index == int(costs.ranking()[expected_rank])
    assert step.safe and terrain.is_safe(step.footholds_xy_world, planner.margin_m).all()
    assert not terrain.is_safe(costs.footholds_xy_world[best, swing[best]], planner.margin_m).all()


def islands(points_xy, radius=0.02) -> Terrain:
    regions = [{"shape": "circle", "center": [float(x), float(y)], "radius": radius} for x, y in points_xy]
    regions.append({"shape": "circle", "center": [0.0, 0.0], "radius": 0.03})
    return Terrain.from_dict({"name": "islands", "start": [0.0, 0.0], "goal_x": 1.0, "regions": regions})


def test_oracle_stands_when_no_action_is_safe():
    """With the stand choice, nothing safe to step on means standing, whatever standing's rank."""
    offsets = np.full((4, 2), 0.025)
    planner = OraclePlanner(WALK, SOLO12)
    step = planner.plan(context(islands(HIPS + offsets), foot_offsets_xy=offsets))[0]
    assert step.legs == () and step.action_index == WALK.stand_index and step.safe
    assert step.footholds_xy_world.shape == (0, 2)


def test_oracle_steps_in_place_when_no_action_is_safe():
    offsets = np.full((4, 2), 0.025)  # every candidate is >= 3.5 cm from a foot
    feet_xy = HIPS + offsets
    planner = OraclePlanner(WALK, SOLO12, weights=dataclasses.replace(WALK.cost_weights, stand=False))
    ranking = planner.cost.evaluate(CostState.from_context(context(flat(), foot_offsets_xy=offsets), FOOT_RADIUS_M)).ranking()
    groups = list(dict.fromkeys(WALK.decode(int(a)).group for a in ranking))

    # every foot stands on its island: the group of the cheapest action steps in place
    step = planner.plan(context(islands(feet_xy), foot_offsets_xy=offsets))[0]
    assert step.legs == WALK.swing_groups[groups[0]]
    np.testing.assert_allclose(step.footholds_xy_world, feet_xy[list(step.legs)])
    assert step.action_index is None and step.rank is None and step.discarded == 100 and step.safe

    # that leg's island is gone: the next group steps in place
    keep = [leg for leg in range(4) if leg != groups[0]]
    step = planner.plan(context(islands(feet_xy[keep]), foot_offsets_xy=offsets))[0]
    assert step.legs == WALK.swing_groups[groups[1]] and step.safe

    # no foot on safe ground: the cheapest group, flagged unsafe
    step = planner.plan(context(islands([[0.6, 0.6]]), foot_offsets_xy=offsets))[0]
    assert step.legs == WALK.swing_groups[groups[0]] and not step.safe
    np.testing.assert_allclose(step.footholds_xy_world, feet_xy[list(step.legs)])


def test_the_force_term_is_per_squared_body_weight():
    """A robot k times heavier than Solo12 ranks with the force weight / k^2 (its forces are k times larger);
    Solo12 ranks with the tuned weights themselves."""
    from contactnet.motion.trajopt import TrajoptWeights
    from contactnet.planning.cost import ranking_trajopt_weights
    from contactnet.robots import load_robot

    solo12, go2 = load_robot("solo12").description, load_robot("go2").description
    assert ranking_trajopt_weights(solo12) == TrajoptWeights()
    k = go2.weight_n / solo12.weight_n
    assert 6.0 < k < 7.0
    assert np.allclose(np.asarray(ranking_trajopt_weights(go2).force) * k**2, TrajoptWeights().force, rtol=1e-3)
    assert RankingCost(registry.gait_for("walk", load_robot("go2")), go2).trajopt_weights == ranking_trajopt_weights(go2)
    # the walking loop's: per body weight
    assert np.allclose(np.asarray(TrajoptWeights.for_robot(go2).force) * k, TrajoptWeights().force, rtol=1e-3)
    assert TrajoptWeights.for_robot(solo12) == TrajoptWeights()


def test_the_walking_loop_weighs_forces_per_body_weight():
    """The loop's optimizer takes the robot's weights unless the config names others: with Solo12's force weight
    Go2's CoM stayed over the centroid of its feet (the equal shares of the reference forces outweighed the CoM's
    tracking) and it stopped on the narrow stones."""
    from contactnet.locomotion import Locomotion, LocomotionConfig
    from contactnet.motion.trajopt import TrajoptWeights
    from contactnet.robots import load_robot
    from contactnet.terrain import flat

    go2 = load_robot("go2")
    gait = registry.gait_for("walk", go2)
    planner = registry.make_planner("heuristic", gait, go2)
    with Locomotion(go2, flat(), gait, planner) as loco:
        assert loco.optimizer.weights == TrajoptWeights.for_robot(go2.description) != TrajoptWeights()
    with Locomotion(go2, flat(), gait, planner, config=LocomotionConfig(trajopt_weights=TrajoptWeights())) as loco:
        assert loco.optimizer.weights == TrajoptWeights()


@pytest.mark.slow
def test_go2_walks_the_paper_command_instead_of_standing():
    """The oracle on Go2 at the paper's 0.05 m/s: with the force term in Solo12's units it stood in 6 of 17 plans
    and walked 0.14 of the 0.30 m commanded in 6 s; per squared body weight it walks."""
    from contactnet.locomotion import Locomotion
    from contactnet.robots import load_robot
    from contactnet.sim.world import SimConfig

    robot = load_robot("go2")
    gait = registry.gait_for("walk", robot)
    planner = registry.make_planner("oracle", gait, robot)
    with Locomotion(robot, registry.terrain_for("flat", robot), gait, planner, SimConfig(),
                    vel_cmd_xy=(0.05, 0.0)) as loco:
        loco.advance(6000)
        x_m = float(loco.snapshot().q[0])
        assert loco.fall_reason is None
    assert x_m > 0.22, f"walked {x_m:.3f} m of 0.30 m"


def test_the_height_checks_are_sized_to_the_robot():
    """Every length of the height checks times the robot's size_scale (as its gaits); Solo12's are the defaults."""
    from dataclasses import fields

    from contactnet.planning.footholds import HeightChecks
    from contactnet.robots import load_robot

    for name in ("solo12", "go2"):
        robot = load_robot(name)
        planner = registry.make_planner("contactnet", registry.gait_for("walk", robot), robot)
        checks, scale = planner.footholds.checks, robot.description.size_scale
        for f in fields(HeightChecks):
            expected = getattr(HeightChecks(), f.name) * (scale if f.name.endswith("_m") else 1)
            assert getattr(checks, f.name) == pytest.approx(expected), f.name
    assert load_robot("solo12").description.size_scale == 1.0
    assert registry.make_planner("contactnet", registry.gait_for("walk", load_robot("solo12")),
                                 load_robot("solo12")).footholds.checks == HeightChecks()
