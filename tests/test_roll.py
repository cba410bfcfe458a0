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
    plain.roll = None
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
