"""A robot per visitor in a real headless browser (Debian chromium, playwright): two browsers (two cookie
jars) each drive their own robot, one's push, command and terrain change leave the other's robot untouched,
the Sessions panel lists both, and a watcher's page shows a session read-only (no page controls, the 3D view
of a viser server without the control panel). Asserts on server state and the DOM. Screenshots go to
$CONTACTNET_ARTIFACTS (else artifacts/)."""

from __future__ import annotations

import time

import pytest
from helpers import (
    ARTIFACTS,
    browser_marks,
    chromium,
    light,
    live_app,
    new_context,
    new_page,
    serving,
    wait_for,
)

pytestmark = browser_marks()


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    app = live_app(tmp_path_factory, terrain="flat", planner="heuristic", gait="walk", vx_m_s=0.05,
                   wait_for_viewer=False, max_sessions=3, terrains_dir=tmp_path_factory.mktemp("terrains"))
    with serving(app) as served_app:
        yield served_app


@pytest.fixture(scope="module")
def browser():
    with chromium() as browser:
        yield browser


def visitor(browser, url: str):  # noqa: ANN001, ANN201 - playwright objects
    """A new browser profile (its own cookies) with the page open and wired."""
    context = new_context(browser, 1200, 800)
    page = context.new_page()
    page.goto(light(url + "/"))
    page.locator("body[data-ready]").wait_for()
    return page


def post(page, path: str, body: dict) -> int:  # noqa: ANN001 - a playwright page
    """POST from the page itself (its cookie, its Origin): what its controls do."""
    return page.evaluate(
        """([path, body]) => fetch(path, {method: "POST", headers: {"Content-Type": "application/json"},
                                          body: JSON.stringify(body)}).then(r => r.status)""",
        [path, body],
    )


def state_of(page) -> dict:  # noqa: ANN001
    return page.evaluate("() => fetch('/api/state').then(r => r.json())")


def test_two_browsers_two_robots(live, browser):
    app, url = live
    first, second = visitor(browser, url), visitor(browser, url)
    try:
        one, two = state_of(first), state_of(second)
        assert one["session_id"] != two["session_id"] and one["viser_port"] != two["viser_port"]
        # each page's 3D view is connected to its own session's viser server
        for page, state in ((first, one), (second, two)):
            assert f":{state['viser_port']}" in page.locator("#viewer").get_attribute("src")
        visits = {v.session.session_id: v for v in app.visits.visits()}
        wait_for(lambda: visits[one["session_id"]].viewers() == 1 and visits[two["session_id"]].viewers() == 1,
                 timeout=120, what="each session's 3D view open in its own browser")

        x_before = state_of(first)["base_position"][0]
        assert post(second, "/api/push", {"fx": 0.0, "fy": 4.0, "duration": 0.3}) == 200  # while it walks
        assert post(second, "/api/command", {"vx": 0.0, "vy": 0.1}) == 200
        assert post(second, "/api/session/terrain", {"name": "stepping_stones"}) == 200  # restarts that robot
        after_one, after_two = state_of(first), state_of(second)
        assert after_two["terrain"] == "stepping_stones" and after_two["vel_cmd"][1] == pytest.approx(0.1)
        assert after_one["terrain"] == "flat" and after_one["vel_cmd"] == pytest.approx([0.05, 0.0])
        assert after_one["session_id"] == one["session_id"]  # not restarted by the other's terrain change
        assert after_one["base_position"][0] >= x_before - 0.01  # still walking on
        assert not any("stepping_stones" in n["text"] for n in after_one.get("notices", []))

        first.locator("#sessions-toggle").click()
        items = first.locator("#session-list li")
        items.nth(1).wait_for()
        assert items.count() == 2 and first.locator("#session-list li", has_text="yours").count() == 1
        assert "of at most 3 sessions" in first.locator("#sessions-count").text_content()
        time.sleep(1.0)
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        first.screenshot(path=str(ARTIFACTS / "visits_sessions_panel.png"), timeout=120_000)
    finally:
        first.context.close()
        second.context.close()


def test_a_watcher_sees_a_session_read_only(live, browser):
    app, url = live
    owner = visitor(browser, url)
    watcher = new_page(browser, 1200, 800)
    try:
        watch_id = owner.evaluate("() => fetch('/api/info').then(r => r.json())")["watch_id"]
        sessions_before = len(app.visits)
        watcher.goto(light(f"{url}/?watch={watch_id}"))
        watcher.locator("body[data-ready]").wait_for(timeout=90_000)
        assert len(app.visits) == sessions_before  # watching takes no session
        assert watcher.locator("body.watching").count() == 1
        assert not watcher.locator("#compare-toggle").is_visible() and not watcher.locator("#sessions-toggle").is_visible()
        visit = app.visits.by_watch_id(watch_id)
        src = watcher.locator("#viewer").get_attribute("src")
        assert f":{visit.viewer.watch_port()}" in src and f":{visit.viewer.port}" not in src
        watcher.frame_locator("#viewer").get_by_text("Connected").wait_for(timeout=120_000)
        wait_for(lambda: "walking" in (watcher.locator("#status-line").text_content() or "")
                 or "t " in (watcher.locator("#status-line").text_content() or ""), timeout=60,
                 what="the watched session's status")
        time.sleep(1.0)
        watcher.screenshot(path=str(ARTIFACTS / "visits_watch.png"), timeout=120_000)
    finally:
        owner.context.close()
        watcher.context.close()
