"""The stand choice (contactnet.planning.stand): ranking it among the stepping actions, and the oracle standing still."""

from __future__ import annotations

import numpy as np
import pytest

from contactnet.locomotion import Locomotion
from contactnet.motion.gait import TROT, WALK
from contactnet.planning.oracle import OraclePlanner
from contactnet.planning.planner import PlannedStep
from contactnet.planning.stand import prefer_stand, split_stand
from contactnet.sim.pybullet_world import SimConfig
from contactnet.terrain import flat


def test_split_stand_keeps_the_stepping_order_and_finds_standing():
    order = np.array([7, 3, WALK.stand_index, 0, 9])
    steps, position = split_stand(WALK, order)
    np.testing.assert_array_equal(steps, [7, 3, 0, 9])
    assert position == 2
    steps, position = split_stand(WALK, np.array([1, 2]))
    assert position is None and list(steps) == [1, 2]


@pytest.mark.parametrize(("rank", "stand_position", "stands"), [(0, 1, False), (1, 1, True), (3, 0, True),
                                                                (None, 50, True), (2, None, False)])
def test_standing_wins_when_it_ranks_above_the_first_safe_step(rank, stand_position, stands):
    step = PlannedStep(legs=(2,), footholds_xy_world=np.zeros((1, 2)), action_index=None if rank is None else 5,
                       rank=rank, discarded=rank or 0)
    chosen = prefer_stand(WALK, step, stand_position)
    assert (chosen.legs == ()) == stands
    if stands:
        assert chosen.action_index == WALK.stand_index and chosen.rank == stand_position and chosen.safe
        assert chosen.footholds_xy_world.shape == (0, 2)
    else:
        assert chosen is step


def test_a_network_stands_when_standing_outranks_the_step_or_rounds_to_the_top_rank():
    from contactnet.planning.stand import network_stands

    costs = -np.linspace(0.0, 0.999, 100)  # minus the outputs of 100 stepping actions, the best 0.999
    assert not network_stands(costs, None, -0.999)  # a model without the stand output
    assert network_stands(costs, -0.5, None)  # nothing usable
    assert network_stands(costs, -0.9, -0.8) and not network_stands(costs, -0.8, -0.9)  # outranks or not
    assert network_stands(costs, -0.996, -0.999)  # 0.996 >= 1 - 0.5 / 100: the top rank, a step scores higher
    assert not network_stands(costs, -0.994, -0.999)  # rounds to rank 1
    assert not network_stands(-np.linspace(0, 0.999, 162), -0.996, -0.999)  # the trot's top rank needs 0.99691


def test_gaits_count_standing_as_one_more_choice():
    assert (WALK.n_choices, WALK.stand_index) == (101, 100)
    assert (TROT.n_choices, TROT.stand_index) == (163, 162)


@pytest.mark.slow
@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
def test_oracle_stands_still_with_a_zero_command_and_walks_off_when_commanded(robot, gait):
    """With the ranking cost's stand choice, a zero command on flat ground means standing: after the first
    2 s no leg swings; a forward command then starts the steps again within one step horizon."""
    planner = OraclePlanner(gait, robot.description, evaluated_steps=1)
    with Locomotion(robot, flat(), gait, planner, SimConfig(), vel_cmd_xy=(0.0, 0.0)) as loco:
        summary = loco.run(4.0, stop_at_goal=False)
        assert not summary["fell"] and summary["stand_steps"] > 0
        assert not [r for r in loco.records if r.t_s >= 2.0 and r.legs]
        assert summary["steps"] + summary["stand_steps"] == len(loco.records)
        standing = len(loco.records)
        loco.set_command(0.1, 0.0)
        loco.run(4.0 + 2 * gait.step_duration_s, stop_at_goal=False)
        assert any(r.legs for r in loco.records[standing:standing + 2])
        summary = loco.summary()
        assert not summary["fell"] and summary["useless_steps"] == 0


