"""The live session's runs: waiting for the first viewer, the count-down, the end of a run and the loop,
notices, terrain edits with and without a restart, and compare mode (app/live/session.py, app/live/compare.py)."""

from __future__ import annotations

import time

import pytest
from helpers import make_session, short_flat

from app.live import editor
from app.live.commands import (
    ApplyPush,
    CommandConflict,
    EditTerrain,
    RedoTerrainEdit,
    Reset,
    SetCompare,
    SetLoop,
    SetPaused,
    SetSpeed,
    SetTerrain,
    SetVelocity,
    UndoTerrainEdit,
    ViewerConnected,
)
from app.live.view import status_line
from app.viewer.panels.status import details_markdown, run_markdown
from contactnet.terrain import flat

pytestmark = pytest.mark.app


def test_waits_for_the_first_viewer_then_counts_down(tmp_path):
    live = make_session(tmp_path, flat())
    try:
        view = live.view
        assert view.run.waiting_for_viewer and not view.status.running
        assert status_line(view).startswith("waiting for a browser")
        with pytest.raises(CommandConflict, match="paused|waiting"):
            live.call(ApplyPush(5.0, 0.0, 1.0))  # the clock stands still: a push cannot act
        time.sleep(0.4)
        assert live.view.snapshot.t_s == 0.0  # nothing moves before a viewer comes
        live.call(ViewerConnected())
        view = live.view
        assert not view.run.waiting_for_viewer and 0.0 < view.run.starts_in_s <= 0.3
        assert not view.status.running and status_line(view).startswith("starting in")
        view = live.wait_view(lambda v: v.snapshot.t_s > 0.2, timeout=5)
        assert view.status.running and view.run.starts_in_s is None
        live.call(ViewerConnected())  # a second browser changes nothing
        assert live.view.status.running
    finally:
        live.stop()


def test_an_explicit_run_needs_no_viewer(tmp_path):
    live = make_session(tmp_path, flat())
    try:
        live.call(SetPaused(False))
        view = live.view
        assert not view.run.waiting_for_viewer and view.run.starts_in_s is None and view.status.running
    finally:
        live.stop()


def test_a_run_ends_is_summed_up_and_the_loop_starts_the_next(tmp_path):
    live = make_session(tmp_path, short_flat(), vx_m_s=0.2, wait_for_viewer=False)
    try:
        live.call(SetSpeed(2.0))
        view = live.wait_view(lambda v: v.run.runs == 1, timeout=20)
        last = view.run.last_run
        assert view.status.done == "goal reached" and not view.status.running
        assert last.index == 1 and last.success and last.reason == "goal reached" and last.reached_x_m >= 0.06
        assert last.steps == view.snapshot.steps > 0 and last.t_s == pytest.approx(view.snapshot.t_s)
        assert last.rank_mean is None and last.planner == "heuristic"  # the heuristic planner does not rank
        counts = last.counts
        assert (counts.stand_steps, counts.swing_retargets) == (0, 0) and 0 <= counts.useless_steps <= last.steps
        assert f"stood 0 · useless {counts.useless_steps} · swing retargets 0" in run_markdown(view)  # the card
        assert view.run.progress == 1.0 and 0.0 < view.run.restart_in_s <= 0.5
        assert "GOAL REACHED; next run in" in status_line(view)
        assert "RTF – ·" in details_markdown(view)  # no real-time factor while it stands still (not 0.00)
        view = live.wait_view(lambda v: v.status.done is None and v.snapshot.t_s > 0.0, timeout=5)
        assert view.run.runs == 1 and view.run.restart_in_s is None and view.run.progress < 1.0
        assert view.run.last_run == last  # the card's run stays until the next one ends
    finally:
        live.stop()


