"""The disturbance observer (contactnet.planning.observer): it estimates a push from the CoM momentum, the controller
cancels it and the capture step leans into it; below its threshold nothing changes."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from contactnet.locomotion import Locomotion, LocomotionConfig
from contactnet.motion.controller import WholeBodyController
from contactnet.motion.gait import WALK
from contactnet.planning.capture import CaptureConfig, capture_offset
from contactnet.planning.heuristic import HeuristicPlanner
from contactnet.planning.observer import DEFAULT_OBSERVER, DisturbanceObserver, ObserverConfig
from contactnet.terrain import flat


def _momentum_run(observer: DisturbanceObserver, external_xy: tuple[float, float], ticks: int, seed: int = 0,
                  quiet_ticks: int = 100) -> np.ndarray:
    """Feed the observer a body of its mass under random ground forces, integrated exactly: ``quiet_ticks`` without
    an external force (the observer's start, ``ObserverConfig`` warm-up included), then ``ticks`` with
    ``external_xy``; returns the body's velocity at the end."""
    rng = np.random.default_rng(seed)
    vel = np.zeros(3)
    observer.update(vel, np.zeros((4, 3)))
    for tick in range(quiet_ticks + ticks):
        external = (0.0, 0.0) if tick < quiet_ticks else external_xy
        applied = rng.normal(0.0, 3.0, (4, 3))
        total = applied.sum(axis=0) + np.array([external[0], external[1], -9.81 * observer.mass_kg])
        vel = vel + observer.dt_s / observer.mass_kg * total
        observer.update(vel, applied)
    return vel


def test_the_estimate_follows_a_step_of_force_as_the_critically_damped_observer_does():
    """Both poles at -w: a constant force F is seen as ``F (1 - (1 + w t) e^(-w t))`` (the continuous closed form,
    the reference; the 1 kHz update approximates it to within w dt of the force)."""
    w = 40.0
    observer = DisturbanceObserver(ObserverConfig(bandwidth_rad_s=w, threshold_m_s2=0.8), mass_kg=2.5, dt_s=1e-3)
    force = (3.0, -5.0)
    for ticks in (10, 30, 54, 100, 200, 1000):
        observer.reset()
        _momentum_run(observer, force, ticks)
        t = ticks * 1e-3
        share = 1.0 - (1.0 + w * t) * math.exp(-w * t)
        assert observer.estimate_x_n == pytest.approx(force[0] * share, abs=w * 1e-3 * abs(force[0]))
        assert observer.estimate_y_n == pytest.approx(force[1] * share, abs=w * 1e-3 * abs(force[1]))
    assert observer.estimate_y_n == pytest.approx(force[1], rel=1e-6)  # after 1 s: the force itself
    assert observer.max_estimate_n >= math.hypot(*force) * (1 - 1e-6)


def test_ticks_whose_forces_are_not_known_hold_the_estimate():
    """A tick whose ground forces are not known (``known=False``: a stance leg stretched straight, whose torques do
    not tell the force along it) holds the estimate, however far the velocity moves, and the ticks after it go on
    from the measured velocity."""
    observer = DisturbanceObserver(ObserverConfig(bandwidth_rad_s=40.0), mass_kg=2.5, dt_s=1e-3)
    _momentum_run(observer, (4.0, 0.0), 500)
    held = (observer.estimate_x_n, observer.estimate_y_n)
    assert held[0] == pytest.approx(4.0, rel=1e-4)
    vel = np.array([0.3, 0.0, 0.0])
    for _ in range(200):  # the 20 N forward read from the torques are not what the ground gave: the body slows down
        vel = vel + 1e-3 / 2.5 * np.array([-6.0, 0.0, 0.0])
        observer.update(vel, np.array([[20.0, 0.0, 0.0]] + [[0.0, 0.0, 0.0]] * 3), known=False)
        assert (observer.estimate_x_n, observer.estimate_y_n) == held
    for _ in range(500):  # known again, no push: the estimate returns to zero from the measured velocity
        observer.update(vel, np.zeros((4, 3)))
    assert abs(observer.estimate_x_n) < 1e-3 and abs(observer.estimate_y_n) < 1e-3


def test_the_optimizer_plans_with_an_estimate_only_when_it_rose_suddenly():
    """A push is sudden; a slow mismatch is not (a foot's contact on a square's edge: a force nobody commanded that
    grew over a second). Both read 4 N and the controller and the capture step use both; the optimizer plans
    with the first only, and keeps doing so until the estimate drops below the threshold."""
    config = ObserverConfig(threshold_m_s2=0.8, onset_s=0.2)
    drift = DisturbanceObserver(config, mass_kg=2.5, dt_s=1e-3)
    for tick in range(1500):  # 0 to 4 N over 1 s, then 4 N: commanded forward, not delivered
        commanded = np.array([[4.0 * min(1.0, tick / 1000), 0.0, 0.0]] + [[0.0, 0.0, 0.0]] * 3)
        drift.update(np.array([0.05, 0.0, 0.0]), commanded)
    assert drift.estimate_x_n == pytest.approx(-4.0, rel=1e-2)
    assert drift.force_for("feedforward") is not None and drift.force_for("plan") is None
    push = DisturbanceObserver(config, mass_kg=2.5, dt_s=1e-3)
    vel = _momentum_run(push, (-4.0, 0.0), 300)  # the same 4 N, at once
    assert push.force_for("plan") == pytest.approx((-4.0, 0.0), abs=0.05)
    for _ in range(300):  # then the feet cancel it: the body keeps its velocity, the estimate stays in use
        push.update(vel, np.array([[4.0, 0.0, 0.0]] + [[0.0, 0.0, 0.0]] * 3))
    assert push.force_for("plan") is not None


def test_a_noisy_first_velocity_is_not_taken_for_a_push():
    """The observer's start: the velocity is the mean of the first 1 / w s of measurements (here a body at rest,
    measured with 0.05 m/s of noise), so its first estimates stay at the noise's level. Over the first 0.1 s of
    each of 100 starts, the largest estimate: median below 2 N, all below 3 N (a single first sample taken as the
    velocity gave a transient of up to m w |error| / e: a median of 2.9 N, up to 6.5 N)."""
    rng = np.random.default_rng(3)
    observer = DisturbanceObserver(ObserverConfig(bandwidth_rad_s=40.0), mass_kg=2.5, dt_s=1e-3)
    largest = []
    for _ in range(100):
        observer.reset()
        for _ in range(100):
            observer.update(np.array([*rng.normal(0.0, 0.05, 2), 0.0]), np.zeros((4, 3)))
        largest.append(observer.max_estimate_n)
    assert np.median(largest) < 2.0 and max(largest) < 3.0


@pytest.mark.parametrize("w", [20.0, 40.0, 80.0])
def test_velocity_noise_reaches_the_estimate_as_the_formula_says(w):
    """White noise of std sigma on each measured velocity (1 kHz) gives the estimate a std of ``m w^1.5 sqrt(sigma^2
    dt) / 2`` (the module doc; the first version's differentiated momentum gave about ``m sigma / sqrt(2 tau dt)``,
    10 times more at these settings): checked on 20 s of a body at rest."""
    mass, dt, sigma = 2.5, 1e-3, 0.05
    observer = DisturbanceObserver(ObserverConfig(bandwidth_rad_s=w), mass_kg=mass, dt_s=dt)
    rng = np.random.default_rng(7)
    estimates = []
    for _ in range(20_000):
        observer.update(np.array([*rng.normal(0.0, sigma, 2), 0.0]), np.zeros((4, 3)))
        estimates.append((observer.estimate_x_n, observer.estimate_y_n))
    measured = np.std(np.asarray(estimates)[2000:], axis=0)
    expected = mass * w**1.5 * math.sqrt(sigma**2 * dt) / 2.0
    np.testing.assert_allclose(measured, expected, rtol=0.12)


def test_below_its_threshold_the_estimate_is_not_used():
    observer = DisturbanceObserver(ObserverConfig(threshold_m_s2=0.8, lean=False), mass_kg=2.5, dt_s=1e-3)
    _momentum_run(observer, (1.0, 1.0), 500)
    assert observer.active_force_xy() is None  # |F| = 1.41 N
    _momentum_run(observer, (0.0, 2.5), 500)
    x, y = observer.active_force_xy()
    assert x == pytest.approx(0.0, abs=1e-5) and y == pytest.approx(2.5, rel=1e-5)  # the jump between the runs decays
    assert observer.force_for("feedforward") == (x, y) and observer.force_for("lean") is None  # lean off


def test_the_controller_cancels_what_the_plan_does_not_hold():
    """The trajectory optimizer plans with the estimate at its re-solves (``plan``); between them the controller
    cancels the estimate less the force the active plan holds, and after the push what the plan still holds."""
    observer = DisturbanceObserver(DEFAULT_OBSERVER, mass_kg=2.5, dt_s=1e-3)
    assert observer.feedforward_world(None) is None  # nothing estimated, nothing planned
    _momentum_run(observer, (0.0, 5.0), 1000)
    now = np.array([*observer.active_force_xy(), 0.0])
    assert observer.force_for("plan") == observer.active_force_xy()
    np.testing.assert_allclose(observer.feedforward_world(None), now)  # a plan solved before the push
    np.testing.assert_allclose(observer.feedforward_world(now), 0.0, atol=1e-12)  # a plan solved with it
    np.testing.assert_allclose(observer.feedforward_world(np.array([0.0, 3.0, 0.0])), now - [0.0, 3.0, 0.0])
    observer.reset()
    np.testing.assert_allclose(observer.feedforward_world(now), -now)  # the push is over: the plan still holds it
    off = DisturbanceObserver(ObserverConfig(feedforward=False, plan=False), mass_kg=2.5, dt_s=1e-3)
    _momentum_run(off, (0.0, 5.0), 1000)
    assert off.feedforward_world(now) is None and off.force_for("plan") is None


def test_the_observer_is_on_by_default_and_a_trial_without_it_is_named(tmp_path):
    from contactnet.jobs.experiment import trial_inputs, trials_of
    from contactnet.jobs.replay import trial_from_record

    assert LocomotionConfig().observer == DEFAULT_OBSERVER
    plain, without = trials_of("push", 1, ("walk",), ("contactnet",)), trials_of("push", 1, ("walk",), ("contactnet",),
                                                                                  observer=False)
    assert [t.key + "/no-observer" for t in plain] == [t.key for t in without]
    assert "observer" not in trial_inputs(plain[0])["trial"]  # the default stack's fingerprint names no part
    assert trial_inputs(without[0])["trial"]["observer"] is False
    old = {"key": "x", "trial": {k: v for k, v in dataclasses.asdict(plain[0]).items() if k != "observer"}}
    assert trial_from_record(old).observer is False  # a record from before the observer existed ran without it


@pytest.mark.parametrize("field", ["bandwidth_rad_s", "threshold_m_s2"])
@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf")])
def test_a_bad_setting_names_its_field(field, value):
    with pytest.raises(ValueError, match=field):
        ObserverConfig(**{field: value})


def test_the_capture_step_leans_into_a_known_force():
    config = CaptureConfig(velocity_error_m_s=0.15, gain_s=0.15, max_offset_m=0.08, max_offset_with_force_m=0.12)
    cmd = np.array([0.05, 0.0])
    still = np.array([0.05, 0.0, 0.0])
    assert capture_offset(still, cmd, 0.0, config) is None
    assert capture_offset(still, cmd, 0.0, config, None, 0.01) is None  # no force: as without
    dx, dy = capture_offset(still, cmd, 0.0, config, (0.0, 7.5), 0.01)  # no velocity error: the lean alone
    assert dx == 0.0 and dy == pytest.approx(0.075)
    dx, dy = capture_offset(np.array([0.05, 0.4, 0.0]), cmd, 0.0, config, (0.0, 7.5), 0.01)
    assert dy == pytest.approx(0.12)  # 0.06 + 0.075, clipped to max_offset_with_force_m
    assert capture_offset(still, cmd, 0.0, None, (0.0, 7.5), 0.01) is None  # capture off


def test_the_controller_cancels_the_external_force(robot):
    from test_controller import standing_target

    controller = WholeBodyController(robot)
    q, v = robot.q_standing.copy(), np.zeros(18)
    target = standing_target(controller, q, v, robot.mass_kg)
    controller.torques(q, v, target)
    without = controller.last_forces.sum(axis=0)
    pushed = dataclasses.replace(target, external_force_world=np.array([3.0, -2.0, 0.0]))
    controller.torques(q, v, pushed)
    # up to the feedback's regularization (ControllerGains.force_regularization), about 0.05 %
    np.testing.assert_allclose(controller.last_forces.sum(axis=0), without + [-3.0, 2.0, 0.0], atol=5e-3)


def test_undisturbed_walking_runs_exactly_as_without_the_observer(robot):
    summaries = []
    for observer in (DEFAULT_OBSERVER, None):
        config = LocomotionConfig(observer=observer)
        with Locomotion(robot, flat(), WALK, HeuristicPlanner(WALK), config=config, vel_cmd_xy=(0.1, 0.0)) as loco:
            summaries.append(loco.run(3.0))
    with_observer, without = summaries
    assert 0.0 < with_observer["max_external_force_n"] < ObserverConfig().threshold_m_s2 * robot.mass_kg
    assert without["max_external_force_n"] == 0.0
    for key in ("wall_time_s", "max_external_force_n", "planner_ms", "trajopt_ms"):
        del with_observer[key], without[key]
    assert with_observer == without


def test_noisy_base_sensors_do_not_look_like_a_push(robot):
    """The robustness experiment's sensor case (0.05 m/s on the measured base velocity, 0.01 rad, 0.05 rad/s), 3 s
    walking on flat: the estimate stays about its threshold at most (the first observer, which differentiated the
    velocity, read 5 N median and up to 19 N there) and the walk goes on."""
    from contactnet.sim.mismatch import ModelMismatch
    from contactnet.sim.pybullet_world import SimConfig

    noisy = SimConfig(mismatch=ModelMismatch(orientation_noise_rad=0.01, lin_vel_noise_m_s=0.05,
                                             ang_vel_noise_rad_s=0.05))
    with Locomotion(robot, flat(), WALK, HeuristicPlanner(WALK), noisy, vel_cmd_xy=(0.05, 0.0)) as loco:
        summary = loco.run(3.0)
    assert not summary["fell"]
    assert 0.3 < summary["max_external_force_n"] < 1.5 * ObserverConfig().threshold_m_s2 * robot.mass_kg


@pytest.mark.slow
def test_the_walk_withstands_a_sideways_push_it_fell_under_before():
    """A push experiment trial (push_field seed 0, +7.5 N along y for 1 s at 4 s) in which the shipped walk tipped
    over its left feet without the observer (roll -0.95 rad at 4.85 s): with it (``experiment push --observer``),
    it braces while pushed and walks on."""
    from contactnet.jobs.experiment import Trial, run_trial

    record = run_trial(Trial("push", "push_field", None, 0, "walk", "contactnet", 0.05, 0.0, None, push_t0_s=4.0,
                             push_force_xy=(0.0, 7.5), observer=True))
    assert not record["fell"], record["fall_reason"]
    assert 6.0 < record["max_external_force_n"] < 15.0  # the push, as estimated
    assert record["brace_steps"] >= 1


def test_a_summary_tells_observer_rows_apart():
    from test_paper import _record

    from contactnet.jobs.summary import format_summary, summarize

    def trial(observer):
        return {"gait": "walk", "planner": "contactnet", "removed": None, "noise": 0.0, "seed": 0,
                "push_force_xy": [0.0, 7.5], "push_t0_s": 4.0, "observer": observer}

    key = "push_field/push0,7.5@4/seed0/walk/contactnet/noise0"
    records = [_record(key + "/no-observer", trial(False), False), _record(key, trial(True), True)]
    rows = summarize("push", records)["rows"]
    assert [(r["observer"], r["successes"]) for r in rows] == [(False, 0), (True, 1)]
    assert "observer" in format_summary({"rows": rows})
    assert "observer" not in format_summary({"rows": rows[1:]})  # the default stack: no column, as before
    legacy = {k: v for k, v in trial(False).items() if k != "observer"}  # a record from before the observer
    assert summarize("push", [_record(key, legacy, True)])["rows"][0]["observer"] is False


def test_bracing_stands_a_two_legged_step_while_a_push_lasts():
    from contactnet.motion.gait import TROT
    from contactnet.planning.brace import BraceConfig, braces, standing_horizon
    from contactnet.planning.ranking import PlannedStep

    config = BraceConfig(threshold_m_s2=1.2)  # 3 N on 2.5 kg
    trot_step = PlannedStep(legs=(0, 3), footholds_xy_world=np.zeros((2, 2)))
    walk_step = PlannedStep(legs=(1,), footholds_xy_world=np.zeros((1, 2)))
    assert braces(config, (0.0, 3.0), trot_step, 2.5) and braces(config, (-2.5, -2.5), trot_step, 2.5)
    assert not braces(config, (2.0, 2.0), trot_step, 2.5)  # 2.83 N: below the threshold
    assert not braces(config, (0.0, 9.0), trot_step, 16.0)  # 19.2 N on a robot of 16 kg
    assert not braces(config, None, trot_step, 2.5) and not braces(None, (0.0, 9.0), trot_step, 2.5)  # no push; off
    assert braces(config, (0.0, 9.0), walk_step, 2.5)  # the walk braces too (by default)
    assert not braces(BraceConfig(min_swinging_legs=2), (0.0, 9.0), walk_step, 2.5)  # the trot only
    horizon = standing_horizon(TROT, 3)
    assert [(s.legs, s.action_index, s.footholds_xy_world.shape) for s in horizon] == [((), TROT.stand_index, (0, 2))] * 3
    for field, value in (("threshold_m_s2", -1.0), ("threshold_m_s2", float("nan")), ("min_swinging_legs", 0),
                         ("touchdown_s", 0.0), ("min_remaining_s", float("inf")), ("outward_m", -0.01),
                         ("outward_m", 0.2), ("outward_m", float("nan"))):
        with pytest.raises(ValueError, match=field):
            BraceConfig(**{field: value})


def test_a_foot_bracing_puts_down_on_the_push_side_lands_outward():
    """``outward_shift``: ``outward_m`` along the push for a foot whose offset from the CoM points along it, nothing
    for a foot on the other side, without a push or with 0 m; ``touchdown_point`` lands the shifted point if it is
    safe ground, else the point under the foot, else where it lifted off (a foot over a hole)."""
    from contactnet.planning.brace import outward_shift, touchdown_point
    from contactnet.terrain import Terrain

    com = np.array([0.0, 0.0])
    push = np.array([0.0, 30.0])  # toward +y
    left, right = np.array([0.25, 0.09]), np.array([0.25, -0.09])
    assert np.allclose(outward_shift(left, com, push, 0.05), [0.0, 0.05])
    assert np.allclose(outward_shift(left, com, np.array([30.0, 30.0]), 0.05), [0.05 / math.sqrt(2.0)] * 2)
    assert outward_shift(right, com, push, 0.05) is None
    assert outward_shift(left, com, None, 0.05) is None and outward_shift(left, None, push, 0.05) is None
    assert outward_shift(left, com, push, 0.0) is None and outward_shift(left, com, np.zeros(2), 0.05) is None
    # ground from x = -1 to 1 m, y = -1 to 0.15 m: the left foot's outward point (y 0.14) is 1 cm inside it, not a
    # foot radius (2 cm); at 0.10 m it is 5 cm inside
    ground = Terrain(name="t", start_xy=(0.0, 0.0), goal_x=1.0,
                     regions=[{"shape": "rect", "center": [0.0, -0.425], "size": [2.0, 1.15]}])
    foot = np.array([0.25, 0.09, 0.05])
    liftoff = np.array([0.2, 0.0, 0.02])
    assert np.allclose(touchdown_point(ground, foot, liftoff, 0.02, np.array([0.0, 0.01])), [0.25, 0.10, 0.0])
    assert np.allclose(touchdown_point(ground, foot, liftoff, 0.02, np.array([0.0, 0.05])), [0.25, 0.09, 0.0])
    assert np.allclose(touchdown_point(ground, foot, liftoff, 0.02), [0.25, 0.09, 0.0])
    over_hole = np.array([0.25, 0.2, 0.05])
    assert np.allclose(touchdown_point(ground, over_hole, liftoff, 0.02, np.array([0.0, 0.05])), [0.2, 0.0, 0.0])


def test_a_trot_pushed_from_the_side_braces_and_walks_on(robot):
    """7.5 N along -y for 1 s on flat: the steps planned while the push is estimated stand on four feet, the trot
    steps again after it, and nothing falls; without bracing the same push is met by stepping."""
    from contactnet.motion.gait import TROT
    from contactnet.sim.pybullet_world import Push

    counts = {}
    for brace in (True, False):
        config = LocomotionConfig() if brace else LocomotionConfig(brace=None)
        with Locomotion(robot, flat(), TROT, HeuristicPlanner(TROT), config=config, vel_cmd_xy=(0.05, 0.0)) as loco:
            loco.push(Push(1.5, 1.0, (0.0, -7.5, 0.0)))
            summary = loco.run(4.0)
            during = [r for r in loco.records if 1.6 < r.t_s < 2.4]
            after = [r for r in loco.records if r.t_s > 3.0]
        assert not summary["fell"], summary["fall_reason"]
        counts[brace] = summary["brace_steps"]
        if brace:
            assert during and all(r.braced and not r.legs for r in during)
            assert after and all(r.legs and not r.braced for r in after)  # stepping again
    assert counts[True] >= 2 and counts[False] == 0


def test_the_com_reference_moves_with_its_velocity_on_a_leash_to_the_com():
    """``ComReference.advance``: one tick of the velocity, then back along the line to the CoM within the leash;
    with no velocity it moves only when the CoM goes beyond the leash (a pushed body pulls it along)."""
    from contactnet.motion.com_reference import ComReference

    ref = ComReference(np.array([1.0, 2.0, 0.3]), leash_m=0.05, dt_s=0.001)
    ref.advance(np.array([1.0, 2.0]), np.array([0.1, -0.2]))
    assert np.allclose(ref.xy_world, [1.0001, 1.9998])
    ref = ComReference(np.array([1.0, 2.0]), leash_m=0.05, dt_s=0.001)
    for _ in range(1000):  # 1 s at 0.1 m/s with the CoM standing: 10 cm asked, the leash keeps 5
        ref.advance(np.array([1.0, 2.0]), np.array([0.1, 0.0]))
    assert np.allclose(ref.xy_world, [1.05, 2.0], atol=1e-12)
    ref.advance(np.array([1.01, 2.02]), np.zeros(2))  # still, the CoM within the leash (4.5 cm): it stays
    assert np.allclose(ref.xy_world, [1.05, 2.0], atol=1e-12)
    ref.advance(np.array([0.9, 2.0]), np.zeros(2))  # the CoM pushed 15 cm from it: pulled to 5 cm of the CoM
    assert np.allclose(ref.xy_world, [0.95, 2.0], atol=1e-12)
    tied = ComReference(np.zeros(2), leash_m=0.0, dt_s=0.001)  # no leash: the reference is the CoM
    tied.advance(np.array([0.3, -0.2]), np.array([0.1, 0.0]))
    assert np.allclose(tied.xy_world, [0.3, -0.2], atol=1e-12)
    for leash in (-0.1, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="leash"):
            ComReference(np.zeros(2), leash, 0.001)


def test_a_braced_robot_holds_its_com_still_and_walks_on_after_the_push(robot):
    """Trot at 0.1 m/s pushed with 7.5 N from the side for 1 s: while it braces the CoM reference stands, so the body
    stays over its four feet (measured: 1.8 mm along the command over its 0.94 s braced); with ``hold_reference=False`` the
    reference goes on with the command and the body creeps 9.1 cm forward over feet that do not step. Both stand, and
    the held robot walks on once the push is over."""
    from contactnet.motion.gait import TROT
    from contactnet.planning.brace import BraceConfig
    from contactnet.sim.pybullet_world import Push

    creep_m = {}
    for hold in (True, False):
        config = LocomotionConfig(brace=BraceConfig(hold_reference=hold))
        with Locomotion(robot, flat(), TROT, HeuristicPlanner(TROT), config=config, vel_cmd_xy=(0.1, 0.0)) as loco:
            loco.push(Push(1.5, 1.0, (0.0, -7.5, 0.0)))
            braced_x = []
            while loco.sim.t_s < 3.5 and not loco.done:
                loco.advance(20)
                if loco.plan.braced:
                    braced_x.append(float(loco.controller.last_com[0]))
            x_end = float(loco.controller.last_com[0])
            summary = loco.summary()
        assert not summary["fell"], summary["fall_reason"]
        assert len(braced_x) >= 40  # braced for 0.8 s or more
        creep_m[hold] = braced_x[-1] - braced_x[0]
        if hold:
            assert x_end - braced_x[-1] > 0.05  # walking on after the push (0.1 m/s for about 1 s)
    assert abs(creep_m[True]) < 0.01 and creep_m[False] > 0.06, creep_m


def test_a_push_as_the_trot_lifts_its_diagonal_puts_the_feet_down_again(robot):
    """7.5 N along +y for 1 s, starting just after a trot diagonal lifted off on flat ground: with bracing's
    touchdown the swinging feet come down on safe ground at once, the body gathers half the sideways speed it
    gathers when they swing on to their landings (the same push, ``touch_down=False``: 0.18 against 0.37 m/s
    measured, and that run tipped over) and the robot stands."""
    from contactnet.motion.gait import TROT
    from contactnet.planning.brace import BraceConfig
    from contactnet.sim.pybullet_world import Push

    t_push_s = 6 * TROT.step_duration_s + TROT.liftoff_s + 0.01
    peaks, touchdowns = {}, {}
    for touch_down in (True, False):
        config = LocomotionConfig(brace=BraceConfig(touch_down=touch_down))
        with Locomotion(robot, flat(), TROT, HeuristicPlanner(TROT), config=config, vel_cmd_xy=(0.05, 0.0)) as loco:
            loco.push(Push(t_push_s, 1.0, (0.0, 7.5, 0.0)))
            loco.run(t_push_s)
            assert loco.plan.swings and not loco.plan.touched.any()  # a diagonal in the air
            peak = 0.0
            while loco.sim.t_s < t_push_s + 0.6 and not loco.done:
                loco.advance(10)
                peak = max(peak, float(loco.controller.last_com_vel[1]))
            summary = loco.run(t_push_s + 2.0)
        if touch_down:
            assert not summary["fell"], summary["fall_reason"]
        peaks[touch_down], touchdowns[touch_down] = peak, summary["brace_touchdowns"]
    assert touchdowns[True] == 1 and touchdowns[False] == 0
    assert peaks[True] < 0.7 * peaks[False], peaks


@pytest.mark.slow
def test_a_contact_the_torques_explain_is_not_taken_for_a_push(robot):
    """Table II's seed 3 (random field, 110 squares removed, ContactNet walk): the rear leg stretched behind the
    standing robot delivers 2-3 N backwards that the commanded forces leave out (the legs' weight), and later a
    front leg goes straight. Read from the commanded forces, the estimate crept to 6 N and the walk fell at 15.8 s;
    read from the forces the torques deliver, with the straight leg's ticks held, it stays under the threshold
    (1.2 N measured) and the walk crosses."""
    from contactnet.jobs.experiment import Trial, run_trial

    record = run_trial(Trial("table2", "random", 110, 3, "walk", "contactnet"))
    assert record["success"], record["fall_reason"]
    assert record["max_external_force_n"] < ObserverConfig().threshold_m_s2 * robot.mass_kg


@pytest.mark.slow
@pytest.mark.parametrize("force_y_n", [10.0, -10.0])
def test_standing_on_flat_ground_the_wider_stance_holds_a_side_push_that_tips_the_srdf_stance(force_y_n, capsys):
    """Solo12 standing (vx 0) on flat ground, pushed 10 N from the side for 1 s: ``contactnet simulate`` walks the
    robot its terrain gives it (``Robot.for_terrain``: feet 2.2 cm wider on terrain of one level) and it stands; the
    same loop with the SRDF's stance (the robot as loaded, the reference) tips over its feet. 11 N tips both (measured:
    docs/how-it-works.md, "A wider stance on terrain of one level")."""
    import json

    from contactnet import registry
    from contactnet.cli import main
    from contactnet.sim.world import Push

    push = f"1,1,0,{force_y_n}"
    assert main(["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "contactnet", "--vx", "0",
                 "--duration", "4", "--push", push, "--json"]) == 0
    wide = json.loads(capsys.readouterr().out)
    assert wide["stance_abduction_rad"] == pytest.approx(0.1) and not wide["fell"], wide["fall_reason"]
    robot = registry.load_robot("solo12")  # the SRDF's stance, not the one for this terrain
    gait = registry.gait_for("walk", robot)
    with Locomotion(robot, flat(), gait, registry.make_planner("contactnet", gait, robot)) as loco:
        loco.push(Push.parse(push))
        srdf = loco.run(4.0)
    assert srdf["stance_abduction_rad"] == 0.0 and srdf["fell"] and "tilted" in srdf["fall_reason"]


def test_bracing_puts_a_foot_on_the_push_side_down_outward(robot):
    """Solo12's walk on flat, pushed with 6 N toward its left 20 ms after its front-left foot lifted: bracing's
    touchdown lands that foot ``outward_m`` (2 cm here) beyond where it is, along the estimated push, and where it is
    with 0 (Solo12's own, on every terrain); the same foot pushed from the right lands where it is, and the walks
    stand. A robot's own ``brace_outward_m`` is taken on terrain of one level only."""
    from contactnet.planning.brace import BraceConfig
    from contactnet.robots import load_robot
    from contactnet.sim.pybullet_world import Push

    def touchdown(outward_m: float | None, push_y_n: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        config = LocomotionConfig(brace=BraceConfig(outward_m=outward_m))
        with Locomotion(robot, flat(), WALK, HeuristicPlanner(WALK), config=config, vel_cmd_xy=(0.05, 0.0)) as loco:
            while not (loco.plan is not None and 0 in loco.plan.swings
                       and loco.sim.t_s >= loco.plan.swings[0].t0_s + 0.02):
                loco.advance(1)
                assert loco.sim.t_s < 5.0, "the front-left foot never lifted"
            loco.push(Push(loco.sim.t_s, 1.0, (0.0, push_y_n, 0.0)))
            for _ in range(150):  # the estimate reaches the threshold within 0.15 s
                loco.advance(1)
                if loco.brace_touchdowns:
                    break
            assert loco.brace_touchdowns == 1, "bracing never put the foot down"
            estimate = np.asarray(loco.observer.active_force_xy())
            swing = loco.plan.swings[0]  # from where the foot was when bracing put it down
            foot, end = swing.start_world.copy(), swing.end_world.copy()
            summary = loco.run(loco.sim.t_s + 1.0)
        assert not summary["fell"], summary["fall_reason"]
        return foot, end, estimate / np.hypot(*estimate)

    for outward_m in (0.02, None):  # None: Solo12's own, 0
        foot, end, along = touchdown(outward_m, 6.0)
        assert along[1] > 0.9  # the estimate points left
        assert np.allclose(end[:2] - foot[:2], (outward_m or 0.0) * along, atol=1e-9)
    foot, end, _ = touchdown(0.02, -6.0)  # pushed from the left side: the left foot lands where it is
    assert np.allclose(end[:2], foot[:2], atol=1e-9)
    assert robot.description.brace_outward_m == 0.0 and load_robot("go2").description.brace_outward_m == 0.05
    assert BraceConfig().outward_on(0.05, heights=False) == 0.05  # a robot's 5 cm
    assert BraceConfig().outward_on(0.05, heights=True) == 0.0
    assert BraceConfig(outward_m=0.03).outward_on(0.05, heights=True) == 0.03  # the loop's own, everywhere
