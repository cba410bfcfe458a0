"""The idle rule (contactnet.planning.stand.IdleConfig): with a zero command and a balanced state a ContactNet planner stands
instead of a swing that barely moves its feet, with any model; anything else plans as before."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from contactnet.bench.planner import planning_contexts
from contactnet.locomotion import Locomotion
from contactnet.motion.gait import TROT, WALK
from contactnet.planning.planner import ContactNetPlanner, FixedGaitPlanner
from contactnet.planning.stand import DEFAULT_IDLE, IdleConfig, is_idle, useless_swing
from contactnet.registry import make_planner, model_path
from contactnet.sim.pybullet_world import SimConfig
from contactnet.terrain import flat, resolve


def test_idle_means_a_zero_command_and_a_balanced_state():
    config = IdleConfig(max_command_m_s=0.005, max_velocity_error_m_s=0.05)
    assert is_idle(np.array([0.03, -0.03, 0.4]), np.zeros(2), config)  # the vertical velocity does not count
    assert not is_idle(np.array([0.04, -0.04, 0.0]), np.zeros(2), config)  # 5.7 cm/s: still moving
    assert not is_idle(np.zeros(3), np.array([0.0, 0.05]), config)  # a command: step
    assert is_idle(np.zeros(3), np.array([0.003, -0.003]), config)
    assert not is_idle(np.zeros(3), np.zeros(2), None)  # the rule off
    assert not is_idle(np.array([np.nan, 0.0, 0.0]), np.zeros(2), config)


@pytest.mark.parametrize("field", ["max_command_m_s", "max_velocity_error_m_s", "min_swing_m"])
@pytest.mark.parametrize("value", [-0.01, float("nan"), float("inf")])
def test_bad_idle_settings_name_their_field(field, value):
    with pytest.raises(ValueError, match=f"IdleConfig.{field} must be a finite number >= 0"):
        IdleConfig(**{field: value})


def test_a_useless_swing_moves_every_swinging_foot_less_than_the_threshold():
    rng = np.random.default_rng(0)
    for _ in range(300):
        feet = rng.uniform(-0.3, 0.3, (4, 2))
        legs = tuple(sorted(rng.choice(4, size=int(rng.integers(1, 3)), replace=False).tolist()))
        landing = feet[list(legs)] + rng.uniform(-0.03, 0.03, (len(legs), 2))
        expected = bool((np.linalg.norm(landing - feet[list(legs)], axis=1) < 0.02).all())
        assert useless_swing(legs, landing.tolist(), feet.tolist(), 0.02) == expected
        assert useless_swing(legs, landing, feet, 0.02) == expected  # arrays as well
    assert not useless_swing((), np.zeros((0, 2)), np.zeros((4, 2)), 0.02)  # standing is no swing


def _still(ctx, vel_xy=(0.01, -0.01), cmd=(0.0, 0.0)):  # noqa: ANN001, ANN202
    return dataclasses.replace(ctx, com_vel_world=np.array([*vel_xy, 0.0]), vel_cmd_xy=np.array(cmd))


def _settled(ctx, planner):  # noqa: ANN001, ANN202
    """``ctx`` after a few steps in place: each first step of the rule-free ``planner`` taken (its feet moved to
    their landings) under a zero command, so that the feet are where the network puts them at rest."""
    for _ in range(6):
        step = planner.plan(ctx)[0]
        feet = np.array(ctx.foot_pos_world, dtype=float)
        feet[list(step.legs), :2] = step.footholds_xy_world
        ctx = dataclasses.replace(ctx, foot_pos_world=feet)
    return ctx


@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
@pytest.mark.parametrize("terrain_name", ["flat", "random", "random_heights"])
def test_a_still_robot_stands_instead_of_a_useless_swing_and_plans_as_before_otherwise(robot, gait, terrain_name):
    """Against the same planner with the rule off, on the shipped model: with a zero command and a balanced state the
    first step stands exactly when the rule-free first step is a useless swing (< 2 cm), and is that step otherwise;
    no step of such a plan is a useless swing. With a command, or moving, the plans are the same step for step. The
    fixed gait never idles."""
    model = make_planner("contactnet", gait, robot, model=model_path("solo12", gait.name)).model
    terrain = flat() if terrain_name == "flat" else resolve(terrain_name, removed=80, seed=1)
    idle = ContactNetPlanner(gait, robot.description, model)
    plain = ContactNetPlanner(gait, robot.description, model, idle=None)
    fixed = FixedGaitPlanner(gait, robot.description, model)
    stood = stepped = network_stood = 0
    for k, ctx in enumerate(planning_contexts(gait, terrain, robot.description, 40, seed=4)):
        # half of them with the feet where the network puts them at rest
        base = _settled(_still(ctx), plain) if k % 2 else ctx
        still = _still(base)
        before, after = plain.plan(still)[0], idle.plan(still)
        feet = np.asarray(base.foot_pos_world)[:, :2]
        if useless_swing(before.legs, before.footholds_xy_world, feet, DEFAULT_IDLE.min_swing_m):
            assert after[0].legs == () and after[0].action_index == gait.stand_index
            assert after[0].rank == before.rank
            stood += 1
        else:
            network_stood += before.legs == ()
            assert after[0].legs == before.legs and after[0].action_index == before.action_index
            np.testing.assert_array_equal(after[0].footholds_xy_world, before.footholds_xy_world)
            stepped += 1
        for step in after:  # predicted feet: a useless swing is never planned while idle
            assert not useless_swing(step.legs, step.footholds_xy_world, feet, DEFAULT_IDLE.min_swing_m)
            feet = feet.copy()
            feet[list(step.legs)] = step.footholds_xy_world
        assert fixed.plan(still)[0].legs != ()
        for busy in (_still(base, cmd=(0.05, 0.0)), _still(base, vel_xy=(0.08, 0.0)), ctx):
            for a, b in zip(idle.plan(busy), plain.plan(busy), strict=True):
                assert (a.legs, a.action_index, a.rank) == (b.legs, b.action_index, b.rank)
                np.testing.assert_array_equal(a.footholds_xy_world, b.footholds_xy_world)
    assert stepped > 0
    # The shipped trot has no stand output: only the rule stands. The walk's network stands by itself at rest.
    assert stood > 0 if model.n_actions == gait.n_actions else stood + network_stood > 0


@pytest.mark.slow
@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
def test_the_shipped_models_stand_with_a_zero_command_and_walk_off_when_commanded(robot, gait):
    """Issue 14's target on a short run: with a zero command on flat no leg swings after the first 2 s; a forward
    command starts the steps again at the next step horizon. (The shipped trot has no stand output: the idle rule
    makes it stand.)"""
    planner = make_planner("contactnet", gait, robot, model=model_path("solo12", gait.name))
    with Locomotion(robot, flat(), gait, planner, SimConfig(), vel_cmd_xy=(0.0, 0.0)) as loco:
        summary = loco.run(5.0, stop_at_goal=False)
        assert not summary["fell"] and summary["stand_steps"] > 0
        assert not [r for r in loco.records if r.t_s >= 2.0 and r.legs]
        standing = len(loco.records)
        loco.set_command(0.1, 0.0)
        loco.run(5.0 + 2 * gait.step_duration_s, stop_at_goal=False)
        assert loco.records[standing].legs  # the first plan under the command steps
        assert not loco.summary()["fell"]
