"""The 3D view in a real headless browser (Debian chromium, software WebGL), opened on its own page:
a click on a candidate disk names it in the legend and in a label next to it, an orbit keeps the
camera following the robot and Re-center brings the default view back, the compare mode's ghost
robot, and viser's software-WebGL toast closing by itself. Screenshots go to artifacts/."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from helpers import (
    ARTIFACTS,
    browser_marks,
    camera_offset,
    chromium,
    live_app,
    open_viser,
    screen_xy,
    viser_client,
    wait_for,
)

from app.live.commands import SetCompare, SetPaused, SetPlanner, SetVelocity
from app.scene.camera import place_camera
from app.scene.live_scene import describe_candidate

pytestmark = browser_marks()


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    app = live_app(tmp_path_factory, terrain="stepping_stones", planner="contactnet", vx_m_s=0.05)
    yield app
    app.close()


@pytest.fixture(scope="module")
def page(live):
    with chromium() as browser:
        page = open_viser(browser, live.viser_port)
        yield page


def test_the_software_webgl_toast_closes_by_itself(live, page):
    page.get_by_text("Software WebGL rendering").first.wait_for(state="hidden")  # BROWSER_TIMEOUT_MS


def test_a_click_on_a_disk_names_it(live, page):
    app = live
    wait_for(lambda: app.session.view.run.waiting_for_viewer is False, what="the session to start")
    wait_for(lambda: app.session.view.snapshot.steps >= 3, timeout=60, what="a few steps")
    client = viser_client(app)
    reports = []  # the poses the browser says it draws with (its reports come after it drew them)

    @client.camera.on_update
    async def _(camera) -> None:  # noqa: ANN001 - async: run on viser's event loop, in arrival order
        reports.append((np.array(camera.position), np.array(camera.look_at)))

    app.session.call(SetPaused(True))  # (the random ContactNet falls at times: the pause holds the loop's restart)
    scene = app.viewer.scene
    wait_for(lambda: scene._drawn[0] is app.session.view.candidates, what="the disks drawn")
    # The clicked point is worked out from the camera, so the camera is put (free mode: nothing moves it) at a
    # pose of the test's own, from above the disks, and the click waits for the browser to report that pose: a
    # software renderer on a busy machine draws (and reports) a pose seconds after it was sent. (Waiting for the
    # following camera to settle instead never ends when the robot lay still before the test: no report comes.)
    control = app.viewer.panel.camera
    control.set_mode(client, "free")
    try:
        cand, positions = scene._drawn
        n = min(len(cand.xy_world), len(positions))
        look_at = positions[:n].mean(axis=0)
        position = look_at + np.array([-0.35, -0.45, 1.0])
        place_camera(client, position, look_at, force=True)
        wait_for(lambda: reports and np.allclose(reports[-1][0], position, atol=1e-3)
                 and np.allclose(reports[-1][1], look_at, atol=1e-3), timeout=60, what="the browser to draw the pose")
        click_a_disk(app, page, client, scene, cand, positions)
    finally:
        control.set_mode(client, "follow")


def click_a_disk(app, page, client, scene, cand, positions) -> None:  # noqa: ANN001
    """Click the disk drawn (at ``positions``) clearest of the others and of the feet; the legend names it."""
    n = min(len(cand.xy_world), len(positions))
    feet = app.session.view.foot_pos_world
    size = (page.viewport_size["width"], page.viewport_size["height"])
    on_screen = [(i, screen_xy(client.camera, positions[i], size)) for i in range(n)]
    on_screen = [(i, xy) for i, xy in on_screen if xy is not None and 100 < xy[0] < 900 and 100 < xy[1] < 800]
    assert on_screen, "no disk on screen"
    # the disk drawn farthest (on the screen) from every other disk and every foot: a click there hits it and
    # nothing in front of it, wherever the robot stopped (a far disk among many was hit behind a nearer one)
    others = [xy for xy in (screen_xy(client.camera, p, size) for p in (*positions[:n], *feet)) if xy is not None]

    def room(xy) -> float:  # noqa: ANN001
        return min((math.dist(xy, o) for o in others if math.dist(xy, o) > 1e-9), default=math.inf)
    index, (x, y) = max(on_screen, key=lambda item: room(item[1]))
    page.mouse.click(x, y)
    legend = app.viewer.panel.legend
    expected = describe_candidate(cand, index, scene.leg_names).text()
    try:
        wait_for(lambda: expected in legend.picked.content, timeout=30, what=f"the legend to name disk {index}")
    except AssertionError as error:
        raise AssertionError(f"{error}: clicked ({x:.0f}, {y:.0f}) px, {room((x, y)):.0f} px from the nearest "
                             f"other disk or foot; the legend says {legend.picked.content!r}") from None
    assert scene._pick_labels[client.client_id].text == expected
    page.get_by_text(expected).first.wait_for(timeout=30_000)  # shown in the panel (and next to the disk)
    time.sleep(1.5)
    page.screenshot(path=str(ARTIFACTS / "viser_disk_click.png"), timeout=120_000)


def test_an_orbit_keeps_following_and_recenter_restores_the_view(live, page):
    app = live
    app.terrains.load("flat")
    app.session.call(SetPlanner("heuristic"))  # a steady walk (the test's ContactNet has random weights)
    app.session.call(SetPaused(True))
    client = viser_client(app)
    camera = app.viewer.panel.camera
    mode, recenter = camera.controls[client.client_id]
    recenter_offset = lambda: camera_offset(app, client)  # noqa: E731
    seen = [recenter_offset().copy()]

    def settled() -> bool:  # the camera glides (an orbit's damping too, frame by frame); a software renderer on a
        time.sleep(3.0)     # busy machine draws a frame a second or less, and reports its poses late
        seen.append(recenter_offset().copy())
        return np.linalg.norm(seen[-1] - seen[-2]) < 1e-3

    page.get_by_role("button", name="Re-center").dispatch_event("click")  # no scrolling: see the e2e test
    wait_for(settled, timeout=60, what="the re-centred view to settle")
    default = recenter_offset().copy()
    page.mouse.move(300, 600)  # orbit: drag on the 3D view, left of the panel
    page.mouse.down()
    for k in range(1, 11):
        page.mouse.move(300 + 20 * k, 600 - 6 * k)
        time.sleep(0.05)
    page.mouse.up()
    wait_for(lambda: np.linalg.norm(recenter_offset() - default) > 0.2, timeout=60, what="the orbit reported")
    seen.append(recenter_offset().copy())
    wait_for(settled, timeout=60, what="the orbit to settle")  # the last (late) reports of the drag are in
    assert camera.following(client.client_id)
    orbited = seen[-1]
    app.session.call(SetVelocity(0.15, 0.0))
    app.session.call(SetPaused(False))
    x0, look0 = app.session.view.snapshot.q[0], client.camera.look_at[0]
    wait_for(lambda: app.session.view.snapshot.q[0] > x0 + 0.1, timeout=60, what="the robot to walk 10 cm")
    wait_for(lambda: client.camera.look_at[0] > look0 + 0.05, timeout=30, what="the camera to come along")
    offset = recenter_offset()
    assert np.linalg.norm(offset - orbited) < 0.1, (  # at the user's angle
        f"offset {offset}, the user's {orbited}, the control's {camera._browsers[client.client_id].offset}")
    app.session.call(SetPaused(True))
    page.screenshot(path=str(ARTIFACTS / "viser_after_orbit.png"), timeout=120_000)
    page.get_by_role("button", name="Re-center").dispatch_event("click")  # no scrolling: see the e2e test
    wait_for(lambda: np.linalg.norm(recenter_offset() - default) < 0.05, timeout=60, what="the default view back")
    assert mode.value == "follow"


def test_compare_mode_draws_the_other_robot(live, page):
    app = live
    app.terrains.load("stepping_stones")
    app.session.call(SetCompare(("contactnet", "fixed")))
    app.session.call(SetPaused(False))
    ghosts = app.viewer.scene.ghosts
    wait_for(lambda: ghosts.ghosts and ghosts.ghosts[0].visible, timeout=30, what="the ghost robot")
    # the ghost's clock (the main robot stops where it ends, a fall; the other walks on); random-weight models
    # may fall early, and the loop then restarts both: a second of walking is what every run gets
    wait_for(lambda: app.session.view.compare[0].snapshot.t_s > 1.0, timeout=60, what="a second of walking")
    page.get_by_text("fixed:").first.wait_for(timeout=30_000)  # its label in the 3D view
    time.sleep(1.5)
    page.screenshot(path=str(ARTIFACTS / "viser_compare.png"), timeout=120_000)
    app.session.call(SetCompare(()))
    wait_for(lambda: not ghosts.ghosts[0].visible, timeout=30, what="the ghost hidden")
