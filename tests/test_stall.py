"""The stall rule (contactnet.planning.stand.StallWatch, IdleConfig.stall_plans): a robot whose CoM has not followed a
moving command for several plans in a row neither stands nor swings a leg without moving it at its next first step;
the loop counts those plans, the planner reads the count from its context and otherwise plans as before."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from helpers import FixedScores

from contactnet.bench.planner import planning_contexts
from contactnet.locomotion import Locomotion
from contactnet.motion.gait import TROT, WALK
from contactnet.planning.brace import standing_horizon
from contactnet.planning.observer import DEFAULT_OBSERVER
from contactnet.planning.planner import ContactNetPlanner
from contactnet.planning.roll import roll_ahead_xy
from contactnet.planning.stand import DEFAULT_IDLE, IdleConfig, StallWatch, stalled, useless_swing
from contactnet.registry import make_planner, model_path
from contactnet.sim.pybullet_world import SimConfig
from contactnet.terrain import flat, resolve

STEP_S = 0.32


def test_the_watch_counts_plans_whose_com_did_not_follow_a_moving_command():
    """Each plan's CoM against the one where it last followed (the anchor): following means a quarter of the
    command's way per plan since then, along the command."""
    watch, config = StallWatch(STEP_S), IdleConfig(stall_speed_share=0.25)
    cmd = np.array([0.05, 0.0])
    way = 0.05 * STEP_S  # the command's way between two plans
    at = (lambda x, y=0.0: np.array([x, y, 0.3]))  # noqa: E731
    assert watch.count(at(0.0), cmd, 0.0, config) == 0  # the first plan: the anchor
    assert watch.count(at(0.2 * way), cmd, 0.0, config) == 1  # a fifth of the way: not following
    assert watch.count(at(0.2 * way, 0.05), cmd, 0.0, config) == 2  # sideways does not count
    assert watch.count(at(0.6 * way, 0.05), cmd, 0.0, config) == 3  # 0.6 of the way in 3 plans: less than 0.75
    assert watch.count(at(0.9 * way), cmd, 0.0, config) == 4  # ... 0.9 in 4 plans: less than 1
    assert watch.count(at(1.3 * way), cmd, 0.0, config) == 0  # 1.3 in 5 plans: it follows (a new anchor)
    assert watch.count(at(1.3 * way + 0.3 * way), cmd, 0.0, config) == 0  # 0.3 of the way in one plan
    for k in range(1, 6):  # a body that sways back and forth (0.3 of the way each plan) never follows
        assert watch.count(at(1.6 * way - 0.3 * way * (k % 2)), cmd, 0.0, config) == k
    assert watch.count(at(1.6 * way), np.zeros(2), 0.0, config) == 0  # no command: no stall
    assert watch.count(at(1.6 * way), cmd, 0.0, config) == 1
    watch.reset()
    assert watch.count(at(1.6 * way), cmd, 0.0, config) == 0  # after a reset: a first plan
    assert watch.count(at(1.6 * way), cmd, 0.0, None) == 0  # a planner without the rule


def test_the_way_is_measured_along_the_command_in_the_world():
    """The command is in the heading frame: at a yaw of 90 degrees forward is +y in the world."""
    config, cmd, yaw = IdleConfig(), np.array([0.05, 0.0]), math.pi / 2
    way = 0.05 * STEP_S
    north, east = StallWatch(STEP_S), StallWatch(STEP_S)
    for k in range(1, 5):
        assert north.count(np.array([0.0, k * way, 0.0]), cmd, yaw, config) == 0
        assert east.count(np.array([k * way, 0.0, 0.0]), cmd, yaw, config) == k - 1


def test_a_plan_is_stalled_after_stall_plans_still_plans():
    config = IdleConfig(stall_plans=3)
    assert [stalled(n, config) for n in range(6)] == [False, False, False, False, True, True]
    assert not stalled(100, IdleConfig(stall_plans=0)) and not stalled(100, None)


@pytest.mark.parametrize("value", [-1, 1.5, True, None])
def test_bad_stall_plans_name_their_field(value):
    with pytest.raises(ValueError, match="IdleConfig.stall_plans must be an integer >= 0"):
        IdleConfig(stall_plans=value)


