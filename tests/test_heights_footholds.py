"""Issue 13, items 2 and 3 (planning side): footholds and swings on terrain with heights.

The height checks of candidate footholds (``contactnet.planning.footholds``), the swing over the tops on its way
(``contactnet.motion.swing``), the support height and body pitch (``contactnet.motion.ground``), and the ContactNet
planner using them on the shipped stairs while a flat terrain keeps today's plan."""

from __future__ import annotations

import numpy as np
import pytest

from contactnet.bench.planner import planning_contexts
from contactnet.motion.controller import SwingTrajectory
from contactnet.motion.gait import TROT, WALK
from contactnet.motion.ground import PITCH_SHARE, body_pitch, front_to_hind_m, support_height
from contactnet.motion.swing import STEP_FRACTION, swing_over_terrain
from contactnet.planning.footholds import FootholdChecker, HeightChecks, path_top_z
from contactnet.planning.planner import ContactNetPlanner, PlanningContext
from contactnet.terrain import Terrain, flat, random_field, resolve

FL, FR, HL, HR = range(4)


@pytest.fixture(scope="module")
def stairs() -> Terrain:
    return resolve("stairs")  # risers of 5 cm at x 0.25, 0.45, 0.65 (up), 1.05, 1.25, 1.45 (down)


@pytest.fixture(scope="module")
def checker(robot) -> FootholdChecker:
    return FootholdChecker(robot.description)


def evaluate(checker, terrain, leg, landing_x, liftoff_x, hip_x, tops, y=0.1, sideways=0.0):
    """The checks of one landing at (landing_x, y) for ``leg`` lifting off at (liftoff_x, y), the feet on ``tops``;
    the foot ``sideways`` (m, +y) of its leg's plane (the hip where that puts it)."""
    hip_y = y - sideways - checker.legs.plane_left_m[leg]
    result = checker.evaluate(terrain, np.array([leg]), np.array([[landing_x, y]]), np.array([[liftoff_x, y]]),
                              np.array([[hip_x, hip_y]]), np.asarray(tops, dtype=float), 0.0)
    return {name: bool(value[0]) for name, value in result.items()}


def test_only_terrain_with_heights_is_checked(checker, stairs):
    assert not checker.applies(flat()) and not checker.applies(random_field(80, 0))
    assert not checker.applies(resolve("stepping_stones")) and checker.applies(stairs)
    assert checker.applies(resolve("raised_stones"))


def test_leg_geometry_comes_from_the_robot(checker, robot):
    legs = checker.legs
    # Thigh and shank in the leg's plane: together about the straight leg (which includes a small sideways offset).
    assert np.all(legs.thigh_m + legs.shank_m <= robot.description.leg_reach_m)
    np.testing.assert_allclose(legs.thigh_m + legs.shank_m, robot.description.leg_reach_m, atol=0.01)
    # Solo12: front knees point backward, hind knees forward.
    np.testing.assert_array_equal(legs.knee_side, [-1, -1, 1, 1])
    # Level body: every hip at the CoM height plus the nominal hip-above-CoM offset.
    hips = legs.hip_heights(0.3, 0.0)
    assert np.allclose(hips, hips[0]) and hips[0] == pytest.approx(0.3 + robot.description.hip_pos_base[0, 2]
                                                                   - robot.description.com_base_standing[2])
    front, hind = legs.hip_heights(0.3, -0.1)[[FL, HL]]  # nose up: the front hips higher
    assert front > hind
    # Over the tops of the feet: the nominal CoM height over their mean, pitched with them.
    np.testing.assert_allclose(legs.hips_over_tops(np.zeros(4)), legs.hip_heights(robot.description.com_height_nominal_m,
                                                                                   0.0))
    up = legs.hips_over_tops(np.array([0.1, 0.1, 0.0, 0.0]))  # front feet 10 cm up: the CoM 5 cm, pitched half-way
    expected = [0.05 + PITCH_SHARE * 0.05, 0.05 - PITCH_SHARE * 0.05]
    np.testing.assert_allclose(up[[FL, HL]] - legs.hips_over_tops(np.zeros(4))[[FL, HL]], expected, atol=3e-3)


