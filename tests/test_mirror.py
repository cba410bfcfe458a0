"""The left-right mirror of a ranking instance (``contactnet.planning.mirror``) against the ranking cost itself:
the cost of every choice of a mirrored state is the cost of the mirrored choice of the state (the optimizer
included), for Solo12 and Go2, walk and trot; so a mirrored training instance is labelled exactly."""

from __future__ import annotations

import numpy as np
import pytest

from contactnet.planning.cost import CostState, RankingCost, nominal_state
from contactnet.planning.mirror import MIRROR_LEGS, choice_mirror, mirror_inputs, mirrored
from contactnet.planning.network_input import network_input
from contactnet.registry import gait_for, load_robot

FLIP = np.array([1.0, -1.0, 1.0])  # y negated
FLIP_AXIAL = np.array([-1.0, 1.0, -1.0])  # a pseudovector's (roll, pitch, yaw; angular velocity) mirror


def mirror_state(state: CostState) -> CostState:
    """The state mirrored about the x-z plane, written out plainly (legs swapped, every y negated)."""
    return CostState(
        com_pos_world=state.com_pos_world * FLIP, com_vel_world=state.com_vel_world * FLIP,
        rpy=state.rpy * FLIP_AXIAL, ang_vel_world=state.ang_vel_world * FLIP_AXIAL,
        foot_pos_world=state.foot_pos_world[MIRROR_LEGS] * FLIP, base_xy_world=state.base_xy_world * FLIP[:2],
        yaw_rad=-state.yaw_rad, vel_cmd_world=state.vel_cmd_world * FLIP[:2],
        com_height_ref_m=state.com_height_ref_m, ground_z=state.ground_z,
    )


def an_uneven_state(robot, seed: int) -> CostState:  # noqa: ANN001 - a Robot
    rng = np.random.default_rng(seed)
    state = nominal_state(robot.description, vel_cmd_world=(0.08, 0.03), foot_offsets_xy=rng.normal(0, 0.02, (4, 2)))
    return CostState(**{**state.__dict__, "com_vel_world": np.array([0.07, 0.02, 0.01]),
                        "rpy": np.array([0.02, 0.01, 0.0]), "ang_vel_world": np.array([0.1, -0.05, 0.02])})


def inputs_of(state: CostState) -> np.ndarray:
    return network_input(state.foot_pos_world[:, :2], state.com_pos_world, state.com_vel_world, state.vel_cmd_world,
                         state.yaw_rad, state.ground_z)


@pytest.mark.parametrize("robot_name", ["solo12", "go2"])
@pytest.mark.parametrize("gait_name", ["walk", "trot"])
def test_the_cost_of_a_mirrored_state_is_the_mirrored_cost(robot_name, gait_name):
    robot = load_robot(robot_name)
    gait = gait_for(gait_name, robot)
    cost = RankingCost(gait, robot.description)
    state = an_uneven_state(robot, seed=3)
    V, V_mirror = cost.evaluate(state).V, cost.evaluate(mirror_state(state)).V
    perm = choice_mirror(gait, len(V))
    assert not np.allclose(V, V[perm])  # the state is not symmetric itself: the check could fail
    # Go2's CoM and inertia are a little off the centre line: 1e-4 of the cost, far below the gaps in a ranking
    np.testing.assert_allclose(V_mirror, V[perm], rtol=1e-4, atol=1e-6)
    assert (np.argsort(V_mirror, kind="stable")[:5] == perm[np.argsort(V, kind="stable")[:5]]).all()
    # the network inputs of the mirrored state are the mirrored inputs
    np.testing.assert_allclose(inputs_of(mirror_state(state)), mirror_inputs(inputs_of(state)), atol=1e-12)


@pytest.mark.parametrize("gait_name", ["walk", "trot"])
def test_the_choice_mirror_is_an_involution_that_swaps_sides(gait_name):
    gait = gait_for(gait_name, load_robot("solo12"))
    for n in (gait.n_actions, gait.n_choices):
        perm = choice_mirror(gait, n)
        assert sorted(perm) == list(range(n)) and (perm[perm] == np.arange(n)).all()
    perm = choice_mirror(gait)
    assert perm[gait.stand_index] == gait.stand_index
    swing, offsets = gait.action_table
    a = int(np.flatnonzero(swing[:, 0] & (offsets[:, 0, 1] > 0))[0])  # FL lands to its left
    assert swing[perm[a], 1] and offsets[perm[a], 1, 1] == -offsets[a, 0, 1]  # FR lands to its right
    u = np.random.default_rng(0).normal(size=(7, 14)).astype(np.float32)
    V = np.random.default_rng(1).normal(size=(7, gait.n_choices)).astype(np.float32)
    u2, V2 = mirrored(*mirrored(u, V, gait), gait)
    assert u2.dtype == np.float32 and np.array_equal(u2, u) and np.array_equal(V2, V)
    with pytest.raises(ValueError, match="choices"):
        choice_mirror(gait, gait.n_actions + 5)
