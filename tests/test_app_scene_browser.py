"""The 3D view in a real headless browser (Debian chromium, software WebGL), opened on its own page:
a click on a candidate disk names it in the legend and in a label next to it, an orbit keeps the
camera following the robot and Re-center brings the default view back, the compare mode's ghost
robot, and viser's software-WebGL toast closing by itself. Screenshots go to artifacts/."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from helpers import ARTIFACTS, browser_marks, chromium, live_app, open_viser, viser_client, wait_for

from app.live.commands import SetCompare, SetPaused, SetPlanner, SetVelocity
from app.scene.live_scene import describe_candidate, follow_anchor

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



def screen_xy(camera, point_world: np.ndarray) -> tuple[float, float] | None:
    """Where a world point is drawn in the browser's canvas (CSS pixels), from the camera it reported."""
    from viser import transforms

    rotation = transforms.SO3(np.asarray(camera.wxyz)).as_matrix()  # OpenCV: x right, y down, z forward
    p = rotation.T @ (np.asarray(point_world, dtype=float) - np.asarray(camera.position))
    if p[2] <= 1e-3:
        return None
    focal = 0.5 * camera.image_height / math.tan(0.5 * camera.fov)
    return camera.image_width / 2 + focal * p[0] / p[2], camera.image_height / 2 + focal * p[1] / p[2]


def camera_drawn_still(app, client, reports) -> bool:  # noqa: ANN001
    """The paused robot's following camera will not move again, and the browser reported the pose sent last."""
    camera = app.viewer.panel.camera
    browser = camera._browsers.get(client.client_id)
    if browser is None or browser.anchor is None or camera._anchor is None or not browser.sent or not reports:
        return False
    # the smoothed anchor eases along a line to the robot's: no move while both are this close to the last one
    target = follow_anchor(app.session.view)
    if max(np.linalg.norm(target - browser.anchor), np.linalg.norm(camera._anchor - browser.anchor)) >= camera.min_move_m:
        return False
    _, look_at, offset = browser.sent[-1]
    position, reported_look_at = reports[-1]
    return bool(np.allclose(reported_look_at, look_at, atol=1e-3) and np.allclose(position - reported_look_at, offset, atol=1e-3))


def test_the_software_webgl_toast_closes_by_itself(live, page):
    page.get_by_text("Software WebGL rendering").first.wait_for(state="hidden", timeout=30_000)


def test_a_click_on_a_disk_names_it(live, page):
    app = live
    wait_for(lambda: app.session.view.run.waiting_for_viewer is False, what="the session to start")
    wait_for(lambda: app.session.view.snapshot.steps >= 3, timeout=60, what="a few steps")
    client = viser_client(app)
    reports = []  # the poses the browser says it draws with (its reports come after it drew them)

    @client.camera.on_update
    async def _(camera) -> None:  # noqa: ANN001 - async: run on viser's event loop, in arrival order
        reports.append((np.array(camera.position), np.array(camera.look_at)))

    app.session.call(SetPaused(True))
    scene = app.viewer.scene
    wait_for(lambda: scene._drawn[0] is app.session.view.candidates, what="the disks drawn")
    # The clicked point is worked out from the camera, so wait until the browser draws the camera's last pose:
    # after the pause the following camera still eases onto the robot for a while (a slow browser is moved at
    # most every 1.5 s), and a software renderer on a busy machine draws (and reports) a pose seconds after it
    # was sent; a fixed sleep clicked with a pose the browser did not draw yet, a disk's width off.
    wait_for(lambda: camera_drawn_still(app, client, reports), timeout=60, what="the browser to draw the last pose")
    cand, positions = scene._drawn
    feet = app.session.view.foot_pos_world
    targets = []
    for i in range(len(cand.xy_world)):
        xy = screen_xy(client.camera, positions[i])
        if xy is None or not (40 < xy[0] < 900 and 40 < xy[1] < 860):  # left of the panel
            continue
        clearance = min(np.linalg.norm(positions[i, :2] - foot[:2]) for foot in feet)
        targets.append((clearance, i, xy))
    assert targets, "no disk on screen"
    _, index, (x, y) = max(targets)  # the disk farthest from every foot
    page.mouse.click(x, y)
    legend = app.viewer.panel.legend
    expected = describe_candidate(cand, index, scene.leg_names).text()
    wait_for(lambda: expected in legend.picked.content, timeout=30, what=f"the legend to name disk {index}")
    assert scene._pick_labels[client.client_id].text == expected
    page.get_by_text(expected).first.wait_for(timeout=30_000)  # shown in the panel (and next to the disk)
    time.sleep(1.5)
    page.screenshot(path=str(ARTIFACTS / "viser_disk_click.png"))


def test_an_orbit_keeps_following_and_recenter_restores_the_view(live, page):
    app = live
    app.terrains.load("flat")
    app.session.call(SetPlanner("heuristic"))  # a steady walk (the test's ContactNet has random weights)
    app.session.call(SetPaused(True))
    client = viser_client(app)
    camera = app.viewer.panel.camera
    mode, recenter = camera.controls[client.client_id]
    recenter_offset = lambda: client.camera.position - client.camera.look_at  # noqa: E731
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
    assert np.linalg.norm(recenter_offset() - orbited) < 0.1  # at the user's angle
    app.session.call(SetPaused(True))
    page.screenshot(path=str(ARTIFACTS / "viser_after_orbit.png"))
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
    page.screenshot(path=str(ARTIFACTS / "viser_compare.png"))
    app.session.call(SetCompare(()))
    wait_for(lambda: not ghosts.ghosts[0].visible, timeout=30, what="the ghost hidden")