def test_a_hind_foot_keeps_its_shin_off_the_riser_ahead(checker, stairs):
    """A hind leg's knee points forward: its shin slants over the ground ahead of the foot. Right behind the
    first riser (x 0.25, 5 cm) the shin would rest on its edge (the fall of issue 13 before this work)."""
    tops = [0.05, 0.0, 0.0, 0.0]  # one front foot already up
    near = evaluate(checker, stairs, HL, 0.22, 0.15, 0.20, tops)
    far = evaluate(checker, stairs, HL, 0.12, 0.05, 0.12, tops)
    assert near["top"] and near["reach"] and near["step"] and not near["leg"]
    assert all(far.values()), far
    # A front leg's knee points backward: the same spot is fine for its shin (nothing higher behind it).
    assert evaluate(checker, stairs, FL, 0.22, 0.15, 0.17, tops)["leg"]


def test_a_front_foot_stepping_down_lands_clear_of_the_edge_behind(checker, stairs):
    """Going down (edge at x 1.05 from 0.15 to 0.10): the front shin slants back over the edge, so the front
    foot lands well past it."""
    tops = [0.15, 0.15, 0.15, 0.15]
    assert not evaluate(checker, stairs, FL, 1.07, 1.00, 1.03, tops)["leg"]
    assert all(evaluate(checker, stairs, FL, 1.14, 1.04, 1.12, tops).values())


def test_the_ball_the_step_height_and_the_reach(checker, stairs):
    tops = np.zeros(4)
    # The ball's side against the riser: 1.2 cm from the wall of the next tread, on the lower one.
    assert not evaluate(checker, stairs, FL, 0.238, 0.15, 0.2, tops)["ball"]
    # Three risers in one step: more than the swing can clear.
    assert not evaluate(checker, stairs, FL, 0.70, 0.20, 0.45, tops)["step"]
    assert evaluate(checker, stairs, FL, 0.34, 0.20, 0.30, tops)["step"]
    # Far beyond the leg's reach from the hip.
    assert not evaluate(checker, stairs, FL, 0.45, 0.20, 0.15, tops)["reach"]
    # No top at all (off the stairs' side).
    assert not evaluate(checker, stairs, FL, 0.34, 0.20, 0.30, tops, y=0.3)["top"]


def test_a_foot_far_sideways_from_its_leg_plane(checker, stairs, robot):
    """The leg's plane is where its foot stands in the nominal stance (Solo12: 4.55 cm outside the hip joint).
    Within ``max_lean_m`` of it a foot is checked as usual. Further, the leaning leg sweeps its shin over the
    ground beside the foot: allowed only where that ground is no higher than the foot's top, and never on a
    small top (a 5 cm square: the shin passes over its edge)."""
    description = robot.description
    np.testing.assert_allclose(checker.legs.plane_left_m,
                               description.foot_nominal_base[:, 1] - description.hip_pos_base[:, 1])
    tops = np.zeros(4)
    limit = checker.checks.max_lean_m
    for leg in (FL, HR):
        for sideways in (0.8 * limit, -0.8 * limit, 2.0 * limit, -2.0 * limit):  # a tread: flat beside the foot
            assert evaluate(checker, stairs, leg, 0.34, 0.20, 0.30, tops, sideways=sideways)["reach"], sideways
    # A stone 4 cm up beside the foot, on the side toward the leg's plane (+y for a left leg).
    beside = Terrain.from_dict({"name": "beside", "start": [0, 0], "goal_x": 0.5, "regions": [
        {"shape": "rect", "center": [0.0, 0.0], "size": [1.0, 1.0]},
        {"shape": "rect", "center": [0.3, 0.16], "size": [0.1, 0.04], "z": 0.04}]})
    assert evaluate(checker, beside, FL, 0.3, 0.2, 0.28, tops, y=0.1, sideways=-0.8 * limit)["reach"]
    assert not evaluate(checker, beside, FL, 0.3, 0.2, 0.28, tops, y=0.1, sideways=-2.0 * limit)["reach"]
    assert evaluate(checker, beside, FL, 0.3, 0.2, 0.28, tops, y=0.1, sideways=2.0 * limit)["reach"]  # the other way
    # On a small top: within the limit only.
    field = resolve("random_heights", removed=0, seed=0)
    square = field.top_parts().centres_xy[np.argmin(np.abs(field.top_parts().centres_xy - [0.6, 0.1]).sum(axis=1))]
    z = float(field.height_at(square))
    on_square = dict(y=square[1], tops=[z, z, z, z])
    assert evaluate(checker, field, FL, square[0], square[0] - 0.1, square[0] - 0.02, sideways=0.8 * limit,
                    **on_square)["reach"]
    assert not evaluate(checker, field, FL, square[0], square[0] - 0.1, square[0] - 0.02, sideways=2.0 * limit,
                        **on_square)["reach"]


