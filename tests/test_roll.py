"""The room for the foot's roll (contactnet.planning.roll): the allowance along the command, and the planner's
choice against the plan without it (the room checked by two plain lookups of ``Terrain.is_safe``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactnet.bench.planner import planning_contexts
from contactnet.frames import rotate_xy
from contactnet.motion.gait import TROT, WALK
from contactnet.planning.roll import DEFAULT_ROLL, RollConfig, roll_ahead_xy
from contactnet.registry import make_planner
from contactnet.terrain import random_field, resolve


def test_the_allowance_follows_the_command():
    radius = 0.016
    assert roll_ahead_xy(radius, (0.05, 0.0), DEFAULT_ROLL) == pytest.approx((0.012, 0.0))
    assert roll_ahead_xy(radius, (0.0, 0.0), DEFAULT_ROLL) is None  # standing: no direction
    assert roll_ahead_xy(radius, (0.05, 0.0), None) is None  # off
    assert roll_ahead_xy(radius, (0.05, 0.0), RollConfig(allowance_radii=0.0)) is None
    # along the command, 0.75 radii long whatever the speed
    back = roll_ahead_xy(radius, (-0.3, -0.3), DEFAULT_ROLL)
    assert back[0] == pytest.approx(back[1]) and back[0] < 0
    assert math.hypot(*back) == pytest.approx(0.012)
    with pytest.raises(ValueError, match="allowance_radii"):
        RollConfig(allowance_radii=float("nan"))


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_room_ahead_where_there_is_some_else_the_plain_margin(robot, gait):
    """On the random field the allowance moves some landings back from the edge ahead, keeping the legs the network
    chose; on the narrow stones (bars of 4-4.5 cm: often no cell with room) the plain choice stands."""
    roomy, plain = (make_planner("contactnet", gait, robot) for _ in range(2))
    plain.roll, roomy.roll = None, RollConfig(reseat=False)  # (a re-seat replaces a stand: below)
    moved = 0
    for terrain in (random_field(140, 5), resolve("narrow_stones")):
        for ctx in planning_contexts(gait, terrain, robot.description, 60, seed=2):
            a, b = roomy.plan(ctx)[0], plain.plan(ctx)[0]
            assert (a.action_index is None) == (b.action_index is None)
            if a.action_index is None or a.legs == ():
                continue
            ahead = roll_ahead_xy(robot.description.foot_radius_m,
                                  rotate_xy(np.asarray(ctx.vel_cmd_xy, dtype=float), ctx.yaw_rad), roomy.roll)
            has_room = ahead is None or terrain.is_safe(a.footholds_xy_world + np.array(ahead), roomy.margin_m).all()
            assert a.legs == b.legs  # the network's choice of legs stands; only their cells may move
            moved += a.action_index != b.action_index
            if not has_room:  # no action had room: the plain choice
                assert a.action_index == b.action_index
    assert moved > 0, "the allowance should change some choices"


def _bar_terrain(bar_width_m: float):
    """A platform to x = 0.3 m, a gap, and one bar from x = 0.40 m, ``bar_width_m`` wide, 0.5 m long."""
    from contactnet.terrain import Terrain

    return Terrain.from_dict({"name": "bar", "start": [0.0, 0.0], "goal_x": 1.0, "regions": [
        {"shape": "rect", "center": [0.0, 0.0], "size": [0.6, 0.5]},
        {"shape": "rect", "center": [0.40 + bar_width_m / 2, 0.0], "size": [bar_width_m, 0.5]}]})


def test_a_landing_without_room_slides_back_to_it_keeping_room_behind():
    """``slide_back``: on a 5 cm bar a landing 8 mm from the edge ahead (the margin) slides back to the first point
    with 12 mm of room (to 20 mm from the edge); on a 3 cm bar there is no such point with 8 mm of safe ground behind
    it, and it slides as far as that allows (16 mm from the bar's back edge: the margin and the room behind); a
    landing with the room, a step with no legs and a robot without a command stay."""
    from contactnet.planning.ranking import PlannedStep
    from contactnet.planning.roll import SLIDE_STEP_M, slide_back

    margin, ahead, most, behind = 0.008, (0.012, 0.0), 0.016, 0.008
    for width, expected_x in ((0.05, 0.45 - 0.020), (0.03, 0.40 + 0.016)):
        terrain = _bar_terrain(width)
        covers = terrain.safe_locator(margin).covers_xy
        at_edge = 0.40 + width - margin
        step = PlannedStep(legs=(0, 3), footholds_xy_world=np.array([[at_edge, 0.1], [0.0, -0.1]]))
        slid = slide_back(step, ahead, covers, most, behind)
        x, y = slid.footholds_xy_world[0]
        assert y == 0.1 and abs(x - expected_x) <= SLIDE_STEP_M + 1e-12, (width, x)
        assert covers(x, y) and covers(x - behind, y)
        assert covers(x + ahead[0], y) == (width == 0.05)
        assert slid.footholds_xy_world[1].tolist() == [0.0, -0.1]  # it had the room: it stays
        assert slid.legs == step.legs and step.footholds_xy_world[0, 0] == at_edge  # the step itself unchanged
        for unchanged in (slide_back(step, None, covers, most, behind), slide_back(step, ahead, covers, 0.0, behind),
                          slide_back(PlannedStep(legs=(), footholds_xy_world=np.zeros((0, 2))), ahead, covers, most,
                                     behind)):
            assert unchanged.footholds_xy_world.tolist() in (step.footholds_xy_world.tolist(), [])
    # landing 9 mm past the back edge of the 3 cm bar: no room behind, it stays
    terrain = _bar_terrain(0.03)
    step = PlannedStep(legs=(1,), footholds_xy_world=np.array([[0.409, 0.0]]))
    assert slide_back(step, ahead, terrain.safe_locator(margin).covers_xy, most, behind) is step


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_the_planner_slides_its_first_landing_back_on_the_same_cell(robot, gait):
    """With the slide (on by default) the planner makes the same choices as without it (legs and action); only a
    first step's landing point lacking the room may move, back against the command by at most a foot radius, on safe
    ground; on the narrow stones some do."""
    sliding, still = (make_planner("contactnet", gait, robot) for _ in range(2))
    still.roll = RollConfig(slide_back_radii=0.0)
    slid = 0
    for terrain in (random_field(140, 5), resolve("narrow_stones")):
        for ctx in planning_contexts(gait, terrain, robot.description, 60, seed=2):
            a, b = sliding.plan(ctx)[0], still.plan(ctx)[0]
            assert (a.legs, a.action_index, a.rank) == (b.legs, b.action_index, b.rank)
            shift = a.footholds_xy_world - b.footholds_xy_world
            if not np.any(shift):
                continue
            slid += 1
            command = rotate_xy(np.asarray(ctx.vel_cmd_xy, dtype=float), ctx.yaw_rad)
            assert np.all(shift @ command <= 0.0)
            assert np.all(np.hypot(*shift.T) <= robot.description.foot_radius_m + 1e-9)
            assert terrain.is_safe(a.footholds_xy_world, sliding.margin_m).all()
    assert slid > 0


def test_the_allowance_of_a_heading_command_is_the_rotated_command_s_to_the_bit():
    """``roll_ahead_heading`` (scalars, a plan's hot path) gives exactly ``roll_ahead_xy`` of ``rotate_xy``'s world
    command, bit for bit, over random headings and commands (the slide's landing points depend on it)."""
    from contactnet.planning.roll import roll_ahead_heading

    rng = np.random.default_rng(4)
    for k in range(20000):
        yaw = float(rng.uniform(-4.0, 4.0) if k % 2 else rng.normal(0.0, 0.05))
        cmd = np.array([rng.choice([0.05, rng.uniform(-0.3, 0.3)]), rng.choice([0.0, rng.uniform(-0.3, 0.3)])])
        assert roll_ahead_heading(0.016, cmd, yaw, DEFAULT_ROLL) == roll_ahead_xy(0.016, rotate_xy(cmd, yaw),
                                                                                  DEFAULT_ROLL), (yaw, cmd)


def test_a_plan_that_stands_first_puts_a_foot_rolled_to_the_edge_of_a_short_top_back_in():
    """``reseat_step``: a foot 3 mm from the front edge of a 3 cm bar (closer than the 8 mm margin, the edge ahead of
    the command; no point of the bar has the room) is lifted with its swing group and put back in, instead of a
    plan's first step that stands; not on a 6 cm bar (a top with room: the slide gives the room there), not a foot
    near the bar's back edge (its roll takes it away from that edge), not when the first step moves legs, not
    without a command."""
    from contactnet.planning.ranking import PlannedStep
    from contactnet.planning.roll import lacks_room, reseat_step

    margin, ahead, behind, reach = 0.008, (0.012, 0.0), 0.008, 0.032
    stand = PlannedStep(legs=(), footholds_xy_world=np.zeros((0, 2)))
    for width in (0.03, 0.06):
        terrain = _bar_terrain(width)
        feet = np.array([[0.40 + width - 0.003, 0.15], [0.0, -0.15], [-0.2, 0.15], [-0.2, -0.15]])
        covers = terrain.safe_locator(margin).covers_xy
        assert lacks_room(covers, *feet[0], ahead, behind, reach) == (width == 0.03)
        for gait, legs in ((WALK, (0,)), (TROT, (0, 3))):
            step = reseat_step(gait, stand, feet, terrain, margin, ahead, behind, reach)
            if width > 0.03:
                assert step is None
                continue
            assert step.legs == legs
            x, y = step.footholds_xy_world[0]
            assert y == pytest.approx(0.15) and x == pytest.approx(0.40 + width - margin, abs=1e-6)  # the margin in
            assert step.footholds_xy_world[1:].tolist() == feet[list(legs[1:])].tolist()  # its partner stays
            moving = PlannedStep(legs=(1,), footholds_xy_world=np.array([[0.05, -0.15]]))
            assert reseat_step(gait, moving, feet, terrain, margin, ahead, behind, reach) is None
            assert reseat_step(gait, stand, feet, terrain, margin, None, behind, reach) is None
            at_back = feet.copy()
            at_back[0, 0] = 0.403  # 3 mm from the back edge: its roll takes it away from that one
            assert reseat_step(gait, stand, at_back, terrain, margin, ahead, behind, reach) is None
