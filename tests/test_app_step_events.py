"""Stand steps and swing retargets in the web tool (issue 14): what the views carry (`app/live/step_events.py`,
`app/live/view.py`), how the 3D view marks them (`app/scene/marks.py`), the panel's words, and the retarget setting
of the live session. Real Locomotion runs (PyBullet), no browser (tests/test_app_marks_browser.py has one)."""

from __future__ import annotations

import dataclasses
from functools import partial

import numpy as np
import pytest
from helpers import save_random_models, wait_for

from app.live.commands import ApplyPush, Reset, SetPaused, SetPlanner, SetRetarget, SetVelocity
from app.live.planners import default_planner_factory
from app.live.session import LiveSession
from app.live.settings import ServeSettings
from app.live.step_events import FLASH_S, LiveCounts, RetargetFlash, StepEvents, loco_config, use_retarget
from app.live.view import STANDING, ViewTracker, is_stand, stand_chart, status_line
from app.recordings.recorder import quiet_viser_server, stop_quietly, view_of
from app.scene.live_scene import LiveScene
from app.scene.marks import HIDDEN_POS, PULSE_GROWTH, PULSES, RETARGET_COLOR, flash_style
from app.viewer.panels.status import details_markdown, status_markdown
from contactnet import registry
from contactnet.locomotion import Locomotion
from contactnet.planning.retarget import RetargetedSwing
from contactnet.sim.pybullet_world import SimConfig
from contactnet.terrain import flat

pytestmark = pytest.mark.app  # the web tool: `pytest -m "not app"` skips these


def test_an_oracle_that_stands_is_shown_standing(robot):
    """Zero command on flat: the oracle stands from its first step (walk); the views say so everywhere."""
    gait = registry.gait_by_name("walk")
    planner = registry.make_planner("oracle", gait, robot)
    with Locomotion(robot, flat(), gait, planner, SimConfig(), vel_cmd_xy=(0.0, 0.0)) as loco:
        tracker = ViewTracker(robot, loco.terrain, gait)
        while loco.t_s < 1.0:
            loco.advance(20)
            view = view_of(loco, tracker)
        summary = loco.summary()
    assert summary["stand_steps"] >= 3 and summary["steps"] == 0  # standing: no step taken
    assert view.counts == LiveCounts(plans=len(loco.records), stand_steps=summary["stand_steps"],
                                     useless_steps=summary["useless_steps"], swing_retargets=0,
                                     capture_steps=summary["capture_steps"])
    assert is_stand(view.snapshot) and status_line(view).startswith(f"{STANDING} · ")
    assert f"stood {summary['stand_steps']}" in status_line(view)
    assert f"stood {summary['stand_steps']}" in details_markdown(view) and "retargeting off" in details_markdown(view)
    assert view.stand_history.all() and len(view.stand_history) == len(view.stance_history)
    # Told to walk, a robot that stands a step is walking (the label does not flip step by step; "stood" counts).
    walking = dataclasses.replace(view, snapshot=dataclasses.replace(view.snapshot, vel_cmd_xy=(0.05, 0.0)))
    assert is_stand(walking.snapshot) and status_line(walking).startswith("walking · ")
    assert f"stood {summary['stand_steps']}" in status_line(walking)
    assert view.planned_stand.all() and len(view.planned_stand) == len(view.planned_contact)
    past, planned = stand_chart(view)
    assert past.max() == 1.0 and planned.max() == 1.0  # the stand band: done and planned
    # the plan ahead follows the stand horizons (a stand is a plan, not a step)
    assert view.plan_t0_s == pytest.approx(view.snapshot.t_s // gait.step_duration_s * gait.step_duration_s,
                                           abs=gait.step_duration_s + 1e-9)