class _StandModel:
    """A stand-in model with N_a + 1 outputs: fixed random scores, standing's set by the test."""

    def __init__(self, gait, seed: int, stand_score: float) -> None:
        self.gait, self.n_actions, self.path = gait.name, gait.n_choices, "<stand>"
        self._scores = np.random.default_rng(seed).uniform(0.0, 1.0, gait.n_choices)
        self._scores[gait.stand_index] = stand_score

    def scores(self, u):
        return self._scores.copy()


@pytest.mark.parametrize("gait", [WALK, TROT], ids=["walk", "trot"])
@pytest.mark.parametrize("terrain_name", ["flat", "random", "random_heights"])
def test_contactnet_stands_when_standing_outranks_the_first_usable_step_or_tops_the_ranking(robot, gait,
                                                                                            terrain_name):
    """The fast planner against the plain rule on the same scores: with a stand-capable model, step 1 stands iff
    standing's score beats the step a model without the stand output takes (the first usable one) or rounds to the
    top rank (>= 1 - 0.5 / N_a), unless a leg is cornered (terrain with heights: then it steps); the fixed gait
    never stands."""
    from contactnet.bench.planner import planning_contexts
    from contactnet.planning.planner import ContactNetPlanner, FixedGaitPlanner
    from contactnet.terrain import resolve

    terrain = flat() if terrain_name == "flat" else resolve(terrain_name, removed=100, seed=3)
    stood = stepped = 0
    for k, ctx in enumerate(planning_contexts(gait, terrain, robot.description, 12, seed=k_seed(terrain_name))):
        cornered = _cornered(ContactNetPlanner(gait, robot.description, _StandModel(gait, 0, 0.0)), ctx)
        for stand_score in (0.2, 0.5, 0.8, 0.97, 0.9975, 1.5):
            model = _StandModel(gait, seed=k, stand_score=stand_score)
            without = _StandModel(gait, seed=k, stand_score=-1.0)  # standing last: never chosen over a safe step
            plain = ContactNetPlanner(gait, robot.description, without).plan(ctx)[0]
            chosen = ContactNetPlanner(gait, robot.description, model).plan(ctx)[0]
            fixed = FixedGaitPlanner(gait, robot.description, model).plan(ctx)[0]
            assert fixed.legs != ()
            if cornered:
                assert chosen.legs == plain.legs and chosen.action_index == plain.action_index
                stepped += 1
            elif plain.action_index is not None and (stand_score > model.scores(None)[plain.action_index]
                                                     or stand_score >= 1.0 - 0.5 / gait.n_actions):
                assert chosen.legs == () and chosen.action_index == gait.stand_index
                assert chosen.rank == int(np.count_nonzero(model.scores(None)[:gait.n_actions] >= stand_score))
                stood += 1
            elif plain.action_index is None:  # nothing usable: standing beats a step in place
                assert chosen.legs == ()
                stood += 1
            else:
                assert chosen.action_index == plain.action_index and chosen.legs == plain.legs
                np.testing.assert_array_equal(chosen.footholds_xy_world, plain.footholds_xy_world)
                stepped += 1
    assert stood > 0 and stepped > 0


def _cornered(planner, ctx) -> bool:  # noqa: ANN001
    """Whether a leg is cornered at step 1 (``ContactNetPlanner._swing_cornered_legs_first``'s test)."""
    from contactnet.planning.cornered import CORNERED_LOOKAHEAD_STEPS

    if not planner.footholds.applies(ctx.terrain):
        return False
    c, s = np.cos(ctx.yaw_rad), np.sin(ctx.yaw_rad)
    to_world = np.array([[c, -s], [s, c]])
    feet_xy = np.asarray(ctx.foot_pos_world, dtype=float)[:, :2]
    ahead = (np.asarray(ctx.base_xy_world) + planner.hip_xy_base @ to_world.T
             + (to_world @ np.asarray(ctx.vel_cmd_xy)) * CORNERED_LOOKAHEAD_STEPS * planner.gait.step_duration_s)
    return not planner.footholds.stance_clear(ctx.terrain, feet_xy, ctx.terrain.ground_z(feet_xy), ahead,
                                              ctx.yaw_rad).all()


def k_seed(name: str) -> int:
    return {"flat": 1, "random": 2, "random_heights": 3}[name]