def test_a_pause_holds_the_loops_count_down(tmp_path):
    """Paused while the next run counts down: the robot stays where it ended (no restart behind the back of
    whoever paused it, a click on a disk still names what is drawn); Run lets the count-down go on."""
    live = make_session(tmp_path, short_flat(), vx_m_s=0.2, wait_for_viewer=False, loop_delay_s=0.6)
    try:
        live.call(SetSpeed(2.0))
        live.wait_view(lambda v: v.run.runs == 1, timeout=20)
        live.call(SetPaused(True))
        held = live.view.run.restart_in_s
        assert held is not None and 0.0 < held <= 0.6
        time.sleep(1.2)  # twice the loop's delay
        view = live.view
        assert view.run.runs == 1 and view.status.done == "goal reached" and view.status.paused
        assert view.run.restart_in_s == held and "paused, next run" in status_line(view)
        live.call(SetPaused(False))
        view = live.wait_view(lambda v: v.status.done is None and v.snapshot.t_s > 0.0, timeout=5)
        assert view.run.runs == 1 and not view.status.paused
    finally:
        live.stop()


def test_loop_off_stays_at_the_end_and_on_again_restarts(tmp_path):
    live = make_session(tmp_path, short_flat(), vx_m_s=0.2, wait_for_viewer=False, loop=False)
    try:
        live.call(SetSpeed(2.0))
        view = live.wait_view(lambda v: v.run.runs == 1, timeout=20)
        assert view.run.restart_in_s is None and not view.run.loop
        time.sleep(0.8)
        assert live.view.status.done == "goal reached"  # no loop: the end stays
        live.call(SetLoop(True))
        assert live.view.run.restart_in_s is not None
        live.call(SetLoop(False))
        assert live.view.run.restart_in_s is None
        live.call(Reset())
        assert live.view.status.done is None and live.view.status.running
    finally:
        live.stop()


def test_edits_away_from_the_robot_apply_without_a_restart(tmp_path):
    live = make_session(tmp_path, flat(), vx_m_s=0.1, wait_for_viewer=False)
    try:
        view = live.wait_view(lambda v: v.snapshot.t_s > 1.0, timeout=10)
        version, seq = view.terrain_version, view.notices[-1].seq if view.notices else 0
        assert live.call(EditTerrain(editor.punch_hole, ((2.012, 0.012),))) is True
        view = live.view
        assert view.snapshot.t_s > 1.0 and view.status.running  # no restart
        assert view.terrain_version == version + 1 and not view.terrain.is_safe([[2.012, 0.012]])[0]
        assert view.notices[-1].seq == seq + 1 and "without a restart" in view.notices[-1].text
        live.call(UndoTerrainEdit())
        assert live.view.terrain.is_safe([[2.012, 0.012]])[0] and live.view.snapshot.t_s > 1.0
        assert live.view.terrain_can_redo
        live.call(RedoTerrainEdit())
        assert not live.view.terrain.is_safe([[2.012, 0.012]])[0] and not live.view.terrain_can_redo
        x = float(live.view.snapshot.q[0])
        assert live.call(EditTerrain(editor.punch_hole, ((x + 0.2, 0.15),))) is True  # under the front feet
        view = live.view
        assert view.snapshot.t_s == 0.0 and view.status.paused  # restarted, waits for "run"
        assert view.notices[-1].level == "warning" and "restarted" in view.notices[-1].text
    finally:
        live.stop()


def test_compare_mode_runs_two_robots_with_the_same_command(tmp_path):
    live = make_session(tmp_path, flat(), vx_m_s=0.1, wait_for_viewer=False)
    try:
        live.call(SetCompare(("heuristic", "fixed")))  # no fixed-gait model here: it runs the heuristic
        view = live.view
        assert view.compare is not None and len(view.compare) == 1
        other = view.compare[0]
        assert (other.planner, other.planner_active) == ("fixed", "heuristic")
        # both restarted together (the session thread runs on: on a busy machine it may have ticked already)
        assert view.snapshot.t_s < 0.5 and other.snapshot.t_s == pytest.approx(view.snapshot.t_s, abs=0.02)
        assert "Compare mode" in view.notices[-1].text
        view = live.wait_view(lambda v: v.snapshot.t_s > 1.5, timeout=30)
        other = view.compare[0]
        assert other.snapshot.t_s == pytest.approx(view.snapshot.t_s, abs=0.02)  # one clock
        assert other.x_m > 0.05 and other.steps > 0 and other.foot_pos_world.shape == (4, 3)
        live.call(SetVelocity(0.0, 0.1))
        assert live.view.compare[0].snapshot.vel_cmd_xy == (0.0, 0.1)
        live.call(SetCompare(()))
        assert live.view.compare is None and "off" in live.view.notices[-1].text
        with pytest.raises(ValueError, match="two planner names"):
            live.call(SetCompare(("heuristic",)))
        with pytest.raises(ValueError, match="unknown planner"):
            live.call(SetCompare(("heuristic", "nope")))
    finally:
        live.stop()