@pytest.mark.parametrize("value", [-0.1, float("nan"), float("inf")])
def test_bad_stall_share_names_its_field(value):
    with pytest.raises(ValueError, match="IdleConfig.stall_speed_share must be a finite number >= 0"):
        IdleConfig(stall_speed_share=value)


@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
@pytest.mark.parametrize("terrain_name", ["flat", "random", "random_heights"])
def test_a_stalled_plan_steps_and_moves_and_any_other_plans_as_before(robot, gait, terrain_name):
    """Against the same planner with the rule off, on the shipped model, with a moving command: up to
    ``stall_plans`` still plans the plans are the same step for step; beyond, the first step does not stand, and on
    terrain of one level it is no useless swing unless the rule-free plan's is and nothing that moves is safe (the
    walk's network stands at many of these states: some first steps change)."""
    model = make_planner("contactnet", gait, robot, model=model_path("solo12", gait.name)).model
    terrain = flat() if terrain_name == "flat" else resolve(terrain_name, removed=80, seed=1)
    rule = ContactNetPlanner(gait, robot.description, model)
    plain = ContactNetPlanner(gait, robot.description, model, idle=dataclasses.replace(DEFAULT_IDLE, stall_plans=0))
    changed = 0
    for ctx in planning_contexts(gait, terrain, robot.description, 40, seed=5):
        ctx = dataclasses.replace(ctx, vel_cmd_xy=np.array([0.05, 0.0]))
        before = plain.plan(ctx)
        for still in range(DEFAULT_IDLE.stall_plans + 1):
            for a, b in zip(rule.plan(dataclasses.replace(ctx, still_plans=still)), before, strict=True):
                assert (a.legs, a.action_index, a.rank) == (b.legs, b.action_index, b.rank)
                np.testing.assert_array_equal(a.footholds_xy_world, b.footholds_xy_world)
        after = rule.plan(dataclasses.replace(ctx, still_plans=DEFAULT_IDLE.stall_plans + 1))
        feet = np.asarray(ctx.foot_pos_world)[:, :2]
        assert after[0].legs != ()
        if len(terrain.levels) == 1 and not terrain.sloped:
            moved = not useless_swing(after[0].legs, after[0].footholds_xy_world, feet, DEFAULT_IDLE.min_swing_m)
            # a useless first step only where nothing that moves is safe: the rule-free plan's own step
            assert moved or (after[0].action_index, after[0].rank) == (before[0].action_index, before[0].rank)
        changed += after[0].action_index != before[0].action_index
    assert changed > 0 or gait is TROT  # the shipped trot has no stand output and rarely swings in place here


class _Stander:
    """A planner that always stands, and keeps the stall count of each context it sees."""

    name = "stander"
    last_candidates = None

    def __init__(self, gait, idle):  # noqa: ANN001
        self.gait, self.idle, self.seen = gait, idle, []

    def reset(self) -> None:
        self.seen.clear()

    def plan(self, ctx):  # noqa: ANN001, ANN201
        self.seen.append(ctx.still_plans)
        return standing_horizon(self.gait, self.gait.steps_per_plan)


def test_the_loop_counts_the_plans_of_a_robot_that_does_not_follow_its_command(robot):
    """A robot that only stands follows a forward command for a while (the optimizer moves its CoM over the feet
    toward the support's front), then stops: the loop hands its plans 1, 2, 3, ... from then on (each count one more
    than the last, or 0 when the CoM moved on); with a zero command, or a planner without the idle rule, always 0."""
    for cmd, idle, expect_counting in (((0.05, 0.0), DEFAULT_IDLE, True), ((0.0, 0.0), DEFAULT_IDLE, False),
                                       ((0.05, 0.0), None, False)):
        stander = _Stander(WALK, idle)
        with Locomotion(robot, flat(), WALK, stander, SimConfig(), vel_cmd_xy=cmd) as loco:
            summary = loco.run(8.0, stop_at_goal=False)
            seen = list(stander.seen)
        assert not summary["fell"] and len(seen) >= 20
        assert all(b in (0, a + 1) for a, b in zip(seen, seen[1:], strict=False)), seen
        assert (max(seen) >= DEFAULT_IDLE.stall_plans) == expect_counting, seen
        assert summary["stall_plans"] == sum(stalled(n, idle) for n in seen)  # simulate --json's count