def test_a_contactnet_model_that_stands_is_shown_standing(robot, tmp_path):
    """A model with N_a + 1 outputs (the stand choice) that ranks standing first: the ContactNet planner stands,
    its candidates keep their ranking with no disk chosen, and the scene marks the stand."""
    save_random_models(tmp_path, stand=True)
    gait = registry.gait_by_name("trot")
    planner, active, _ = default_planner_factory("contactnet", gait, robot, model_dir=tmp_path)
    assert active == "contactnet"
    with Locomotion(robot, flat(), gait, planner, SimConfig(), vel_cmd_xy=(0.0, 0.0)) as loco:
        tracker = ViewTracker(robot, loco.terrain, gait)
        while loco.t_s < 0.8:
            loco.advance(20)
            view = view_of(loco, tracker)
    assert is_stand(view.snapshot) and view.counts.stand_steps >= 2 and view.snapshot.steps == 0
    assert view.snapshot.planned_steps[0].action_index == gait.stand_index
    assert view.candidates.rank is not None and view.candidates.chosen == ()  # ranked, none chosen
    server = quiet_viser_server()
    try:
        scene = LiveScene(server, robot)
        scene.update(view)
        assert scene.marks.standing and scene.marks.stand_label.visible
    finally:
        stop_quietly(server)


def test_a_walk_is_not_standing(robot):
    gait = registry.gait_by_name("walk")
    with Locomotion(robot, flat(), gait, registry.make_planner("heuristic", gait, robot), SimConfig(),
                    vel_cmd_xy=(0.1, 0.0)) as loco:
        tracker = ViewTracker(robot, loco.terrain, gait)
        while loco.t_s < 0.6:
            loco.advance(20)
            view = view_of(loco, tracker)
    assert not is_stand(view.snapshot) and status_line(view).startswith("walking")
    assert view.counts.stand_steps == 0 and "stood" not in status_line(view)
    assert not view.stand_history.any() and stand_chart(view)[0].max() == 0.0


def test_a_retargeted_swing_flashes(robot, random_models):
    """Retargeting on, the command jumps from 0.05 to 0.3 m/s (the measured velocity is then far off it, as after
    a push): a swing's landing moves; the views carry it (old and new landing) for FLASH_S, then no more; turning
    retargeting off stops further ones."""
    gait = registry.gait_by_name("trot")
    planner, _, _ = default_planner_factory("contactnet", gait, robot, model_dir=random_models)
    with Locomotion(robot, flat(), gait, planner, SimConfig(), config=loco_config(True),
                    vel_cmd_xy=(0.05, 0.0)) as loco:
        loco.advance(500)
        loco.set_command(0.3, 0.0)
        events = StepEvents()
        flashes = ()
        while loco.swing_retargets == 0 and loco.t_s < 2.5 and not loco.done:
            loco.advance(10)
            counts, flashes = events.update(loco)
        assert loco.swing_retargets >= 1 and flashes, "no retarget"
        assert counts.swing_retargets == loco.swing_retargets
        swings = {leg: s for leg, s in loco.plan.swings.items() if isinstance(s, RetargetedSwing)}
        for flash in flashes:
            swing = swings[flash.leg]
            np.testing.assert_allclose(flash.new_world, swing.end_world)
            np.testing.assert_allclose(flash.old_world, swing.base.end_world)
            assert flash.t_s == swing.t_retarget_s <= loco.t_s
            assert np.hypot(*(flash.new_world - flash.old_world)[:2]) >= 0.02  # RetargetConfig.min_shift_m
        first = flashes[0].t_s
        use_retarget(loco, False)
        assert loco.config.retarget is None
        retargets = loco.swing_retargets
        while loco.t_s < first + FLASH_S + 0.05 and not loco.done:
            loco.advance(10)
            counts, flashes = events.update(loco)
        assert all(f.t_s > first for f in flashes)  # the first flash is over
        assert loco.swing_retargets == retargets  # off: no more
    use_retarget(loco, True)
    assert loco.config.retarget is not None and loco_config(False).retarget is None