def test_compare_runs_end_together(tmp_path):
    live = make_session(tmp_path, short_flat(), vx_m_s=0.2, wait_for_viewer=False, loop=False)
    try:
        live.call(SetCompare(("heuristic", "heuristic")))
        live.call(SetSpeed(2.0))
        view = live.wait_view(lambda v: v.run.runs == 1, timeout=30)
        compare = view.run.last_run.compare
        assert compare is not None and len(compare) == 1 and compare[0].success
    finally:
        live.stop()


def test_a_new_terrain_restarts_every_robot(tmp_path):
    live = make_session(tmp_path, flat(), vx_m_s=0.1, wait_for_viewer=False)
    try:
        live.call(SetCompare(("heuristic", "heuristic")))
        live.wait_view(lambda v: v.snapshot.t_s > 0.5, timeout=10)
        live.call(SetTerrain(short_flat(1.0), "short"))
        view = live.view
        assert view.snapshot.t_s == 0.0 and view.compare[0].snapshot.t_s == 0.0 and view.run.goal_x_m == 1.0
    finally:
        live.stop()


def _far_raised_stone(data):  # noqa: ANN001, ANN202 - an edit (terrain dict -> terrain dict)
    """A 20 cm stone 5 cm high, 5 m beside the start: far from the robot, but a terrain with heights now."""
    from contactnet.terrain.edits import validated

    return validated({**data, "regions": [*data["regions"], {"shape": "rect", "center": [0.0, 5.0],
                                                             "size": [0.2, 0.2], "z": 0.05}]})


def test_the_robot_takes_its_stance_for_the_terrain_and_an_edit_that_changes_the_kind_restarts_it(tmp_path):
    """Solo12 stands wider on terrain of one level (``Robot.for_terrain``): its abduction joints at the standing
    start are 0.1 rad further out than the SRDF's; an edit that gives the terrain heights, however far away, restarts
    it in the SRDF's stance and says why; undone, the wider stance again."""
    import numpy as np

    from contactnet.robots import load_robot

    nominal = load_robot("solo12").joint_standing[0::3]  # FL, FR, HL, HR abduction
    live = make_session(tmp_path, flat(), vx_m_s=0.0, wait_for_viewer=False, paused=True)
    try:
        abduction = np.asarray(live.view.snapshot.q[7::3])
        np.testing.assert_allclose(np.abs(abduction - nominal), 0.1, atol=0.02)  # wider, standing
        assert live.call(EditTerrain(_far_raised_stone)) is True
        view = live.view
        assert view.terrain.has_heights and view.snapshot.t_s == 0.0
        assert "stance and gains for terrain with heights" in view.notices[-1].text
        np.testing.assert_allclose(np.asarray(view.snapshot.q[7::3]), nominal, atol=0.02)
        live.call(UndoTerrainEdit())
        view = live.view
        assert not view.terrain.has_heights and "stance and gains for terrain of one level" in view.notices[-1].text
        np.testing.assert_allclose(np.abs(np.asarray(view.snapshot.q[7::3]) - nominal), 0.1, atol=0.02)
    finally:
        live.stop()


def test_a_push_refused_at_the_end_says_when_the_next_run_starts_or_to_reset():
    from app.live.runs import RunClock

    clock = RunClock(wait_for_viewer=False, viewer_start_delay_s=0.0, loop=True, loop_delay_s=6.0)
    clock.over = True
    clock.restart_at = time.perf_counter() + 4.2
    assert clock.held_because(None, "goal") == "done (goal): the next run starts in 4 s"
    clock.hold(True)  # paused on the card (P): the count-down holds, and the refusal says so
    assert clock.held_because(None, "goal").startswith("done (goal), paused: the next run starts 4 s after Run")
    clock.hold(False)
    clock.restart_at = None  # the loop is off: it stays at the end
    assert clock.held_because(None, "fell") == "done (fell): reset it first (R)"
