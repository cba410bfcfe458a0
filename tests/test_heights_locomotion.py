"""Issue 13, items 2 and 3 (the loop): Solo12 on terrain with heights.

The optimizer's CoM height and pitch references follow the tops under the feet, touchdown adapts to the
contact sensed, ``simulate --json`` reports the largest step up or down, a single-height terrain keeps
today's references, and (slow) the robot crosses the shipped stairs and raised stones with ContactNet."""

from __future__ import annotations

import numpy as np
import pytest

from contactnet.locomotion import Locomotion
from contactnet.motion.gait import TROT, WALK
from contactnet.registry import make_planner
from contactnet.terrain import resolve


def recorded_problems(loco: Locomotion) -> list:
    """Make the loop's optimizer record every problem it solves."""
    problems = []
    solve = loco.optimizer.solve

    def record(problem, *args, **kwargs):
        problems.append(problem)
        return solve(problem, *args, **kwargs)

    loco.optimizer.solve = record
    return problems


def test_single_height_terrain_keeps_today_s_references(robot):
    """Stepping stones (every top at the ground level): no height checks, no touchdown adaptation, the CoM
    height reference is the same at every node (the nominal height less the walk's crouch on one level,
    ``RobotDescription.default_crouch_m``) and the body stays level."""
    gait = WALK
    with Locomotion(robot, resolve("stepping_stones"), gait, make_planner("contactnet", gait, robot),
                    vel_cmd_xy=(0.05, 0.0)) as loco:
        assert not loco._heights and not loco._adapt_touchdown
        problems = recorded_problems(loco)
        result = loco.run(1.0)
    assert problems and result["max_height_change_m"] == 0.0
    nominal = robot.description.com_height_nominal_m - robot.description.default_crouch_m("walk", heights=False)
    for problem in problems:
        np.testing.assert_array_equal(problem.com_height_ref_m, nominal)
        np.testing.assert_array_equal(problem.pitch_ref_rad, 0.0)


def test_references_follow_the_feet_up_the_stairs(robot):
    """After the first front foot lands on the first tread (5 cm up), the CoM height reference rises by a
    quarter of it and the body pitches nose up; the step taken is reported."""
    gait = WALK
    with Locomotion(robot, resolve("stairs"), gait, make_planner("contactnet", gait, robot),
                    vel_cmd_xy=(0.05, 0.0)) as loco:
        assert loco._heights and loco._adapt_touchdown
        problems = recorded_problems(loco)
        result = loco.run(2.0)
        feet = loco.sim.foot_positions_world()
    assert not result["fell"], result["fall_reason"]
    nominal = robot.description.com_height_nominal_m
    up = feet[:, 0] > 0.25  # feet on the first tread
    assert up[:2].any() and not up[2:].any()
    last = problems[-1]
    assert last.com_height_ref_m[0] == pytest.approx(nominal + 0.05 * up.sum() / 4)
    assert np.all(last.pitch_ref_rad < 0)  # nose up
    assert result["max_height_change_m"] == pytest.approx(0.05)
    changes = [r.height_change_m for r in loco.records[:-1]]
    assert all(c in (0.0, pytest.approx(0.05)) for c in changes)


def test_touchdown_adapts_to_early_and_late_contact(robot):
    """A swinging foot touching down near its landing point in the last quarter of its swing becomes a stance
    foot; touching far from it (an edge on the way) does not count; one not touching at the planned time
    keeps descending, then counts as stance at the depth limit."""
    gait = WALK
    with Locomotion(robot, resolve("stairs"), gait, make_planner("contactnet", gait, robot),
                    vel_cmd_xy=(0.05, 0.0)) as loco:
        loco.advance(1)  # plans the first step
        while not loco.plan.swings:  # the walk may stand first (contactnet.planning.stand): on to its first swing
            loco.advance(loco.ticks_per_step)
        plan = loco.plan
        (leg, swing), = plan.swings.items()
        duration = swing.t1_s - swing.t0_s
        touching = np.ones(4, dtype=bool)
        loco._foot_contact = lambda: touching
        # Early, mid-swing: not yet (the foot may brush an edge on its way up).
        assert not loco._target(swing.t0_s + 0.5 * duration).stance[leg]
        # Last quarter, far from the landing point: an edge, keep swinging.
        loco.controller.last_foot_pos[leg] = swing.end_world + np.array([0.05, 0.0, 0.02])
        assert not loco._target(swing.t1_s - 0.1 * duration).stance[leg]
        # Last quarter, at the landing point: touchdown, and stance from then on.
        loco.controller.last_foot_pos[leg] = swing.end_world + np.array([0.005, 0.0, 0.01])
        assert loco._target(swing.t1_s - 0.1 * duration).stance[leg]
        touching[:] = False
        assert loco._target(swing.t1_s - 0.05 * duration).stance[leg]
        # Late: a fresh plan, no contact at the planned touchdown: keep descending below the landing point.
        plan.touched[:] = False
        target = loco._target(swing.t1_s + 0.05)
        assert not target.stance[leg]
        depth = loco.config.late_touchdown_speed_m_s * 0.05
        np.testing.assert_allclose(target.swing_pos[leg], swing.end_world - np.array([0.0, 0.0, depth]))
        assert target.swing_vel[leg][2] < 0
        # Past the depth limit: stance whatever the sensors say.
        late = loco.config.late_touchdown_depth_m / loco.config.late_touchdown_speed_m_s + 0.01
        assert loco._target(swing.t1_s + late).stance[leg]


@pytest.mark.slow
@pytest.mark.parametrize(("terrain", "gait"), [("stairs", WALK), ("raised_stones", TROT)],
                         ids=["stairs-walk", "raised_stones-trot"])
def test_contactnet_crosses_terrain_with_heights(robot, terrain, gait):
    """Issue 13 targets (vx 0.05 m/s): the shipped ContactNet models cross the stairs (5 cm risers up and down)
    and the raised stones (tops within +-6 cm), as a user runs them (the robot for the terrain: its stance feet
    pressed on heights, ``Robot.for_terrain``)."""
    terrain = resolve(terrain)
    robot = robot.for_terrain(terrain, gait.name)
    with Locomotion(robot, terrain, gait, make_planner("contactnet", gait, robot),
                    vel_cmd_xy=(0.05, 0.0)) as loco:
        result = loco.run(40.0)
    assert result["success"], result["fall_reason"]
    assert 0.04 <= result["max_height_change_m"] <= 0.13