def test_candidates_on_a_small_top_go_to_its_centre(checker, stairs):
    field = resolve("random_heights", removed=80, seed=3)
    parts = field.top_parts()
    squares = parts.inradius_m < 0.04
    np.testing.assert_allclose(parts.inradius_m[squares], 0.025, atol=1e-3)  # the 5 cm squares
    rng = np.random.default_rng(0)
    points = rng.uniform([0.3, -0.24], [1.7, 0.24], (400, 2))
    moved = checker.centred(field, points)
    part = parts.part_at(points)
    on_square = (part >= 0) & squares[np.maximum(part, 0)]
    assert on_square.sum() > 200 and (part == -1).sum() > 20  # squares and holes both sampled
    # On a square (or squares at one height side by side): its centre, 2.5 cm from every edge, on the same top;
    # elsewhere unchanged.
    np.testing.assert_allclose(moved[on_square], parts.centres_xy[part[on_square]])
    assert field.is_safe(moved[on_square], 0.024).all()
    np.testing.assert_allclose(field.height_at(moved[on_square]), field.height_at(points[on_square]))
    np.testing.assert_array_equal(moved[~on_square], points[~on_square])
    # Stair treads are big: nothing moves.
    tread_points = np.array([[0.3, 0.0], [0.34, 0.1], [0.9, -0.05]])
    np.testing.assert_array_equal(checker.centred(stairs, tread_points), tread_points)


def test_top_parts_take_the_highest_top_where_they_meet():
    terrain = Terrain.from_dict({"name": "t", "start": [0, 0], "goal_x": 0.5, "regions": [
        {"shape": "rect", "center": [0.0, 0.0], "size": [0.4, 0.4]},
        {"shape": "rect", "center": [0.1, 0.0], "size": [0.04, 0.04], "z": 0.03}]})
    parts = terrain.top_parts()
    points = np.array([[0.1, 0.0], [-0.1, 0.0], [0.5, 0.5], [np.nan, 0.0]])
    part = parts.part_at(points)
    assert parts.tops_z[part[0]] == 0.03 and parts.tops_z[part[1]] == 0.0 and list(part[2:]) == [-1, -1]
    np.testing.assert_allclose(parts.centres_xy[part[0]], [0.1, 0.0], atol=1e-3)
    assert parts.inradius_m[part[0]] == pytest.approx(0.02, abs=1e-3)


def test_path_top_is_the_highest_top_on_the_way(stairs):
    tops = path_top_z(stairs, np.array([[0.1, 0.0], [0.1, 0.0]]), np.array([[0.5, 0.0], [0.2, 0.0]]))
    np.testing.assert_allclose(tops, [0.1, 0.0])


