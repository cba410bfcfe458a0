"""End to end in a real headless browser (Debian chromium driven by playwright): the front page,
the embedded 3D view, its controls, and recording playback. Asserts on server state and DOM text,
never on frame timing. Screenshots go to $CONTACTNET_ARTIFACTS (else artifacts/, git-ignored)."""

from __future__ import annotations

import time

import pytest
from helpers import ARTIFACTS, browser_marks, chromium, light, new_page, save_random_models, serving, wait_for

from app.live.commands import SetPaused, SetPlanner, SetVelocity

pytestmark = browser_marks()


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    from app.api.server import ContactnetApp
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port

    models = tmp_path_factory.mktemp("models")
    save_random_models(models)  # ContactNet with random weights: independent of the shipped models
    app = ContactnetApp(
        ServeSettings(
            terrain="stepping_stones",
            planner="contactnet",
            vx_m_s=0.05,
            paused=True,
            viser_port=free_port(),
            recordings_dir=tmp_path_factory.mktemp("recordings"),
            models_dir=models,
        )
    )
    with serving(app) as served_app:
        yield served_app


@pytest.fixture(scope="module")
def page(live):
    app, url = live
    with chromium() as browser:
        page = new_page(browser, 1600, 1000)
        page.goto(light(url + "/"))
        page.frame_locator("#viewer").get_by_text("Connected").wait_for(timeout=90_000)
        yield page


def test_page_shows_the_session_and_the_3d_view(live, page):
    app, _ = live
    viewer = page.frame_locator("#viewer")
    assert page.title().startswith("contactnet")
    wait_for(lambda: "stepping_stones" in page.locator("#status").inner_text(), what="status line")
    assert page.locator("nav a[href='/docs']").count() == 1
    viewer.get_by_text("Gait schedule").wait_for()
    viewer.get_by_text("PAUSED").wait_for()
    client_id = wait_for(lambda: list(app.viewer.server.get_clients()), what="viser client")[0]
    app.session.call(SetPaused(False))
    wait_for(lambda: app.state().t_s > 1.5, what="1.5 s of walking")
    app.session.call(SetPaused(True))
    viewer.get_by_text("PAUSED").wait_for()
    state = app.state()
    assert state.planner_active == "contactnet" and state.rank_chosen is not None
    candidates = app.session.view.candidates
    assert candidates.rank is not None and len(candidates.chosen) == 1  # the ranked disks drawn
    viewer.get_by_text(f"rank chosen {state.rank_chosen}").wait_for()
    time.sleep(1.5)  # let the renderer catch up with the last scene update
    page.screenshot(path=str(ARTIFACTS / "browser_stepping_stones.png"), timeout=120_000)
    assert app.viewer.panel.camera.following(client_id)


def test_push_button_and_velocity_keys_drive_the_robot(live, page):
    app, _ = live
    viewer = page.frame_locator("#viewer")
    app.terrains.load("flat")
    app.session.call(SetPlanner("heuristic"))  # random ContactNet weights do not make a steady walk
    app.session.call(SetVelocity(0.0, 0.0))
    app.session.call(SetPaused(False))
    # The page's status line says so (the 3D view's toast of it lasts 6 s, which a software renderer on a busy
    # machine may draw after it closed: tests/test_app_scene.py checks the toast is sent to every browser).
    wait_for(lambda: page.locator("#status-detail").inner_text().startswith("flat · "), timeout=90, poll_s=0.5,
             what="the status on flat")

    # A DOM click event straight to the button: a pointer click first scrolls the button into view,
    # which can take long while the software renderer keeps the page busy.
    viewer.get_by_role("button", name="+x").dispatch_event("click")
    wait_for(lambda: app.state().pushes == 1, what="the push to register")

    # Focus the 3D view. The click is done at once, but Playwright then waits for navigations it might start, which
    # a page starved by its software renderer on a busy machine can hold off past the 30 s default (busy run 6).
    page.locator("#viewer").click(position={"x": 200, "y": 700}, force=True, no_wait_after=True, timeout=90_000)
    page.keyboard.press("i")
    page.keyboard.press("i")
    wait_for(lambda: app.state().vel_cmd == (0.1, 0.0), what="vx = 0.1 from the I key")
    x0 = app.state().base_position[0]
    wait_for(lambda: app.state().base_position[0] > x0 + 0.1, timeout=20, what="the robot to walk 10 cm")
    viewer.get_by_text("cmd (+0.10, +0.00)").wait_for(timeout=60_000)  # a software renderer on a busy machine: seconds behind
    page.screenshot(path=str(ARTIFACTS / "browser_flat_walking.png"), timeout=120_000)


def test_recordings_from_the_page_and_the_command_line_play_back(live, page):
    from contactnet.cli import main

    app, url = live
    folder = app.recordings.directory
    assert main(["simulate", "--terrain", "stepping_stones", "--gait", "walk", "--planner", "heuristic",
                 "--duration", "1.0", "--record", str(folder / "cli-run.viser")]) == 0
    app.session.call(SetPaused(False))
    # DOM click events (as for the push button above): a pointer click waits for the page to take input, which a
    # software renderer on a busy machine can hold off for tens of seconds.
    page.locator("#recordings-toggle").dispatch_event("click")
    page.locator("#record-button").dispatch_event("click")  # the front page's record button
    wait_for(lambda: app.recorder.status()["frames"] >= 20, timeout=60, what="20 recorded frames")
    page.locator("#record-button").dispatch_event("click")
    wait_for(lambda: not app.recorder.recording and app.recorder.last_saved, what="the recording saved")
    app.session.call(SetPaused(True))  # an idle scene lets the software renderer keep up with the clicks
    page.get_by_text(app.recorder.last_saved).wait_for(timeout=90_000)
    entry = page.locator("#recording-list li", has_text="cli-run.viser")
    entry.wait_for(timeout=90_000)
    entry.locator("a", has_text="Play").dispatch_event("click")
    page.locator("#playback-bar").wait_for(timeout=90_000)
    assert page.locator("#playback-name").inner_text() == "cli-run.viser"
    page.frame_locator("#viewer").get_by_label("Show scene tree").first.wait_for(timeout=60_000)
    time.sleep(2.0)
    page.screenshot(path=str(ARTIFACTS / "browser_playback.png"), timeout=120_000)
    page.locator("#back-to-live").dispatch_event("click")
    page.frame_locator("#viewer").get_by_text("Connected").wait_for(timeout=60_000)


def test_api_docs_render_without_internet(live, page):
    """/docs is Swagger UI from the installed package: it renders the API in a browser on a machine
    without internet (this one has none)."""
    _, url = live
    docs = new_page(page.context.browser, 1200, 800)
    try:
        docs.goto(url + "/docs")
        docs.get_by_text("/api/state").first.wait_for(timeout=30_000)
        docs.screenshot(path=str(ARTIFACTS / "browser_api_docs.png"), timeout=120_000)
    finally:
        docs.close()
