"""The front page's recordings list in a real headless browser (Debian chromium, playwright): what each
recording shows (title, terrain, gait, planner, duration, result), Rename (title and file name, a refused
name said in a toast), Delete (asks first), Play (the title in the playback bar). Screenshot in artifacts/."""

from __future__ import annotations

import shutil
import time

import pytest
from helpers import ARTIFACTS, browser_marks, chromium, light, new_page, serving, wait_for

pytestmark = browser_marks()


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    from app.api.server import ContactnetApp
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port
    from contactnet.cli import main

    folder = tmp_path_factory.mktemp("recordings")
    assert main(["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic", "--vx", "0.1",
                 "--duration", "1.0", "--record", str(folder / "cli-run.viser")]) == 0
    shutil.copy(folder / "cli-run.viser", folder / "old.viser")  # as made before metadata: no sidecar
    app = ContactnetApp(ServeSettings(terrain="flat", planner="heuristic", vx_m_s=0.0, paused=True,
                                      viser_port=free_port(), recordings_dir=folder))
    with serving(app) as served_app:
        yield served_app


@pytest.fixture(scope="module")
def browser():
    with chromium() as browser:
        yield browser


@pytest.fixture(scope="module")
def page(live, browser):
    _, url = live
    page = new_page(browser)
    page.goto(light(url + "/"))
    page.locator("body[data-ready]").wait_for(timeout=90_000)  # main() wired and showing the live session
    yield page


# Clicks are DOM click events (`dispatch_event`): a pointer click waits for the element to stand still over
# two animation frames, which a software-rendered 3D view next to it can delay for long.
def item(page, text: str):
    return page.locator("#recording-list li", has_text=text)


def test_the_recordings_open_while_the_page_still_loads(live, browser):
    """The header's controls work before the session has answered: here /api/info is held back."""
    _, url = live
    slow = new_page(browser)
    held = []
    slow.route("**/api/info", lambda route: held.append(route))  # not answered until the end of the test
    try:
        slow.goto(light(url + "/"), wait_until="domcontentloaded")
        # (evaluate lets playwright dispatch the route to the handler)
        wait_for(lambda: slow.evaluate("1") and held, what="the page to ask for /api/info")
        slow.locator("#recordings-toggle").dispatch_event("click")
        item(slow, "cli-run.viser").wait_for(timeout=60_000)
        assert held and slow.locator("body[data-ready]").count() == 0  # main() still waits for /api/info
        held[0].continue_()
        slow.locator("body[data-ready]").wait_for(timeout=60_000)
    finally:
        slow.close()


def test_the_list_shows_what_each_recording_is(live, page):
    page.locator("#recordings-toggle").dispatch_event("click")
    cli = item(page, "cli-run.viser")
    cli.wait_for(timeout=60_000)  # the first fetch of the list: slow when other jobs load the 2 cores
    text = cli.inner_text()
    assert "flat · walk · heuristic" in text and "stopped" in text and "1.0 s" in text
    assert "no metadata" in item(page, "old.viser").inner_text()


def test_rename_sets_the_title_and_the_file_name(live, page):
    app, _ = live
    folder = app.recordings.directory
    item(page, "cli-run.viser").get_by_role("button", name="Rename").dispatch_event("click")
    page.locator(".rec-edit input[name=title]").fill("My first run")
    page.locator(".rec-edit input[name=name]").fill("first-run")
    page.locator(".rec-edit").get_by_role("button", name="Save").dispatch_event("click")
    page.locator("#recording-list .rec-title", has_text="My first run").wait_for()
    assert {"first-run.viser", "first-run.viser.json"} <= {p.name for p in folder.iterdir()}
    assert "cli-run.viser" not in {p.name for p in folder.iterdir()}
    # a name that is taken: refused, said in a toast, nothing changed
    item(page, "old.viser").get_by_role("button", name="Rename").dispatch_event("click")
    page.locator(".rec-edit input[name=name]").fill("first-run")
    page.locator(".rec-edit").get_by_role("button", name="Save").dispatch_event("click")
    page.locator("#toasts", has_text="exists already").wait_for()
    assert (folder / "old.viser").is_file()
    page.locator(".rec-edit").get_by_role("button", name="Cancel").dispatch_event("click")
    item(page, "old.viser").wait_for()


def test_delete_asks_first(live, page):
    app, _ = live
    folder = app.recordings.directory
    asked = []

    def answer(accept: bool):
        def handle(dialog):
            asked.append(dialog.message)
            dialog.accept() if accept else dialog.dismiss()

        return handle

    page.once("dialog", answer(False))
    item(page, "old.viser").get_by_role("button", name="Delete").dispatch_event("click")
    wait_for(lambda: asked, what="the confirmation")
    assert "old.viser" in asked[0] and (folder / "old.viser").is_file()
    page.once("dialog", answer(True))
    item(page, "old.viser").get_by_role("button", name="Delete").dispatch_event("click")
    wait_for(lambda: not (folder / "old.viser").exists(), what="the file deleted")
    wait_for(lambda: item(page, "old.viser").count() == 0, what="the list updated")


def test_play_shows_the_title(live, page):
    item(page, "My first run").get_by_role("link", name="Play").dispatch_event("click")
    page.locator("#playback-bar").wait_for()
    assert page.locator("#playback-name").inner_text() == "My first run"
    page.frame_locator("#viewer").get_by_label("Show scene tree").first.wait_for(timeout=60_000)
    time.sleep(3.0)  # the scene fades in
    page.screenshot(path=str(ARTIFACTS / "browser_recordings.png"), timeout=120_000)
    page.locator("#back-to-live").dispatch_event("click")