def test_support_height_and_pitch(robot, stairs):
    feet = np.array([[0.35, 0.1], [0.35, -0.1], [0.0, 0.1], [0.0, -0.1]])  # front feet one riser up
    assert support_height(stairs, feet) == pytest.approx(0.025)
    assert support_height(flat(), feet) == 0.0
    length = front_to_hind_m(robot.description.foot_nominal_base)
    assert length == pytest.approx(2 * robot.description.foot_nominal_base[0, 0])
    assert body_pitch(np.array([0.05, 0.05, 0.0, 0.0]), length) < 0  # nose up
    assert body_pitch(np.zeros(4), length) == 0.0


def test_swing_up_a_riser_clears_its_edge(stairs):
    r = 0.016
    start, end = np.array([0.15, 0.1, r]), np.array([0.33, 0.1, 0.05 + r])
    swing = swing_over_terrain(stairs, start, end, 1.0, 1.16, 0.05, r)
    assert swing.apex_z == pytest.approx(0.05 + r + 0.05)
    assert swing.liftoff_fraction >= STEP_FRACTION and swing.touchdown_fraction == 0
    for t in np.linspace(1.0, 1.16, 161):  # the ball never dips into the upper tread before landing
        pos = swing.sample(t)[0]
        if pos[0] >= 0.25 - r:
            assert pos[2] >= 0.05 + r - 1e-9
    # Level path: exactly today's swing.
    level = swing_over_terrain(stairs, np.array([0.36, 0.1, 0.05 + r]), np.array([0.42, 0.1, 0.05 + r]), 1.0, 1.16,
                               0.05, r)
    plain = SwingTrajectory(start_world=level.start_world, end_world=level.end_world, t0_s=1.0, t1_s=1.16)
    assert level.liftoff_fraction == level.touchdown_fraction == 0.0
    for t in np.linspace(1.0, 1.16, 9):
        np.testing.assert_array_equal(level.sample(t)[0], plain.sample(t)[0])
    # Close to the riser (2.5 cm, the least the planner allows), a long step rises longer before it moves.
    close = swing_over_terrain(stairs, np.array([0.225, 0.1, r]), np.array([0.42, 0.1, 0.05 + r]), 1.0, 1.16, 0.05, r)
    assert close.liftoff_fraction >= STEP_FRACTION and close.touchdown_fraction == 0
    for t in np.linspace(1.0, 1.16, 161):  # over the edge with the clearance, never into the upper tread
        pos = close.sample(t)[0]
        if abs(pos[0] - 0.25) <= r:
            assert pos[2] >= 0.05 + r + 0.015 - 1e-9
        elif pos[0] > 0.25:
            assert pos[2] >= 0.05 + r - 1e-9
    # Stepping down past an edge: the foot lands near-vertically, and leaves without waiting.
    down = swing_over_terrain(stairs, np.array([1.00, 0.1, 0.15 + r]), np.array([1.14, 0.1, 0.10 + r]), 1.0, 1.16,
                              0.05, r)
    assert down.touchdown_fraction >= STEP_FRACTION and down.liftoff_fraction == 0
    # Over a taller top between two lower ones the apex rises above it.
    over = swing_over_terrain(stairs, np.array([0.40, 0.1, 0.05 + r]), np.array([0.60, 0.1, 0.10 + r]), 1.0, 1.16,
                              0.05, r)
    assert over.apex_z >= 0.10 + r + 0.05 - 1e-12


class _Ranked:
    """A stand-in model: every action scored by a fixed random permutation (checks do not need a trained net)."""

    def __init__(self, gait, seed: int) -> None:
        self.gait, self.n_actions, self.path = gait.name, gait.n_actions, "<ranked>"
        self._scores = np.random.default_rng(seed).permutation(gait.n_actions).astype(float)

    def scores(self, u):
        return self._scores


