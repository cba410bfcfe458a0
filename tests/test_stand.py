"""The stand choice (contactnet.stand): ranking it among the stepping actions, and the oracle standing still."""

from __future__ import annotations

import numpy as np
import pytest

from contactnet.gait import TROT, WALK
from contactnet.locomotion import Locomotion
from contactnet.planner import OraclePlanner, PlannedStep
from contactnet.sim import SimConfig
from contactnet.stand import prefer_stand, split_stand
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