@pytest.mark.slow
def test_a_walking_robot_is_never_counted_as_stalled(robot):
    """Solo12's walk with the shipped model at 0.05 m/s on flat ground, 8 s: its CoM follows the command, so no plan
    after the first few counts more than a plan or two still (the rule never acts)."""
    planner = make_planner("contactnet", WALK, robot, model=model_path("solo12", "walk"))
    seen = []
    plan = planner.plan

    def watching(ctx):  # noqa: ANN001, ANN202
        seen.append(ctx.still_plans)
        return plan(ctx)

    planner.plan = watching
    from contactnet.locomotion import LocomotionConfig

    with Locomotion(robot, flat(), WALK, planner, SimConfig(), config=LocomotionConfig(observer=DEFAULT_OBSERVER),
                    vel_cmd_xy=(0.05, 0.0)) as loco:
        summary = loco.run(8.0, stop_at_goal=False)
    assert not summary["fell"] and len(seen) > 15
    assert max(seen[5:]) <= DEFAULT_IDLE.stall_plans, seen


@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
def test_a_stalled_plans_first_step_is_the_first_safe_step_along_the_command(robot, gait):
    """Every foot on the landing cell of the best-ranked action moving its leg (a model of fixed scores), so that the
    ranking's first safe step often goes nowhere: a stalled plan's first step is, as a reference walking the ranking
    says, the first safe step whose swinging feet move 2 cm or more along the command on average (with the room for
    the roll among those, in its swing group), the first step that moves them at all where none does, else the
    ranking's first."""
    action_legs, action_cells = gait.action_cells
    replaced = 0
    for seed in range(3):
        model = FixedScores(gait, seed)
        planner = ContactNetPlanner(gait, robot.description, model, reach=None)
        terrain = resolve("random", removed=100, seed=seed)
        order = np.argsort(-model.scores(None), kind="stable")
        for ctx in planning_contexts(gait, terrain, robot.description, 30, seed=6):
            to_world, cells = _feet_on_best_cells(ctx, planner, order)
            plain = planner.plan(ctx)[0]
            stalled_step = planner.plan(dataclasses.replace(ctx, still_plans=DEFAULT_IDLE.stall_plans + 1))[0]
            room = roll_ahead_xy(robot.description.foot_radius_m, to_world @ ctx.vel_cmd_xy, planner.roll)
            expected = _stalled_reference(planner, terrain, order, cells, np.asarray(ctx.foot_pos_world)[:, :2],
                                          to_world @ np.array([1.0, 0.0]), np.array(room), plain)
            assert stalled_step.action_index == expected
            assert stalled_step.rank == list(order).index(expected)
            replaced += stalled_step.action_index != plain.action_index
    assert replaced > 5


def _feet_on_best_cells(ctx, planner, order, terrain=None):  # noqa: ANN001, ANN202
    """Walk along +x at 0.05 m/s (the velocity on the command: no capture step) with every foot on the landing cell
    of the best-ranked action (``order``) moving its leg, on its top when ``terrain`` is given; (heading -> world
    rotation, the (4, cells per leg, 2) candidate grid)."""
    gait = planner.gait
    action_legs, action_cells = gait.action_cells
    ctx.vel_cmd_xy[:] = [0.05, 0.0]
    c, s = math.cos(ctx.yaw_rad), math.sin(ctx.yaw_rad)
    to_world = np.array([[c, -s], [s, c]])
    ctx.com_vel_world[:2] = to_world @ ctx.vel_cmd_xy
    cells = (np.asarray(ctx.base_xy_world) + planner.hip_ref_xy_base @ to_world.T)[:, None, :] + (
        gait.cell_offsets_xy @ to_world.T)[None]
    placed = set()
    for action in order:
        for leg, cell in zip(action_legs[action], action_cells[action], strict=True):
            if leg not in placed:
                ctx.foot_pos_world[leg, :2] = cells[leg, cell]
                if terrain is not None:
                    ctx.foot_pos_world[leg, 2] = terrain.ground_z(cells[leg, cell][None])[0] + planner.robot.foot_radius_m
                placed.add(int(leg))
    return to_world, cells