def test_the_scene_marks_a_stand_and_a_flash(robot):
    """The stand outline and label, and a retarget ring pulsing at the new landing with a line from the old."""
    gait = registry.gait_by_name("walk")
    server = quiet_viser_server()
    try:
        scene = LiveScene(server, robot)
        marks = scene.marks
        with Locomotion(robot, flat(), gait, registry.make_planner("oracle", gait, robot), SimConfig()) as loco:
            tracker = ViewTracker(robot, loco.terrain, gait)
            loco.advance(300)
            standing = view_of(loco, tracker)
        assert is_stand(standing.snapshot)
        scene.update(standing)
        assert marks.standing and marks.stand_label.visible and marks.stand_outline.visible
        assert marks.stand_label.text == STANDING
        feet = np.asarray(marks.stand_outline.points)[:, 0]
        np.testing.assert_allclose(np.sort(feet[:, 0]), np.sort(standing.foot_pos_world[:, 0]), atol=1e-5)
        assert np.all(np.abs(feet[:, 2]) < 0.01)  # on the ground
        assert not marks.flashes and np.all(np.asarray(marks.rings.batched_positions) == HIDDEN_POS)

        t = standing.snapshot.t_s
        flash = RetargetFlash(t - 0.5 * FLASH_S / PULSES, 1, np.array([0.2, -0.15, 0.016]), np.array([0.25, -0.1, 0.016]))
        flashing = dataclasses.replace(standing, seq=standing.seq + 1, retarget_flashes=(flash,))
        scene.update(flashing)
        assert marks.flashes == (flash,) and marks.lines.visible
        ring = np.asarray(marks.rings.batched_positions)[0]
        np.testing.assert_allclose(ring[:2], flash.new_world[:2], atol=1e-6)
        assert 0.0 < ring[2] < 0.02  # just over the ground (and the gold disk of the old choice)
        assert np.asarray(marks.rings.batched_scales)[0, 0] == pytest.approx(1.0 + PULSE_GROWTH)  # a pulse's height
        line = np.asarray(marks.lines.points)[0]
        np.testing.assert_allclose(line[:, :2], [flash.old_world[:2], flash.new_world[:2]], atol=1e-6)

        scene.update(dataclasses.replace(standing, seq=standing.seq + 2))  # the flash is over
        assert not marks.flashes and not marks.lines.visible
        assert np.all(np.asarray(marks.rings.batched_positions) == HIDDEN_POS)
    finally:
        stop_quietly(server)


def test_flash_style_pulses_and_ends_cyan():
    assert flash_style(0.0)[0] == 1.0 and np.array_equal(flash_style(0.0)[1], RETARGET_COLOR)
    scales = [flash_style(a)[0] for a in np.linspace(0.0, FLASH_S, 301)]
    peaks = [k for k in range(1, 300) if scales[k - 1] < scales[k] >= scales[k + 1]]
    assert len(peaks) == PULSES and max(scales) == pytest.approx(1.0 + PULSE_GROWTH)
    assert flash_style(FLASH_S)[0] == pytest.approx(1.0)


@pytest.fixture(scope="module")
def session(tmp_path_factory, random_models):
    live = LiveSession(
        ServeSettings(planner="contactnet", gait="trot", vx_m_s=0.05, wait_for_viewer=False),
        flat(),
        "flat",
        planner_factory=partial(default_planner_factory, model_dir=random_models),
        robot_cache_dir=tmp_path_factory.mktemp("cache"),
    ).start()
    yield live
    live.stop()


def test_the_live_session_turns_retargeting_on_without_a_restart(session):
    view = session.wait_view(lambda v: v.snapshot.t_s > 0.3, timeout=30)
    assert not view.status.retarget and session._loco.config.retarget is None  # off by default
    session.call(SetRetarget(True))
    view = session.view
    assert view.status.retarget and session._loco.config.retarget is not None
    assert view.snapshot.t_s > 0.3  # no restart
    assert "retargeting on" in view.notices[-1].text.lower()
    assert "retargeting on" in details_markdown(view)
    session.call(ApplyPush(0.0, 3.0, 0.2))  # a push, and a command far from the velocity: swings retarget
    session.call(SetVelocity(0.3, 0.0))
    view = session.wait_view(lambda v: v.counts.swing_retargets >= 1 or v.snapshot.fell, timeout=30)
    assert view.counts.swing_retargets >= 1, view.status.done
    assert view.retarget_flashes or session.wait_view(lambda v: bool(v.retarget_flashes), timeout=5)
    session.call(SetPaused(True))
    assert "swing retargets" in status_markdown(session.view)
    session.call(SetPlanner("oracle"))  # a rebuild keeps the setting
    assert session._loco.config.retarget is not None and session.view.counts.swing_retargets == 0
    session.call(SetRetarget(False))
    assert not session.view.status.retarget and session._loco.config.retarget is None
    session.call(SetVelocity(0.0, 0.0))
    session.call(Reset())
    view = session.wait_view(lambda v: v.counts.stand_steps >= 2, timeout=30)
    assert "stood" in status_line(view)
    session.call(SetPaused(True))
    wait_for(lambda: session.view.status.paused, what="paused")
