"""Gaits: the paper's timing, candidate grids and a bijection between action index and step."""

from __future__ import annotations

import numpy as np
import pytest

from contactnet.motion.gait import TROT, WALK
from contactnet.registry import gait_by_name


@pytest.mark.parametrize(("gait", "n_actions", "cells", "extent"), [(WALK, 100, 25, 0.20), (TROT, 162, 9, 0.10)])
def test_paper_numbers(gait, n_actions, cells, extent):
    assert gait.n_actions == n_actions
    assert gait.cells_per_leg == cells
    offsets = gait.cell_offsets_xy
    assert np.ptp(offsets[:, 0]) == pytest.approx(extent) and np.ptp(offsets[:, 1]) == pytest.approx(extent)
    np.testing.assert_allclose(offsets.mean(axis=0), 0.0, atol=1e-12)  # centred on the hip reference
    spacing = np.diff(np.unique(offsets[:, 0]))
    np.testing.assert_allclose(spacing, 0.05)
    assert gait.step_duration_s == pytest.approx(0.32)
    assert gait.horizon_nodes == 24


@pytest.mark.parametrize("gait", [WALK, TROT])
def test_action_index_is_a_bijection(gait):
    seen = set()
    for index in range(gait.n_actions):
        action = gait.decode(index)
        assert gait.encode(action.group, action.cells) == index
        assert len(action.legs) == gait.legs_per_step
        seen.add((action.group, action.cells))
    assert len(seen) == gait.n_actions
    with pytest.raises(IndexError):
        gait.decode(gait.n_actions)
    with pytest.raises(IndexError):
        gait.decode(-1)


def test_action_table_matches_decode():
    for gait in (WALK, TROT):
        swing, offsets = gait.action_table
        for index in range(0, gait.n_actions, 7):
            action = gait.decode(index)
            assert set(np.flatnonzero(swing[index])) == set(action.legs)
            np.testing.assert_allclose(offsets[index, list(action.legs)], action.offsets_xy)
            stance = [leg for leg in range(4) if leg not in action.legs]
            np.testing.assert_array_equal(offsets[index, stance], 0.0)


def test_trot_swings_diagonal_pairs_and_walk_one_leg():
    assert {TROT.decode(i).leg_names for i in range(TROT.n_actions)} == {("FL", "HR"), ("FR", "HL")}
    assert {WALK.decode(i).leg_names for i in range(WALK.n_actions)} == {("FL",), ("FR",), ("HL",), ("HR",)}


def test_step_contact_schedule():
    contact = WALK.step_contact((2,))
    assert contact.shape == (8, 4)
    assert contact[:3].all() and contact[7].all()  # 3 stance nodes, then 4 swing, then 1 stance
    assert not contact[3:7, 2].any() and contact[3:7, [0, 1, 3]].all()
    horizon = TROT.horizon_contact([(0, 3), (1, 2), (0, 3)])
    assert horizon.shape == (24, 4)
    assert (~horizon).sum() == 3 * 4 * 2


def test_candidates_world_rotate_with_yaw():
    hips = np.array([[0.2, 0.15], [0.2, -0.15], [-0.2, 0.15], [-0.2, -0.15]])
    straight = WALK.candidates_world(hips, 0.0)
    np.testing.assert_allclose(straight[0], hips[0] + WALK.cell_offsets_xy)
    turned = WALK.candidates_world(hips, np.pi / 2)
    np.testing.assert_allclose(turned[1] - hips[1], WALK.cell_offsets_xy @ np.array([[0, 1], [-1, 0]]), atol=1e-12)


def test_unknown_gait_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown gait 'gallop'"):
        gait_by_name("gallop")


def test_a_gait_is_sized_to_the_robot_and_solo12_keeps_the_paper_s_numbers():
    from contactnet.motion.gait import gait_by_name, gait_for
    from contactnet.robots import load_robot

    solo, go2 = load_robot("solo12"), load_robot("go2")
    assert solo.description.size_scale == 1.0
    assert gait_for("walk", solo) is gait_by_name("walk") and gait_for("trot", solo) is gait_by_name("trot")
    scale = go2.description.size_scale
    assert scale == pytest.approx(go2.description.leg_reach_m / 0.3245, abs=5e-4) and 1.2 < scale < 1.4
    for name in ("walk", "trot"):
        base, sized = gait_by_name(name), gait_for(name, go2)
        assert sized.grid_spacing_m == pytest.approx(base.grid_spacing_m * scale)
        assert sized.node_dt_s == pytest.approx(base.node_dt_s * scale ** 0.5, abs=5e-4)
        assert round(sized.node_dt_s * 1000) == pytest.approx(sized.node_dt_s * 1000, abs=1e-9)  # whole ticks
        assert (sized.grid_n, sized.n_actions, sized.nodes_per_step) == (base.grid_n, base.n_actions,
                                                                         base.nodes_per_step)
    with pytest.raises(ValueError, match="scale"):
        gait_by_name("walk").scaled(0.0)
