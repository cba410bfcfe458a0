"""`contactnet bench planner` (``contactnet.bench.planner``): its rows on the flat random field and on the field
with heights, and the planning states it times. Times are not asserted (speed is the benchmark's output)."""

from __future__ import annotations

import numpy as np

from contactnet.bench import format_table
from contactnet.bench.planner import IN_PYTHON, NO_ROLL, bench_planner, planning_contexts
from contactnet.motion.gait import WALK
from contactnet.motion.ground import support_height
from contactnet.terrain import resolve


def test_rows_flat_field_first_then_heights():
    """The flat random field's rows keep their order (with the network reference after each gait); the rows on
    ``random_heights`` follow, for both gaits and planners, 0 and 100 squares removed, each ratio against 0 and
    against the flat field's row."""
    rows = bench_planner(repeats=3, n_contexts=3)
    n_flat = 2 * (4 * 2 + 1)  # per gait: four planner rows, 0 and 100 holes each, and the reference
    flat = [(r["gait"], r["planner"], r["holes"]) for r in rows[:n_flat]]
    reference = "network forward pass only (reference)"
    assert flat == [(g, p, h) for g in ("walk", "trot")
                    for p, h in (*((p, h) for p in ("contactnet", "fixed", NO_ROLL, IN_PYTHON) for h in (0, 100)),
                                 (reference, None))]
    assert {r.get("terrain") for r in rows[:n_flat]} == {"random", None}
    by_key = {(r["gait"], r["planner"], r["holes"]): r for r in rows[:n_flat]}
    for (gait, planner, holes), row in by_key.items():  # the plans made in Python are the compiled ones
        if planner == IN_PYTHON:
            assert row["mean_rank"] == by_key[gait, "contactnet", holes]["mean_rank"]
    heights = rows[n_flat:]
    assert [(r["terrain"], r["gait"], r["planner"], r["holes"]) for r in heights] == [
        ("random_heights", g, p, h) for g in ("walk", "trot") for p in ("contactnet", "fixed") for h in (0, 100)]
    for zero, hundred in zip(heights[::2], heights[1::2], strict=True):
        assert zero["vs_0_holes"] == 1.0
        assert hundred["vs_0_holes"] == hundred["median_us"] / zero["median_us"]
        assert zero["median_us"] > 0 and hundred["mean_rank"] is not None
    on_flat = {(r["gait"], r["planner"], r["holes"]): r["median_us"] for r in rows[:n_flat]}
    for row in heights:  # each against the flat field's row of the same gait, planner and holes
        assert row["vs_flat"] == row["median_us"] / on_flat[row["gait"], row["planner"], row["holes"]]
    assert all(r.get("vs_flat") is None for r in rows[:n_flat])
    table = format_table(rows).splitlines()
    assert table[0].split()[:4] == ["gait", "planner", "terrain", "holes"]
    assert len(table) == 2 + len(rows) == 28


def test_contexts_stand_on_the_tops(robot):
    """On ``random_heights`` each foot stands on the top under it and the CoM at the nominal height over the
    feet's support; on the flat field everything is at the ground (z = 0)."""
    robot = robot.description
    terrain = resolve("random_heights", removed=100, seed=0)
    contexts = planning_contexts(WALK, terrain, robot, 30, seed=4)
    raised = 0
    for ctx in contexts:
        feet = ctx.foot_pos_world
        np.testing.assert_allclose(feet[:, 2], terrain.ground_z(feet[:, :2]) + robot.foot_radius_m)
        expected = support_height(terrain, feet[:, :2]) + robot.com_height_nominal_m
        assert abs(ctx.com_pos_world[2] - expected) < 1e-12
        raised += int(np.any(np.abs(feet[:, 2] - robot.foot_radius_m) > 1e-3))
    assert raised >= 20  # most states have a foot on a raised or lowered square
    for ctx in planning_contexts(WALK, resolve("random", removed=100, seed=0), robot, 10, seed=4):
        np.testing.assert_allclose(ctx.foot_pos_world[:, 2], robot.foot_radius_m)
        assert abs(ctx.com_pos_world[2] - robot.com_height_nominal_m) < 1e-12
