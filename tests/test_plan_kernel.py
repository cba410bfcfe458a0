"""The plan made in one compiled call (``contactnet.planning.plan_kernel``) against the same planner's plan made step by
step in Python (its reference: ``tests/test_planner_fast.py`` checks that one against a plain walk down the
ranking): the same steps, ranks, footholds and candidate view, with the shipped models of both robots, on the random
field with and without holes, pushed and not, for ContactNet and the fixed gait."""

from __future__ import annotations

import numpy as np
import pytest

from contactnet.bench.planner import planning_contexts
from contactnet.motion.gait import TROT, WALK
from contactnet.planning import plan_kernel
from contactnet.registry import load_robot, make_planner, model_path
from contactnet.terrain import resolve


def _contexts(gait, robot, terrain, n: int, seed: int) -> list:  # noqa: ANN001
    """The benchmark's walking states, a third of them pushed (a velocity error: the capture step's shifted grid,
    no stand at the first step), a few with a zero command (the idle rule: Python's path) and some with a foot
    moved back, near or beyond its leg's reach."""
    import dataclasses

    rng = np.random.default_rng(seed)
    out = []
    for i, ctx in enumerate(planning_contexts(gait, terrain, robot.description, n, seed=seed)):
        if i % 3 == 1:
            ctx = dataclasses.replace(ctx, com_vel_world=ctx.com_vel_world + np.r_[rng.normal(0.0, 0.25, 2), 0.0])
        elif i % 10 == 0:
            ctx = dataclasses.replace(ctx, vel_cmd_xy=np.zeros(2), com_vel_world=np.zeros(3))
        elif i % 5 == 2:  # a foot near its leg's reach, some beyond it (contactnet.planning.reach: Python's path)
            feet = ctx.foot_pos_world.copy()
            feet[rng.integers(4), 0] -= rng.uniform(0.05, 0.2) * robot.description.size_scale
            ctx = dataclasses.replace(ctx, foot_pos_world=feet, vel_cmd_xy=np.array([0.1, 0.0]))
        out.append(ctx)
    return out


def _as_tuple(step) -> tuple:  # noqa: ANN001
    return (step.legs, step.footholds_xy_world.tolist(), step.action_index, step.rank, step.discarded, step.safe,
            step.captured)


@pytest.mark.parametrize("robot_name", ["solo12", "go2"])
@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
@pytest.mark.parametrize("name", ["contactnet", "fixed"])
def test_the_compiled_plan_is_the_python_plan(robot_name, gait, name, monkeypatch):
    robot = load_robot(robot_name)
    gait = gait.scaled(robot.description.size_scale)
    model = model_path(robot_name, gait.name)
    compiled = make_planner(name, gait, robot, model=model)
    python = make_planner(name, gait, robot, model=model)
    python._one_level = None  # every plan step by step in Python
    made = []  # how many steps each compiled call made (fewer than the plan's: Python made the plan)
    kernel = plan_kernel.plan_steps
    monkeypatch.setattr(plan_kernel, "plan_steps", lambda *args: made.append(kernel(*args)) or made[-1])
    stands = captured = 0
    for removed, seed in ((0, 0), (100, 1), (170, 2)):
        terrain = resolve("random", removed=removed, seed=seed)
        for ctx in _contexts(gait, robot, terrain, 60, seed):
            got, want = compiled.plan(ctx), python.plan(ctx)
            assert [_as_tuple(s) for s in got] == [_as_tuple(s) for s in want]
            assert compiled.last_candidates.order.tolist() == python.last_candidates.order.tolist()
            assert compiled.last_candidates.chosen == python.last_candidates.chosen
            stands += sum(not s.legs for s in got)
            captured += got[0].captured
    # the compiled path made most plans, and the cases it covers occurred; it stopped at once for a leg left behind
    assert sum(m == gait.steps_per_plan for m in made) >= 100
    assert name == "fixed" or made.count(0) >= 5
    assert captured >= 30 and (name == "fixed" or stands > 0 or robot_name == "solo12" and gait.name == "trot")
