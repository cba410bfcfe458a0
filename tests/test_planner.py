"""Planners that rank: ContactNet and the fixed gait (the network's ranking, first safe candidate), the
shared walk down a ranking, and the candidate view for the web tool. The fast planner is checked
against a plain reference built from the library's generic pieces (CostState, predicted_state, one
is_safe query per action)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import slid_back

from contactnet.bench.planner import planning_contexts
from contactnet.frames import rotate_xy
from contactnet.motion.gait import TROT, WALK
from contactnet.planning.cost import CostState, candidate_footholds_world, predicted_state
from contactnet.planning.network import (
    ContactNet,
    ModelFileError,
    Normalizer,
    load_model,
    network_input_of_context,
    network_input_of_state,
    save_model,
)
from contactnet.planning.planner import (
    ContactNetPlanner,
    FixedGaitPlanner,
    PlannedStep,
    cell_grid,
    first_safe_step,
)
from contactnet.planning.roll import roll_ahead_xy
from contactnet.registry import make_planner
from contactnet.terrain import Terrain, flat, random_field


def landing_points(gait, cell_xy_world):
    """(N_a, legs_per_step, 2) landing points of every action from the (4, cells_per_leg, 2) grid cells."""
    legs, cells = gait.action_cells
    return cell_xy_world[legs, cells]


def random_model(path, gait, seed: int = 0):
    torch = pytest.importorskip("torch")
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    u = np.column_stack([rng.uniform(-0.3, 0.3, (200, 8)), rng.uniform(0.18, 0.25, 200),
                         rng.uniform(-0.1, 0.1, (200, 5))])
    save_model(path, ContactNet(gait.n_actions), Normalizer.fit(u), {"gait": gait.name})
    return path


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    folder = tmp_path_factory.mktemp("models")
    return {gait.name: random_model(folder / f"{gait.name}.pt", gait) for gait in (WALK, TROT)}


def reference_plan(planner: ContactNetPlanner, ctx, restrict_group=None) -> list[PlannedStep]:
    """The slow, obvious version: CostState objects, float64 inputs from network_input_of_state, the full
    (N_a, 4, 2) candidate array, one safety query per action in ranking order."""
    gait = planner.gait
    state = CostState.from_context(ctx, planner.robot.foot_radius_m)
    swing, _ = gait.action_table
    steps = []
    for j in range(gait.steps_per_plan):
        scores = planner.model.scores(network_input_of_state(state))
        order = np.argsort(-scores, kind="stable")
        if restrict_group is not None:
            group = gait.cyclic_order[(restrict_group + j) % len(gait.cyclic_order)]
            order = [a for a in order if a // gait.actions_per_group == group]
        centres = state.base_xy_world + rotate_xy(planner.hip_ref_xy_base, state.yaw_rad)
        footholds = candidate_footholds_world(gait, centres, state.yaw_rad, state.foot_pos_world)
        chosen = None
        for rank, index in enumerate(order):
            legs = np.flatnonzero(swing[index])
            if all(ctx.terrain.is_safe(footholds[index, leg][None], planner.margin_m)[0] for leg in legs):
                chosen = PlannedStep(legs=tuple(int(leg) for leg in legs), footholds_xy_world=footholds[index, legs],
                                     action_index=int(index), rank=rank, discarded=rank)
                break
        # the same legs' first landing with room for the foot's roll ahead (the command's direction), if any
        ahead = roll_ahead_xy(planner.robot.foot_radius_m,
                              rotate_xy(np.asarray(ctx.vel_cmd_xy, dtype=float), state.yaw_rad), planner.roll)
        if chosen is not None and ahead is not None:
            ahead = np.array(ahead)
            for rank, index in enumerate(order):
                legs = np.flatnonzero(swing[index])
                if tuple(int(leg) for leg in legs) == chosen.legs and all(
                        ctx.terrain.is_safe(footholds[index, leg][None], planner.margin_m)[0]
                        and ctx.terrain.is_safe(footholds[index, leg][None] + ahead, planner.margin_m)[0]
                        for leg in legs):
                    chosen = PlannedStep(legs=chosen.legs, footholds_xy_world=footholds[index, legs],
                                         action_index=int(index), rank=rank, discarded=chosen.discarded)
                    break
        if chosen is None:  # no safe candidate: the planner steps in place; compare no further
            steps.append(None)
            break
        steps.append(chosen)
        state = predicted_state(state, chosen.footholds_xy_world, chosen.legs, gait.step_duration_s)
    if steps and steps[0] is not None and ahead is not None and planner.roll.slide_back_radii > 0.0:
        steps[0] = dataclasses.replace(steps[0], footholds_xy_world=slid_back(  # the first step only, after the plan
            steps[0].footholds_xy_world, ctx.terrain, planner, ahead))
    return steps



def test_network_input_of_state_matches_network_input(robot):
    for ctx in planning_contexts(TROT, random_field(30, 1), robot.description, 10, seed=3):
        np.testing.assert_allclose(network_input_of_state(CostState.from_context(ctx, robot.description.foot_radius_m)), network_input_of_context(ctx),
                                   atol=1e-12)


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_contactnet_planner_matches_the_reference(robot, models, gait):
    planner = make_planner("contactnet", gait, robot, model=models[gait.name])
    terrain = random_field(200, 2)  # two thirds of the squares gone: rankings are walked deep
    deep = 0
    for ctx in planning_contexts(gait, terrain, robot.description, 40, seed=1):
        fast = planner.plan(ctx)
        slow = reference_plan(planner, ctx)
        for a, b in zip(fast, slow, strict=False):
            if b is None:
                assert a.action_index is None and a.discarded == gait.n_actions
                continue
            assert a.legs == b.legs and a.action_index == b.action_index
            assert a.rank == b.rank == a.discarded
            np.testing.assert_allclose(a.footholds_xy_world, b.footholds_xy_world, atol=1e-12)
            assert terrain.is_safe(a.footholds_xy_world, planner.margin_m).all()
            deep += a.rank >= 8
    assert deep > 0, "some choice should lie deep in the ranking"


def test_fixed_gait_follows_the_cyclic_order_and_the_reference(robot, models):
    planner = make_planner("fixed", WALK, robot, model=models["walk"])
    assert isinstance(planner, FixedGaitPlanner)
    terrain = random_field(60, 4)
    contexts = planning_contexts(WALK, terrain, robot.description, 12, seed=5)
    for k, ctx in enumerate(contexts):
        expected = reference_plan(planner, ctx, restrict_group=k % 4)
        steps = planner.plan(ctx)
        assert [s.legs for s in steps] == [WALK.swing_groups[WALK.cyclic_order[(k + j) % 4]] for j in range(3)]
        for a, b in zip(steps, expected, strict=False):
            assert (a.action_index, a.rank) == ((None, None) if b is None else (b.action_index, b.rank))
    planner.reset()
    assert planner.plan(contexts[0])[0].legs == WALK.swing_groups[WALK.cyclic_order[0]]


def test_fixed_gait_swings_in_place_when_its_leg_has_no_safe_cell(robot, models):
    planner = make_planner("fixed", WALK, robot, model=models["walk"])
    ctx = planning_contexts(WALK, flat(), robot.description, 1, seed=0)[0]
    leg = WALK.swing_groups[WALK.cyclic_order[0]][0]
    foot = ctx.foot_pos_world[leg, :2]
    # A ring of ground around the foot: it stands safely, but every cell of its grid is off the ground.
    terrain = Terrain.from_dict({
        "name": "island", "start": [float(foot[0]), float(foot[1])], "goal_x": float(foot[0]) + 1.0,
        "regions": [
            {"shape": "circle", "center": [float(foot[0]), float(foot[1])], "radius": 0.012},
            *[{"shape": "circle", "center": [float(x), float(y)], "radius": 0.03}
              for i, (x, y) in enumerate(ctx.foot_pos_world[:, :2]) if i != leg],
        ],
    })
    ctx = type(ctx)(**{**ctx.__dict__, "terrain": terrain})
    step = planner.plan(ctx)[0]
    assert step.legs == (leg,) and step.action_index is None and step.safe
    np.testing.assert_allclose(step.footholds_xy_world, [foot])
    assert step.discarded == WALK.actions_per_group
    # ContactNet, free to choose the leg, takes a safe cell of another leg (deep in its ranking).
    free = make_planner("contactnet", WALK, robot, model=planner.model.path).plan(ctx)[0]
    assert free.action_index is not None and free.legs != (leg,) and free.rank > 0
    assert terrain.is_safe(free.footholds_xy_world, planner.margin_m).all()


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_first_safe_step_takes_the_best_ranked_safe_action(gait):
    terrain = flat()
    order = np.arange(gait.n_actions)[::-1]
    cells = np.full((4, gait.cells_per_leg, 2), 50.0)  # off the 20 m field: unsafe
    legs, cell_ids = gait.action_cells
    target, later = order[20], order[25]  # make exactly these two actions safe (their cells only)
    cells[legs[target], cell_ids[target]] = [0.1, 0.2]
    cells[legs[later], cell_ids[later]] = [0.0, 0.0]
    assert landing_points(gait, cells).shape == (gait.n_actions, gait.legs_per_step, 2)
    safe_actions = terrain.is_safe(landing_points(gait, cells).reshape(-1, 2), 0.0).reshape(
        gait.n_actions, gait.legs_per_step).all(axis=1)
    first = next(rank for rank, index in enumerate(order) if safe_actions[index])  # the obvious loop
    step = first_safe_step(gait, order, cells, np.zeros((4, 2)), terrain, 0.0)
    assert step.rank == step.discarded == first <= 20
    assert step.action_index == order[first]
    np.testing.assert_allclose(step.footholds_xy_world, cells[legs[order[first]], cell_ids[order[first]]])
    # The oracle's view: the grid recovered from every action's feet (cost.footholds_xy_world).
    feet = np.zeros((gait.n_actions, 4, 2))
    feet[np.arange(gait.n_actions)[:, None], legs] = landing_points(gait, cells)
    np.testing.assert_array_equal(cell_grid(gait, feet), cells)
    # Nothing safe and the feet off the ground too: step in place, flagged unsafe.
    nothing = first_safe_step(gait, order, np.full_like(cells, 50.0), np.full((4, 2), 50.0), terrain, 0.0)
    assert nothing.action_index is None and not nothing.safe and nothing.discarded == gait.n_actions


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_candidate_view_ranks_every_cell(robot, models, gait):
    planner = make_planner("contactnet", gait, robot, model=models[gait.name])
    terrain = random_field(80, 0)
    ctx = planning_contexts(gait, terrain, robot.description, 1, seed=7)[0]
    step = planner.plan(ctx)[0]
    view = planner.last_candidates
    assert len(view.xy_world) == 4 * gait.cells_per_leg
    assert len(set(view.rank.tolist())) > 1 and view.rank.min() == 0
    assert len(view.chosen) == len(step.legs)
    for cell in view.chosen:
        assert view.rank[cell] <= step.rank  # a chosen cell is at least as good as the action using it
        assert view.safe[cell]
    chosen_xy = view.xy_world[list(view.chosen)]
    np.testing.assert_allclose(np.sort(chosen_xy, axis=0), np.sort(step.footholds_xy_world, axis=0))
    np.testing.assert_array_equal(view.safe, terrain.is_safe(view.xy_world, planner.margin_m))


def test_model_errors_are_clear(robot, models, tmp_path, monkeypatch):
    with pytest.raises(ModelFileError, match="no such file"):
        make_planner("contactnet", WALK, robot, model=tmp_path / "missing.pt")
    from contactnet.registry import load_robot

    # A robot with no shipped model (Unitree A1 as a robot file): the error names what to do instead.
    from contactnet.robots.robot_file import ROBOT_FILES_ENV

    monkeypatch.setenv(ROBOT_FILES_ENV, "")  # reading the file lists it for child processes: not after this test
    a1 = tmp_path / "a1.toml"
    a1.write_text('name = "a1_no_model"\ndescription_dir = "a1_description"\nurdf = "urdf/a1.urdf"\n'
                  'srdf = "srdf/a1.srdf"\nstanding_pose = "standing"\nleg_prefixes = ["FL", "FR", "RL", "RR"]\n'
                  'joint_suffixes = ["hip_joint", "thigh_joint", "calf_joint"]\nfoot_suffix = "foot"\n'
                  'foot_radius_m = 0.02\nfz_max_n = 120.0\nkin_threshold_m = 0.15\nfall_base_height_m = 0.12\n')
    with pytest.raises(ModelFileError, match=r"no contactnet model for a1_no_model walk .*--planner heuristic"
                                             r".*--model FILE.*datagen --robot a1_no_model --gait walk"
                                             r".*train --robot a1_no_model"):
        make_planner("contactnet", WALK, load_robot(str(a1), cache_dir=tmp_path))
    broken = tmp_path / "broken.pt"
    broken.write_bytes(b"not a model")
    with pytest.raises(ModelFileError, match="broken.pt"):
        make_planner("fixed", WALK, robot, model=broken)
    with pytest.raises(ModelFileError, match="trot"):
        make_planner("contactnet", WALK, robot, model=models["trot"])
    loaded = load_model(models["trot"])
    with pytest.raises(ValueError, match="not walk"):
        ContactNetPlanner(WALK, robot.description, loaded)


def test_oracle_continues_the_cyclic_order_past_its_evaluated_steps(robot):
    from contactnet.planning.cost import nominal_state
    from contactnet.planning.oracle import OraclePlanner

    for gait in (WALK, TROT):
        oracle = OraclePlanner(gait, robot.description, evaluated_steps=1)
        state = nominal_state(robot.description, vel_cmd_world=(0.1, 0.0))
        cyclic = gait.cyclic_order
        for k, group in enumerate(cyclic):
            step = oracle.continue_cyclically(state, gait.swing_groups[group])
            assert step.legs == gait.swing_groups[cyclic[(k + 1) % len(cyclic)]]
            # Raibert nominal: ahead of the hip reference by the command over touchdown + half a stance
            hips = state.base_xy_world + robot.foot_nominal_base[list(step.legs), :2]
            assert np.all(step.footholds_xy_world[:, 0] > hips[:, 0]) and np.allclose(step.footholds_xy_world[:, 1], hips[:, 1])
    with pytest.raises(ValueError, match="evaluated_steps"):
        OraclePlanner(WALK, robot.description, evaluated_steps=0)


def test_a_step_in_place_puts_a_foot_at_an_edge_back_a_margin_in():
    """``ranking.put_back``: a foot standing closer than twice the margin to its top's edge is put back at the
    nearest point twice the margin in, else the margin in, at most twice the margin away (repeated steps in place
    otherwise walk it off the edge); a foot further in, one in a gap, one whose nearest such point is further or on a
    top of another height stays where it is."""
    from contactnet.planning.ranking import put_back, step_in_place

    margin = 0.008
    terrain = Terrain.from_dict({"name": "two tops", "start": [0.1, 0.0], "goal_x": 0.5, "regions": [
        {"shape": "rect", "center": [0.2, 0.0], "size": [0.2, 0.2]},  # x 0.1-0.3, y -0.1-0.1, at z 0
        {"shape": "rect", "center": [0.305, 0.0], "size": [0.01, 0.2], "z": 0.03},  # a 1 cm strip, 3 cm higher
        {"shape": "circle", "center": [0.2, 0.2], "radius": 0.006},  # a small stone 10 cm from the low top
    ]})
    feet = np.array([[0.297, 0.0],  # 3 mm from the edge at x = 0.1 + 0.2 (a riser to the strip beyond it)
                     [0.2, -0.096],  # 4 mm from the edge at y = -0.1
                     [0.2, 0.05],  # 5 cm in
                     [0.2, 0.103],  # in the gap past y = 0.1
                     [0.305, 0.05],  # on the strip: none of it is 8 mm from its edges; the low top is 13 mm away
                     [0.2, 0.2]])  # on the small stone: no point of it is 8 mm in, the low top's nearest 11 cm away
    moved = put_back(terrain, feet, margin)
    # the riser is an edge of both tops: the foot goes 16 mm in from it, the other one 16 mm in from y = -0.1
    np.testing.assert_allclose(moved[:2], [[0.3 - 2 * margin, 0.0], [0.2, -0.1 + 2 * margin]], atol=1e-6)
    assert terrain.is_safe(moved[:2], 2 * margin - 1e-9).all()
    np.testing.assert_array_equal(moved[2:], feet[2:])
    np.testing.assert_array_equal(put_back(terrain, feet, 0.0), feet)  # no margin: where they stand
    # a narrow top (2 cm): nothing 16 mm in, the foot goes 8 mm in
    narrow = Terrain.from_dict({"name": "bar", "start": [0.2, 0.0], "goal_x": 0.5, "regions": [
        {"shape": "rect", "center": [0.2, 0.0], "size": [0.02, 0.2]}]})
    np.testing.assert_allclose(put_back(narrow, np.array([[0.208, 0.0]]), margin), [[0.21 - margin, 0.0]], atol=1e-6)

    # step_in_place puts the chosen group's feet back with the planner's margin
    standing = np.zeros((4, 3))
    standing[:, :2] = [[0.297, 0.05], [0.297, -0.05], [0.15, 0.05], [0.15, -0.05]]
    order = np.arange(WALK.n_actions)  # group 0 first
    step = step_in_place(WALK, order, standing, terrain, margin)
    legs = list(WALK.swing_groups[0])
    assert step.safe and step.action_index is None
    np.testing.assert_allclose(step.footholds_xy_world, put_back(terrain, standing[legs, :2], margin))
    assert not np.array_equal(step.footholds_xy_world, standing[legs, :2])  # a front foot was at the riser


def test_a_trot_leg_left_behind_with_no_safe_pair_steps_alone(robot, models):
    """``reach.alone_step``: the front-left foot 20 cm behind its hip reference (left behind), its pair's other leg
    (hind right) with no safe cell, so no action of their swing group is safe: the front-left leg steps alone to its
    one safe cell; with no safe cell in its own 3 x 3 grid, to the safe point of the grid widened by a spacing nearest
    the grid's centre. With ``ReachConfig(step_alone=False)`` the plan is the plain one (another group's step)."""
    from contactnet.planning.planner import PlanningContext
    from contactnet.planning.reach import ReachConfig

    fl, hr = 0, 3
    assert (fl, hr) in TROT.swing_groups
    base = np.array([0.5, 0.0])
    hips = base + robot.description.foot_nominal_base[:, :2]  # the grids' centres (yaw 0, no capture)
    feet = np.zeros((4, 3))
    feet[:, :2] = hips
    feet[fl, 0] -= 0.20  # left behind
    feet[hr, :2] += 0.025  # between its cells: none of them is on ground
    feet[:, 2] = robot.description.foot_radius_m

    def context(fl_points):
        terrain = Terrain.from_dict({"name": "stuck pair", "start": hips[1].tolist(), "goal_x": 1.5, "regions": [
            *[{"shape": "circle", "center": foot[:2].tolist(), "radius": 0.012} for foot in feet],
            *[{"shape": "rect", "center": hips[leg].tolist(), "size": [0.14, 0.14]} for leg in (1, 2)],
            *[{"shape": "circle", "center": point, "radius": 0.03} for point in fl_points]]})
        return PlanningContext(
            com_pos_world=np.array([*base, robot.description.com_height_nominal_m]),
            com_vel_world=np.array([0.05, 0.0, 0.0]),
            yaw_rad=0.0, foot_pos_world=feet.copy(), hip_ref_xy_base=robot.description.foot_nominal_base[:, :2],
            base_xy_world=base.copy(), vel_cmd_xy=np.array([0.05, 0.0]), terrain=terrain, gait=TROT,
            com_height_ref_m=robot.description.com_height_nominal_m)

    planner = make_planner("contactnet", TROT, robot, model=models["trot"])
    centre = hips[fl]
    step = planner.plan(context([centre.tolist()]))[0]
    assert step.legs == (fl,) and step.action_index is None and step.safe
    np.testing.assert_allclose(step.footholds_xy_world, [centre], atol=1e-12)
    # nothing in its own grid: the widened grid's safe point nearest the centre (10 cm ahead, not 10 cm diagonally)
    step = planner.plan(context([(centre + [0.10, 0.0]).tolist(), (centre + [0.10, 0.10]).tolist()]))[0]
    assert step.legs == (fl,)
    np.testing.assert_allclose(step.footholds_xy_world, [centre + [0.10, 0.0]], atol=1e-9)
    plain = ContactNetPlanner(TROT, robot.description, planner.model, reach=ReachConfig(step_alone=False))
    assert plain.plan(context([centre.tolist()]))[0].legs != (fl,)


def test_the_paper_s_planner_is_a_named_baseline_without_the_additions(robot, models):
    """``contactnet_paper`` (``contactnet.registry``): the same network and safe-landing walk, every addition
    of this project off (capture, idle standing, the roll's room, the reach rule's leg stepping alone, the put-back);
    it plans like ``contactnet`` with those switches off, on a field where the ranking is walked deep."""
    from contactnet.registry import planner_names

    assert "contactnet_paper" in planner_names()
    paper = make_planner("contactnet_paper", WALK, robot, model=models["walk"])
    assert isinstance(paper, ContactNetPlanner) and paper.model.path == models["walk"]
    assert (paper.capture, paper.idle, paper.roll, paper.reach, paper._put_back_m) == (None, None, None, None, 0.0)
    plain = ContactNetPlanner(WALK, robot.description, paper.model, capture=None, idle=None, roll=None, reach=None,
                              put_back=False)
    ours = make_planner("contactnet", WALK, robot, model=models["walk"])
    differs = 0
    for ctx in planning_contexts(WALK, random_field(200, 2), robot.description, 30, seed=1):
        got, want = paper.plan(ctx), plain.plan(ctx)
        assert [(s.legs, s.action_index) for s in got] == [(s.legs, s.action_index) for s in want]
        differs += any(not np.array_equal(a.footholds_xy_world, b.footholds_xy_world)
                       for a, b in zip(got, ours.plan(ctx), strict=False))
    assert differs > 0, "the additions should change some plans on a field this holed"
