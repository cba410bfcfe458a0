"""The capture step (contactnet.planning.capture): after a push the first step's candidate grid moves towards the capture
point; below the threshold the plan is exactly the plan without it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import save_random_models

from contactnet.bench.planner import planning_contexts
from contactnet.motion.gait import TROT, WALK
from contactnet.planning.capture import CaptureConfig, capture_offset
from contactnet.planning.planner import ContactNetPlanner
from contactnet.registry import make_planner
from contactnet.terrain import random_field, random_heights


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    folder = tmp_path_factory.mktemp("models")
    save_random_models(folder)
    return {"walk": folder / "walk.pt", "trot": folder / "trot.pt"}


def test_the_offset_is_the_clipped_raibert_correction_beyond_the_threshold():
    config = CaptureConfig(velocity_error_m_s=0.15, gain_s=0.15, max_offset_m=0.08)
    cmd = np.array([0.05, 0.0])
    assert capture_offset(np.array([0.15, 0.1, 0.0]), cmd, 0.0, config) is None  # |error| 0.141 <= 0.15
    assert capture_offset(np.array([0.05, 0.4, 0.0]), cmd, 0.0, None) is None  # off
    dx, dy = capture_offset(np.array([0.05, 0.4, 0.0]), cmd, 0.0, config)
    assert dx == 0.0 and dy == pytest.approx(0.06)
    dx, dy = capture_offset(np.array([-1.0, -0.3, 0.0]), cmd, 0.0, config)
    assert dx == -0.08 and dy == pytest.approx(-0.045)  # x clipped to max_offset_m
    assert capture_offset(np.array([np.nan, 0.0, 0.0]), cmd, 0.0, config) is None
    # the command is in the heading frame: heading along +y, a command of 0.05 forward is 0.05 along world y
    assert capture_offset(np.array([0.0, 0.05, 0.0]), cmd, np.pi / 2, config) is None
    dx, dy = capture_offset(np.array([0.2, 0.0, 0.0]), cmd, np.pi / 2, config)
    assert dx == pytest.approx(0.03) and dy == pytest.approx(-0.0075)


@pytest.mark.parametrize("field", ["velocity_error_m_s", "gain_s", "max_offset_m"])
@pytest.mark.parametrize("value", [-0.1, float("nan"), float("inf")])
def test_a_bad_setting_names_its_field(field, value):
    with pytest.raises(ValueError, match=field):
        CaptureConfig(**{field: value})


def _pushed(ctx, velocity_xy):
    return dataclasses.replace(ctx, com_vel_world=np.array([*velocity_xy, 0.0]))


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
@pytest.mark.parametrize("name", ["contactnet", "fixed"])
def test_a_pushed_first_step_is_chosen_on_the_shifted_grid(robot, models, gait, name):
    """With a velocity error beyond the threshold, step 1 is the step the planner without capture chooses with its
    grid centred on the shifted base (on one level the grid is all the base moves; a pushed step does not ask which
    leg is left behind, ``contactnet.planning.reach``, so neither does that reference); steps 2 and 3 are not
    shifted. Within the threshold the plan is the plan without capture, step for step."""
    terrain = random_field(100, 1)
    on = make_planner(name, gait, robot, model=models[gait.name])
    off = make_planner(name, gait, robot, model=models[gait.name])
    off.capture = None
    shifted = make_planner(name, gait, robot, model=models[gait.name])
    shifted.capture = shifted.reach = None
    captured = 0
    for k, ctx in enumerate(planning_contexts(gait, terrain, robot.description, 30, seed=3)):
        error = np.array([0.0, 0.35 if k % 2 else -0.5])  # along y: one within the clip, one beyond it
        pushed = _pushed(ctx, ctx.vel_cmd_world() + error)
        offset = np.clip(on.capture.gain_s * error, -on.capture.max_offset_m, on.capture.max_offset_m)
        for planner in (on, off, shifted):
            planner.reset()
            if name == "fixed":
                planner._next_group = k % len(gait.cyclic_order)
        step = on.plan(pushed)[0]
        reference = shifted.plan(dataclasses.replace(pushed, base_xy_world=pushed.base_xy_world + offset))[0]
        assert step.captured and not reference.captured
        assert (step.legs, step.action_index, step.rank) == (reference.legs, reference.action_index, reference.rank)
        np.testing.assert_allclose(step.footholds_xy_world, reference.footholds_xy_world, atol=1e-12)
        captured += step.captured
        calm = _pushed(ctx, ctx.vel_cmd_world() + np.array([0.1, 0.0]))
        for planner in (on, off):
            planner.reset()
        plans = [planner.plan(calm) for planner in (on, off)]
        for a, b in zip(*plans, strict=True):
            assert not a.captured
            assert (a.legs, a.action_index, a.rank) == (b.legs, b.action_index, b.rank)
            np.testing.assert_array_equal(a.footholds_xy_world, b.footholds_xy_world)
    assert captured == 30


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_a_pushed_step_on_terrain_with_heights_lands_on_safe_ground(robot, models, gait):
    terrain = random_heights(60, 2)
    planner = make_planner("contactnet", gait, robot, model=models[gait.name])
    for ctx in planning_contexts(gait, terrain, robot.description, 10, seed=5):
        step = planner.plan(_pushed(ctx, ctx.vel_cmd_world() + np.array([0.3, -0.3])))[0]
        assert step.captured
        if step.action_index is not None:
            assert terrain.is_safe(step.footholds_xy_world, planner.margin_m).all()


class _WantsToStand:
    """A stand-in model with the stand choice that always ranks standing first."""

    def __init__(self, gait) -> None:
        self.gait, self.n_actions, self.path = gait.name, gait.n_choices, "<stands>"
        self._scores = np.linspace(0.0, 0.5, gait.n_choices)
        self._scores[-1] = 1.0

    def scores(self, u):
        return self._scores


@pytest.mark.parametrize("gait", [WALK, TROT], ids=lambda g: g.name)
def test_a_pushed_robot_steps_rather_than_stands(robot, gait):
    planner = ContactNetPlanner(gait, robot.description, _WantsToStand(gait))
    ctx = planning_contexts(gait, random_field(0, 0), robot.description, 1, seed=0)[0]
    assert all(step.legs == () for step in planner.plan(ctx))  # undisturbed: it stands
    steps = planner.plan(_pushed(ctx, ctx.vel_cmd_world() + np.array([0.4, 0.0])))
    assert steps[0].legs != () and steps[0].captured
    assert all(step.legs == () for step in steps[1:])  # the later steps are not pushed


@pytest.mark.slow
def test_the_pushed_trot_catches_itself_on_holed_ground(robot):
    """The push experiment's trial that made the shipped trot fall before the capture step (push_field seed 5, +5 N
    along y for 1 s at 11.5 s: the body drifted sideways until the HL thigh touched the ground): it stands, and
    every landing is safe. With bracing (the default) it stands on four feet while pushed; without, it catches
    itself with capture steps."""
    from contactnet import registry
    from contactnet.jobs.experiment import PUSH_DURATION_S, PUSH_SETTLE_S
    from contactnet.locomotion import Locomotion, LocomotionConfig
    from contactnet.sim.pybullet_world import Push, SimConfig
    from contactnet.terrain import resolve

    gait = registry.gait_by_name("trot")
    terrain = resolve("push_field")
    planner = registry.make_planner("contactnet", gait, robot)
    for config in (LocomotionConfig(), LocomotionConfig(brace=None)):
        with Locomotion(robot, terrain, gait, planner, SimConfig(seed=5), config=config,
                        vel_cmd_xy=(0.05, 0.0)) as loco:
            loco.push(Push(11.5, PUSH_DURATION_S, (0.0, 5.0, 0.0)))
            summary = loco.run(11.5 + PUSH_DURATION_S + PUSH_SETTLE_S)
        assert not summary["fell"], summary["fall_reason"]
        assert summary["brace_steps" if config.brace else "capture_steps"] >= 1
        assert summary["unsafe_landings"] == 0