def _stairs_context(robot, gait, terrain, x0: float) -> PlanningContext:
    """Standing on the stairs with the base at x0 (feet at their nominal places, on whatever top is there)."""
    desc = robot.description
    feet = desc.foot_nominal_base.copy()
    feet[:, 0] += x0
    feet[:, 2] = terrain.ground_z(feet[:, :2]) + desc.foot_radius_m
    return PlanningContext(
        com_pos_world=np.array([x0, 0.0, support_height(terrain, feet[:, :2]) + desc.com_height_nominal_m]),
        com_vel_world=np.array([0.05, 0.0, 0.0]), yaw_rad=0.0, foot_pos_world=feet,
        hip_ref_xy_base=desc.foot_nominal_base[:, :2], base_xy_world=np.array([x0, 0.0]),
        vel_cmd_xy=np.array([0.05, 0.0]), terrain=terrain, gait=gait, com_height_ref_m=desc.com_height_nominal_m)


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_planner_on_stairs_takes_only_usable_footholds(robot, checker, stairs, gait):
    """Whatever the ranking, every foothold the planner takes on the stairs passes the height checks, and the
    candidate view marks the cells that fail them as unsafe."""
    rejected = 0
    for seed in range(4):
        planner = ContactNetPlanner(gait, robot.description, _Ranked(gait, seed))
        for x0 in (0.0, 0.08, 0.30, 0.55, 0.95, 1.10):
            ctx = _stairs_context(robot, gait, stairs, x0)
            step = planner.plan(ctx)[0]
            if step.action_index is None:
                continue
            legs = np.array(step.legs)
            hips_xy = ctx.base_xy_world + robot.description.hip_pos_base[legs, :2] + 0.05 * 0.28 * np.array([1.0, 0])
            tops = stairs.ground_z(ctx.foot_pos_world[:, :2])
            assert checker.usable(stairs, legs, step.footholds_xy_world, ctx.foot_pos_world[legs, :2], hips_xy, tops,
                                  0.0).all()
            view = planner.last_candidates
            safe_only = stairs.is_safe(view.xy_world, planner.margin_m)
            assert not (view.safe & ~safe_only).any()  # the view's safe cells are safe ...
            rejected += int((safe_only & ~view.safe).sum())  # ... and some safe cells fail the height checks
    assert rejected > 0


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_single_height_terrain_plans_as_before(robot, gait):
    """A terrain with one level takes the flat-ground path: the same plan as with every height check off."""
    terrain = random_field(100, 0)
    model = _Ranked(gait, 1)
    planner = ContactNetPlanner(gait, robot.description, model)
    unchecked = ContactNetPlanner(gait, robot.description, model)
    unchecked.footholds = FootholdChecker(robot.description, HeightChecks(max_step_m=-1.0))  # would reject all
    for ctx in planning_contexts(gait, terrain, robot.description, 20, seed=3):
        a, b = planner.plan(ctx), unchecked.plan(ctx)
        for x, y in zip(a, b, strict=True):
            assert x.legs == y.legs and x.action_index == y.action_index
            np.testing.assert_array_equal(x.footholds_xy_world, y.footholds_xy_world)


def test_a_cornered_hind_leg_swings_first(robot, checker, stairs):
    """A hind foot 4 cm behind the first riser with the body moving on over it: its shin would reach the edge,
    so it is *cornered*, and whatever the network prefers the walk swings that leg next."""
    ctx = _stairs_context(robot, WALK, stairs, 0.40)  # front feet on the second tread, hind ones on the ground
    feet = ctx.foot_pos_world.copy()
    feet[HL, 0], feet[HR, 0] = 0.21, 0.30  # HL 4 cm behind the first riser, HR up on the first tread
    tops = stairs.ground_z(feet[:, :2])
    feet[:, 2] = tops + robot.description.foot_radius_m
    hips_ahead = ctx.base_xy_world + robot.description.hip_pos_base[:, :2] + np.array([0.03, 0.0])
    clear = checker.stance_clear(stairs, feet[:, :2], tops, hips_ahead, 0.0)
    np.testing.assert_array_equal(clear, [True, True, False, True])
    cornered = PlanningContext(**{**ctx.__dict__, "foot_pos_world": feet})
    swung = set()
    for seed in range(6):
        step = ContactNetPlanner(WALK, robot.description, _Ranked(WALK, seed)).plan(cornered)[0]
        swung.add(step.legs)
    assert swung == {(HL,)}


