"""Issue 30, item 2 (the loop on sloped tops): the planner's plain walk on slopes, the footholds at the plane's
height, the friction pyramid about the ground's normal, and (slow) Solo12 up and down a 15 degree ramp."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactnet.locomotion import Locomotion
from contactnet.motion.controller_kernel import pack_gains, wbc_torques
from contactnet.motion.gait import TROT, WALK
from contactnet.planning.plain_walk import PlainHeightsWalk
from contactnet.registry import make_planner
from contactnet.terrain import ramps


def test_the_planner_walks_its_ranking_the_plain_way_on_slopes_and_the_feet_stand_on_the_plane(robot):
    """On a 15 degree ramp the planner takes the plain walk (no compiled rasters of flat tops); after 5 s the feet
    on the ramp stand, their balls on its plane (centre a ball's radius over it, along the normal)."""
    terrain = ramps(slopes_deg=(15.0,), across_deg=())
    gait = WALK
    planner = make_planner("contactnet", gait, robot)
    with Locomotion(robot, terrain, gait, planner, vel_cmd_xy=(0.05, 0.0)) as loco:
        assert loco._heights and terrain.height_locator() is None
        result = loco.run(5.0)
        feet, touching = loco.sim.foot_positions_world(), loco.sim.foot_contact()
    assert not result["fell"], result["fall_reason"]
    assert isinstance(planner._heights_walk, PlainHeightsWalk)
    on_ramp = (feet[:, 0] > 0.27) & (feet[:, 0] < 0.53) & touching
    assert on_ramp.any(), feet
    radius = robot.description.foot_radius_m
    above = feet[on_ramp, 2] - terrain.height_at(feet[on_ramp, :2])
    np.testing.assert_allclose(above, radius / math.cos(math.radians(15.0)), atol=0.006)


def _clip(normal: np.ndarray, force: np.ndarray, mu: float = 0.6) -> np.ndarray:
    """The controller's friction clip of one stance foot (``wbc_torques`` with no feedback, no swing)."""
    zeros = np.zeros(3)
    gains = pack_gains(zeros, zeros, zeros, zeros, zeros, zeros, mu, 0.5, 40.0, 0.0, 1e-3, 0, -1.0)
    jacobian = np.zeros((6, 18))
    forces_ref = np.zeros((4, 3))
    forces_ref[0] = force
    stance = np.array([True, False, False, False])
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    normals[0] = normal
    tau, forces, foot = np.zeros(12), np.zeros((4, 3)), np.zeros((4, 3))
    wbc_torques(zeros, zeros, (jacobian,) * 4, (zeros,) * 4, np.eye(3), np.zeros(18), zeros, zeros, zeros, zeros,
                forces_ref, stance, np.zeros((4, 3)), np.zeros((4, 3)), zeros, gains, np.full(12, 10.0), tau, forces,
                foot, normals, np.zeros(12))
    return forces[0]


def test_the_friction_pyramid_is_built_about_the_normal():
    """Reference: a force is kept when its tangential parts (about the unit normal) are within mu times its normal
    part; otherwise they are cut to mu times it. A vertical force on a 15 degree slope has a tangential part of
    tan(15) = 0.27 of its normal part: kept at mu 0.6, cut at mu 0.2. On flat ground the axis-wise clip."""
    slope = math.radians(15.0)
    normal = np.array([-math.sin(slope), 0.0, math.cos(slope)])
    weight = np.array([0.0, 0.0, 6.0])
    np.testing.assert_allclose(_clip(normal, weight), weight, atol=1e-12)
    cut = _clip(normal, weight, mu=0.2)
    along = cut @ normal
    tangential = cut - along * normal
    assert along == pytest.approx(weight @ normal)
    assert np.linalg.norm(tangential) == pytest.approx(0.2 * along)
    flat = _clip(np.array([0.0, 0.0, 1.0]), np.array([5.0, -1.0, 4.0]))
    np.testing.assert_array_equal(flat, [0.6 * 4.0, -1.0, 4.0])


@pytest.mark.slow
@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
def test_contactnet_walks_up_and_down_a_15_degree_ramp(robot, gait):
    """Issue 30 target (vx 0.05 m/s): the shipped ContactNet models go up a 15 degree ramp (8 cm over a 30 cm run),
    across its landing and down again; the base keeps its height over the plane."""
    terrain = ramps(slopes_deg=(15.0,), across_deg=())
    with Locomotion(robot, terrain, gait, make_planner("contactnet", gait, robot), vel_cmd_xy=(0.05, 0.0)) as loco:
        result = loco.run(40.0)
    assert result["success"], result["fall_reason"]
    assert result["unsafe_landings"] == 0
