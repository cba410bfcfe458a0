"""Stand steps and swing retargets in a real headless browser (Debian chromium, software WebGL; issue 14): the
oracle planner stands on flat ground with a zero command, and the page says "standing (planner's choice)" in the
status panel and above the robot, outlines its four feet and draws the stand band in the gait plot; with
retargeting switched on by the panel's checkbox, a ContactNet trot whose command jumps retargets a swing, and the
new landing flashes (a cyan ring and a line from the old landing) while the panel counts it. Asserts on the scene
nodes and the DOM; screenshots go to $CONTACTNET_ARTIFACTS (else artifacts/)."""

from __future__ import annotations

import time

import numpy as np
import pytest
from helpers import (
    ARTIFACTS,
    browser_marks,
    chromium,
    live_app,
    open_viser,
    viser_client,
    wait_for,
)

from app.live.commands import SetGait, SetPaused, SetPlanner, SetVelocity
from app.live.view import STANDING
from app.scene.marks import HIDDEN_POS
from app.viewer.panels.plots import STAND_BAND

pytestmark = browser_marks()


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    app = live_app(tmp_path_factory, terrain="flat", planner="oracle", gait="walk", vx_m_s=0.0)
    yield app
    app.close()


@pytest.fixture(scope="module")
def page(live):
    with chromium() as browser:
        yield open_viser(browser, live.viser_port)


def look_at(app, point: np.ndarray, offset: tuple[float, float, float]) -> None:
    """This browser's camera, free, looking at ``point`` from ``point + offset`` (a close look for a screenshot)."""
    client = viser_client(app)
    mode, _ = app.viewer.panel.camera.controls[client.client_id]
    mode.value = "free"
    wait_for(lambda: not app.viewer.panel.camera.following(client.client_id), what="the camera free")
    client.camera.position = tuple(np.asarray(point) + offset)
    client.camera.look_at = tuple(point)
    time.sleep(2.0)  # software WebGL draws the new view


def test_a_stand_by_choice_shows_in_the_3d_view_the_panel_and_the_gait_plot(live, page):
    app = live
    wait_for(lambda: not app.session.view.run.waiting_for_viewer, timeout=30, what="the session to start")
    app.session.wait_view(lambda v: v.counts.stand_steps >= 3, timeout=90)
    marks = app.viewer.scene.marks
    wait_for(lambda: marks.standing, what="the stand marks")
    assert marks.stand_label.visible and marks.stand_outline.visible and marks.stand_label.text == STANDING
    assert app.session.view.snapshot.steps == 0  # standing, not stepping
    # in the page: the status panel's headline (viser draws the label above the robot in the canvas, not the DOM)
    page.locator("strong", has_text=f"{STANDING} · ").first.wait_for()  # BROWSER_TIMEOUT_MS: the first frames
    page.get_by_text("stood ").first.wait_for(timeout=30_000)  # the panel's counts
    stand_past = 9  # the gait plot's series: t, 4 legs, 4 legs planned, stand, stand planned
    plot = app.viewer.panel.plots.gait_plot
    wait_for(lambda: np.max(plot.data[stand_past]) > STAND_BAND[0] + 0.5 * STAND_BAND[1], what="the stand band")
    assert np.max(plot.data[stand_past + 1]) > STAND_BAND[0] + 0.5 * STAND_BAND[1]  # planned stands too
    time.sleep(2.0)
    page.screenshot(path=str(ARTIFACTS / "stand_view.png"), timeout=120_000)  # standing, the clock running
    app.session.call(SetPaused(True))
    look_at(app, app.session.view.snapshot.q[:3] - [0.0, 0.0, 0.2], (-0.45, -0.6, 0.5))
    page.screenshot(path=str(ARTIFACTS / "stand_close.png"), timeout=120_000)
    page.get_by_text("Gait schedule").first.scroll_into_view_if_needed()
    time.sleep(1.5)
    page.screenshot(path=str(ARTIFACTS / "stand_gait_plot.png"), timeout=120_000)


def test_a_retargeted_swing_flashes_at_its_new_landing(live, page):
    app = live
    app.session.call(SetGait("trot"))
    app.session.call(SetPlanner("contactnet"))  # random weights; retargeting ranks the swinging legs again
    app.session.call(SetVelocity(0.05, 0.0))
    checkbox = page.get_by_role("checkbox", name="Retarget swings")
    checkbox.dispatch_event("click")  # no scrolling: see the e2e test
    wait_for(lambda: app.session.view.status.retarget, timeout=30, what="retargeting on from the checkbox")
    assert app.session._loco.config.retarget is not None
    mode, _ = app.viewer.panel.camera.controls[viser_client(app).client_id]
    mode.value = "follow"
    app.session.call(SetPaused(False))
    for _attempt in range(3):  # the command jumps: the measured velocity is far off it, as after a push
        app.session.wait_view(lambda v: v.snapshot.t_s > 0.5, timeout=60)
        app.session.call(SetVelocity(0.3, 0.0))
        view = app.session.wait_view(lambda v: v.counts.swing_retargets >= 1 or v.status.done is not None,
                                     timeout=60)
        app.session.call(SetPaused(True))  # the clock stops: the flash stays on screen
        if view.counts.swing_retargets >= 1:
            break
        app.session.call(SetVelocity(0.05, 0.0))
        app.session.call(SetPaused(False))  # fell first: the loop restarts it
        app.session.wait_view(lambda v: v.status.done is None and v.snapshot.t_s < 0.3, timeout=60)
    else:
        pytest.fail("no swing retargeted in three runs")
    marks = app.viewer.scene.marks
    wait_for(lambda: marks.flashes, timeout=30, what="the flash drawn")
    flash = marks.flashes[-1]
    ring = np.asarray(marks.rings.batched_positions)[len(marks.flashes) - 1]
    np.testing.assert_allclose(ring[:2], flash.new_world[:2], atol=1e-6)
    assert not np.array_equal(ring, HIDDEN_POS) and marks.lines.visible
    assert np.hypot(*(flash.new_world - flash.old_world)[:2]) >= 0.02
    retargets = app.session.view.counts.swing_retargets
    page.get_by_text(f"swing retargets {retargets}").first.wait_for(timeout=30_000)  # the status panel counts it
    assert app.state().swing_retargets == retargets
    page.get_by_text(f"swing retargets {retargets}").first.scroll_into_view_if_needed()
    time.sleep(2.0)
    page.screenshot(path=str(ARTIFACTS / "retarget_view.png"), timeout=120_000)
    look_at(app, flash.new_world, (-0.3, -0.4, 0.45))
    page.screenshot(path=str(ARTIFACTS / "retarget_close.png"), timeout=120_000)
    mode.value = "follow"