def _raised_stones_trap(terrain, desc) -> PlanningContext:  # noqa: ANN001
    """The traced state of the raised stones' trap (docs/results.md "A cornered leg steps forward")."""
    feet = np.array([[1.151, 0.109, 0.0], [1.357, -0.091, 0.0], [0.872, 0.097, 0.0], [0.836, -0.143, 0.0]])
    feet[:, 2] = terrain.ground_z(feet[:, :2]) + desc.foot_radius_m
    return PlanningContext(
        com_pos_world=np.array([1.08, 0.0, support_height(terrain, feet[:, :2]) + desc.com_height_nominal_m]),
        com_vel_world=np.array([0.05, 0.0, 0.0]), yaw_rad=0.0, foot_pos_world=feet,
        hip_ref_xy_base=desc.foot_nominal_base[:, :2], base_xy_world=np.array([1.08, 0.0]),
        vel_cmd_xy=np.array([0.05, 0.0]), terrain=terrain, gait=WALK, com_height_ref_m=desc.com_height_nominal_m)


def test_a_cornered_leg_is_not_promoted_to_step_in_place(robot, monkeypatch):
    """The raised stones' trap (traced, docs/results.md "A cornered leg steps forward"): the hind-right foot on the low
    disc (top -6 cm) 14 cm behind the 12 cm riser of the next stone, the body moving on over it. The leg is cornered,
    but no landing it can reach yet is on that stone: with steps up to 1 cm back promoted (the rule before) the walk
    steps it in place whatever the network prefers, and it stays cornered; with ``CORNERED_MIN_PROGRESS_M`` asked
    forward no such step is promoted (and the grid a cell further on then steps it onto the stone: the next test)."""
    import contactnet.planning.cornered as cornered_module

    terrain, desc = resolve("raised_stones", seed=0), robot.description
    ctx = _raised_stones_trap(terrain, desc)
    feet = ctx.foot_pos_world

    def first_steps() -> list[tuple[tuple[int, ...], float]]:
        steps = []
        for seed in range(4):
            planner = ContactNetPlanner(WALK, desc, _Ranked(WALK, seed))
            step = planner.plan(ctx)[0]
            assert planner._heights_walk.cornered.tolist() == [False, False, False, True]
            steps.append((step.legs, float(step.footholds_xy_world[0][0] - feet[step.legs[0], 0])))
        return steps

    def in_place(steps: list[tuple[tuple[int, ...], float]]) -> int:
        return sum(legs == (HR,) and abs(progress) < 0.01 for legs, progress in steps)

    assert in_place(first_steps()) <= 1  # (one of the four rankings puts that step first itself)
    monkeypatch.setattr(cornered_module, "CORNERED_MIN_PROGRESS_M", -0.01)
    assert in_place(first_steps()) == 4


