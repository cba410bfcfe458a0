"""The roll allowance (contactnet.planning.roll) and the terrain's margin with room ahead (contactnet.terrain.margin),
against plain references: two lookups of the plain margin, and the plan without the allowance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactnet.bench.planner import planning_contexts
from contactnet.frames import rotate_xy
from contactnet.motion.gait import TROT, WALK
from contactnet.planning.roll import DEFAULT_ROLL, RollConfig, rolled_margin
from contactnet.registry import make_planner
from contactnet.terrain import random_field, resolve
from contactnet.terrain.margin import EdgeMargin


@pytest.mark.parametrize("name", ["random", "stairs", "raised_stones"])
def test_room_ahead_is_two_plain_lookups(name):
    terrain = random_field(80, 3) if name == "random" else resolve(name)
    minx, miny, maxx, maxy = terrain.bounds
    points = np.random.default_rng(0).uniform([minx, miny], [maxx, maxy], (20000, 2))
    for ahead in [(0.012, 0.0), (0.0, -0.02), (-0.007, 0.009)]:
        margin = EdgeMargin(0.008, ahead)
        expected = terrain.is_safe(points, 0.008) & terrain.is_safe(points + np.array(ahead), 0.008)
        got = terrain.is_safe(points, margin)
        assert (got == expected).all(), (name, ahead, int((got != expected).sum()))
        assert expected.sum() < terrain.is_safe(points, 0.008).sum()  # the room ahead rules some points out
        locator = terrain.safe_locator(margin)
        assert all(locator.covers_xy(float(x), float(y)) == e for (x, y), e in zip(points[:300], expected[:300],
                                                                                   strict=True))
    assert (terrain.is_safe(points, EdgeMargin(0.008)) == terrain.is_safe(points, 0.008)).all()


@pytest.mark.parametrize("bad", [dict(around_m=-0.01), dict(around_m=float("nan")), dict(around_m=True),
                                 dict(around_m=0.01, ahead_xy_m=(0.2, 0.0)), dict(around_m=0.01, ahead_xy_m=(1.0,)),
                                 dict(around_m=0.01, ahead_xy_m=(float("inf"), 0.0))])
def test_a_bad_edge_margin_says_which_field(bad):
    with pytest.raises(ValueError, match="around_m|ahead_xy_m"):
        EdgeMargin(**bad)


def test_the_allowance_follows_the_command():
    radius = 0.016
    ahead = rolled_margin(0.008, radius, (0.05, 0.0), DEFAULT_ROLL)
    assert ahead.around_m == 0.008 and ahead.ahead_xy_m == pytest.approx((0.012, 0.0))
    assert rolled_margin(0.008, radius, (0.0, 0.0), DEFAULT_ROLL) is None  # standing: no direction
    assert rolled_margin(0.008, radius, (0.05, 0.0), None) is None  # off
    assert rolled_margin(0.008, radius, (0.05, 0.0), RollConfig(allowance_radii=0.0)) is None
    # along the command, 0.75 radii long whatever the speed
    back = rolled_margin(0.008, radius, (-0.3, -0.3), DEFAULT_ROLL)
    assert back.ahead_xy_m[0] == pytest.approx(back.ahead_xy_m[1]) and back.ahead_xy_m[0] < 0
    assert math.hypot(*back.ahead_xy_m) == pytest.approx(0.012)
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
            ahead = rolled_margin(roomy.margin_m, robot.description.foot_radius_m,
                                  rotate_xy(np.asarray(ctx.vel_cmd_xy, dtype=float), ctx.yaw_rad), roomy.roll)
            has_room = ahead is None or terrain.is_safe(a.footholds_xy_world, ahead).all()
            assert a.legs == b.legs  # the network's choice of legs stands; only their cells may move
            moved += a.action_index != b.action_index
            if not has_room:  # no action had room: the plain choice
                assert a.action_index == b.action_index
    assert moved > 0, "the allowance should change some choices"