def _stalled_reference(planner, terrain, order, cells, feet, forward, room, plain):  # noqa: ANN001, ANN202
    """The stalled first step's action, by walking the ranking ``order``: the plain first step ``plain`` if it goes
    along ``forward``, else the first safe action that does (then, in its swing group, the first that also has the
    ``room`` ahead), else the same with "moves at all" where ``plain`` is a useless swing, else ``plain``'s."""
    gait = planner.gait
    action_legs, action_cells = gait.action_cells

    def points(action: int) -> np.ndarray:
        return cells[action_legs[action], action_cells[action]]

    def safe(action: int, shift: np.ndarray) -> bool:
        landing = points(action)
        return bool(terrain.is_safe(landing, planner.margin_m).all()
                    and terrain.is_safe(landing + shift, planner.margin_m).all())

    def goes(action: int) -> bool:
        return float(((points(action) - feet[action_legs[action]]) @ forward).mean()) >= DEFAULT_IDLE.min_swing_m

    def moves(action: int) -> bool:
        return bool((np.hypot(*(points(action) - feet[action_legs[action]]).T) >= DEFAULT_IDLE.min_swing_m).any())

    if goes(plain.action_index):
        return plain.action_index
    rules = [goes]
    if useless_swing(plain.legs, plain.footholds_xy_world, feet, DEFAULT_IDLE.min_swing_m):
        rules.append(moves)
    for rule in rules:
        first = next((int(a) for a in order if rule(a) and safe(a, np.zeros(2))), None)
        if first is not None:
            group = first // gait.actions_per_group
            return next((int(a) for a in order if a // gait.actions_per_group == group and rule(a) and safe(a, room)),
                        first)
    return plain.action_index


@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
def test_a_stalled_plans_first_step_on_heights_is_the_first_usable_step_along_the_command(robot, gait):
    """On terrain with heights (the random field with heights; a model of fixed scores, every foot on the cell of the
    best-ranked action moving its leg, so that the first usable step often goes nowhere): a stalled plan's first step
    is the plain plan's first step when its feet move 2 cm or more along the command on average, else, as a reference
    walking the ranking says (safe with the planner's margin, and usable by its height checks), the first usable step
    that does, else the plain one. Go2's walk stood on its field with heights until the time limit (seeds 7, 13) without this."""
    from contactnet.planning.footholds import FootholdChecker

    action_legs, action_cells = gait.action_cells
    replaced = compared = 0
    for seed in range(3):
        model = FixedScores(gait, seed)
        planner = ContactNetPlanner(gait, robot.description, model, reach=None)
        terrain = resolve("random_heights", removed=80, seed=seed)
        checker = FootholdChecker(robot.description, planner.footholds.checks)
        order = np.argsort(-model.scores(None), kind="stable")
        for ctx in planning_contexts(gait, terrain, robot.description, 20, seed=6):
            to_world, cells = _feet_on_best_cells(ctx, planner, order, terrain)
            plain = planner.plan(ctx)[0]
            stalled_ctx = dataclasses.replace(ctx, still_plans=DEFAULT_IDLE.stall_plans + 1)
            stalled_step = planner.plan(stalled_ctx)[0]
            if planner._heights_walk.cornered is not None or not plain.legs:  # a cornered leg's own ranking
                continue
            check, feet = planner.last_candidates.check, np.asarray(ctx.foot_pos_world)[:, :2]
            forward = to_world @ np.array([1.0, 0.0])

            def moves(legs, points, feet=feet, forward=forward):  # noqa: ANN001, ANN202
                return float(np.mean((np.asarray(points) - feet[list(legs)]) @ forward)) >= DEFAULT_IDLE.min_swing_m

            expected = plain.action_index
            if not moves(plain.legs, plain.footholds_xy_world):
                for action in order:
                    legs = np.asarray(action_legs[action])
                    points = checker.centred(terrain, cells[legs, action_cells[action]])
                    if moves(legs, points) and terrain.is_safe(points, planner.margin_m).all() and check(legs, points).all():
                        expected = int(action)
                        break
            compared += 1
            assert stalled_step.action_index == expected
            replaced += stalled_step.action_index != plain.action_index
    assert compared > 20 and replaced > 3