def test_a_cornered_leg_with_no_step_forward_gets_its_grid_a_cell_further_on(robot, monkeypatch):
    """The same trap: the stone in front of the cornered hind-right foot lies just beyond its candidate grid, so no
    ranking can step it forward and the thigh's window passes (the raised stones' fall at x = 1.0 m). The first step
    is then planned again on the grid one cell (5 cm) along the heading, and taken because it moves that leg: every
    ranking steps it up onto the stone. Without the shift (0 cells) none does."""
    import contactnet.planning.cornered as cornered_module

    terrain, desc = resolve("raised_stones", seed=0), robot.description
    ctx = _raised_stones_trap(terrain, desc)
    feet = ctx.foot_pos_world

    def onto_the_stone() -> int:
        count = 0
        for seed in range(6):
            step = ContactNetPlanner(WALK, desc, _Ranked(WALK, seed)).plan(ctx)[0]
            rise = terrain.ground_z(step.footholds_xy_world)[0] - terrain.ground_z(feet[HR:, :2])[0]
            count += step.legs == (HR,) and step.footholds_xy_world[0][0] - feet[HR, 0] >= 0.1 and rise > 0.1
        return count

    assert onto_the_stone() == 6
    monkeypatch.setattr(cornered_module, "CORNERED_GRID_SHIFT_CELLS", 0)
    assert onto_the_stone() == 0


def test_a_swing_next_to_a_hole_onto_a_short_top_lands_vertically():
    """``swing_past_holes`` on terrain of one level: a swing from a platform across a gap onto a 3 cm bar (a top too
    short for the foot's roll) lands vertically, and the ball stays above the bar's top until it is over the bar,
    higher than the plain swing where it reaches the bar's edge; onto a 6 cm bar (with room) it is the plain swing,
    and so it is with a fraction 0 and with no command. A swing leaving a 3 cm bar across a gap lifts off vertically."""
    from contactnet.motion.swing import swing_past_holes
    from contactnet.planning.roll import short_top_test

    r, cmd = 0.016, np.array([0.05, 0.0])
    for width in (0.03, 0.06):
        terrain = Terrain.from_dict({"name": "bar", "start": [0.0, 0.0], "goal_x": 1.0, "regions": [
            {"shape": "rect", "center": [0.1, 0.0], "size": [0.4, 0.5]},  # to x = 0.30
            {"shape": "rect", "center": [0.50 + width / 2, 0.0], "size": [width, 0.5]}]})  # from x = 0.50
        short = short_top_test(terrain, cmd, 0.0, r)
        assert short_top_test(terrain, np.zeros(2), 0.0, r) is None  # no command, no direction
        start, end = np.array([0.20, 0.1, r]), np.array([0.516, 0.1, r])
        across = swing_past_holes(terrain, start, end, 1.0, 1.2, 0.05, r, 0.2, short)
        plain = swing_past_holes(terrain, start, end, 1.0, 1.2, 0.05, r, 0.0, short)
        assert (plain.liftoff_fraction, plain.touchdown_fraction) == (0.0, 0.0)
        assert swing_past_holes(terrain, start, end, 1.0, 1.2, 0.05, r, 0.2, None).touchdown_fraction == 0
        in_gap = swing_past_holes(terrain, start, np.array([0.45, 0.1, r]), 1.0, 1.2, 0.05, r, 0.2, short)
        assert in_gap.touchdown_fraction == 0  # a foot put into the gap itself: the plain swing
        if width > 0.03:
            assert (across.liftoff_fraction, across.touchdown_fraction) == (0.0, 0.0)
            continue
        assert (across.liftoff_fraction, across.touchdown_fraction) == (0.0, 0.2)
        for t in np.linspace(1.0, 1.2, 201):
            pos = across.sample(t)[0]
            if 0.30 + r < pos[0] < 0.50:  # over the gap, short of the bar: above the bar's top level
                assert pos[2] >= r - 1e-9 and (pos[0] < 0.50 - r or pos[2] >= r + 0.01), (t, pos)
        assert across.height_at_progress(np.array([0.94]))[0] > plain.height_at_progress(np.array([0.94]))[0] + 0.01
        back = swing_past_holes(terrain, np.array([0.516, 0.1, r]), np.array([0.75, 0.1, r]), 1.0, 1.2, 0.05, r, 0.2,
                                short)
        assert back.liftoff_fraction == 0.2
