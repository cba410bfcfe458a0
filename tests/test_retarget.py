"""Foothold update during the swing (issue 14, item 2, in progress): the retargeted swing is continuous and
lands on its new point; in a pushed run the loop retargets swings and counts them."""

from __future__ import annotations

import numpy as np
import pytest

from contactnet import registry
from contactnet.locomotion import Locomotion, LocomotionConfig
from contactnet.motion.controller import SwingTrajectory
from contactnet.planning.retarget import RetargetConfig, RetargetedSwing
from contactnet.sim.pybullet_world import Push, SimConfig
from contactnet.terrain import resolve


def test_a_retargeted_swing_is_continuous_and_lands_on_the_new_point():
    base = SwingTrajectory(start_world=np.array([0.0, 0.1, 0.016]), end_world=np.array([0.1, 0.1, 0.016]),
                           t0_s=1.0, t1_s=1.24, height_m=0.05)
    delta = np.array([0.03, -0.04, 0.0])
    moved = RetargetedSwing(base, delta, 1.1)
    for t in (0.9, 1.0, 1.05, 1.1):  # up to the retarget: the old swing
        for a, b in zip(moved.sample(t), base.sample(t), strict=True):
            np.testing.assert_allclose(a, b)
    eps = 1e-6
    for t in (1.1, 1.15, 1.2):  # position and velocity continuous (finite differences agree with the velocity)
        p0, v0, _ = moved.sample(t - eps)
        p1, v1, _ = moved.sample(t + eps)
        np.testing.assert_allclose(p1, p0, atol=1e-5)
        np.testing.assert_allclose((p1 - p0) / (2 * eps), 0.5 * (v0 + v1), rtol=1e-3, atol=1e-3)
        np.testing.assert_allclose(v1, v0, atol=1e-3)
    end, end_velocity, _ = moved.sample(1.24)
    np.testing.assert_allclose(end, base.end_world + delta)
    np.testing.assert_allclose(end_velocity, base.sample(1.24)[1])
    np.testing.assert_allclose(moved.end_world, base.end_world + delta)
    assert (moved.t0_s, moved.t1_s) == (base.t0_s, base.t1_s)
    again = RetargetedSwing(moved, -delta, 1.2)  # retargeted twice: back to the old landing
    np.testing.assert_allclose(again.sample(1.24)[0], base.end_world)


@pytest.mark.slow
def test_a_pushed_walk_retargets_its_swings_only_when_asked():
    robot = registry.load_robot("solo12")
    gait = registry.gait_by_name("walk")
    counts = {}
    # bracing off: a braced walk stands while pushed, so there is no swing to retarget
    for name, config in (("off", LocomotionConfig(brace=None)),
                         ("on", LocomotionConfig(brace=None, retarget=RetargetConfig()))):
        planner = registry.make_planner("contactnet", gait, robot)
        with Locomotion(robot, resolve("push_field"), gait, planner, SimConfig(), config=config,
                        vel_cmd_xy=(0.05, 0.0)) as loco:
            loco.push(Push(2.0, 1.0, (0.0, 8.0, 0.0)))
            summary = loco.run(4.0)
        counts[name] = summary["swing_retargets"]
        landed = [r.footholds_xy_world for r in loco.records]
        assert all(resolve("push_field").is_safe(np.asarray(xy)).all() for xy in landed)
    assert counts["off"] == 0 and counts["on"] >= 1
