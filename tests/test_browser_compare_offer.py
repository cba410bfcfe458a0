"""Compare that teaches (issue 31, item 4), in a real headless browser (Debian chromium driven by playwright): on
the default page (stepping stones, walk, ContactNet with the shipped model) Compare turns compare mode on where it
was asked, and a card offers narrow stones, saying why in one sentence; one click loads it with compare mode on, and
there the fixed gait's robot falls while ContactNet's walks on. Asserts on server state and DOM, never on frame
timing. Screenshots go to $CONTACTNET_ARTIFACTS (else artifacts/, git-ignored)."""

from __future__ import annotations

import time

import pytest
from helpers import ARTIFACTS, browser_marks, chromium, light, new_context, serving, wait_for

pytestmark = browser_marks()


@pytest.fixture(scope="module")
def tool(tmp_path_factory):
    from app.api.server import ContactnetApp
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port

    app = ContactnetApp(
        ServeSettings(  # what `contactnet serve` starts with, on free ports and folders of the test's own
            viser_port=free_port(),
            viewer_start_delay_s=1.0,
            terrains_dir=tmp_path_factory.mktemp("terrains"),
            recordings_dir=tmp_path_factory.mktemp("recordings"),
        )
    )
    with serving(app) as served_app:
        yield served_app


@pytest.fixture(scope="module")
def page(tool):
    """The default page; while it is open, ``app.state()`` is its visit's."""
    from app.api.visits import CURRENT_VISIT, VISIT_COOKIE

    app, url = tool
    with chromium() as browser:
        context = new_context(browser)
        page = context.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(light(url + "/"))
        page.locator("body[data-ready]").wait_for()
        cookie = next(c["value"] for c in context.cookies() if c["name"] == VISIT_COOKIE)
        token = CURRENT_VISIT.set(app.visits.get(cookie))
        yield page
        CURRENT_VISIT.reset(token)
        context.close()
        assert not errors, f"the page's scripts failed: {errors}"


def shot(page, name: str) -> None:
    time.sleep(0.6)  # the software renderer draws the last scene update
    page.screenshot(path=str(ARTIFACTS / f"page_{name}.png"), timeout=120_000)


def test_compare_from_the_default_page_offers_narrow_stones(tool, page):
    app, _ = tool
    page.locator("body[data-viewer='shown']").wait_for(timeout=120_000)  # the 3D view drew its scene
    state = app.state()
    assert (state.terrain, state.planner, state.compare) == ("stepping_stones", "contactnet", None)
    assert page.locator("#compare-offer").is_hidden()

    # Compare does what it says on the terrain the user is looking at, and the card offers where it teaches.
    page.locator("#compare-toggle").dispatch_event("click")  # a DOM click: the software renderer delays pointer ones
    wait_for(lambda: app.state().compare is not None, timeout=60, what="compare mode")
    assert app.state().terrain == "stepping_stones"
    offer = page.locator("#compare-offer")
    offer.wait_for()
    text = page.locator("#compare-offer-text").inner_text()
    assert "stepping stones" in text and "narrow stones" in text and "falls" in text
    assert page.locator("#compare-offer-go").inner_text() == "Compare on narrow stones"
    shot(page, "compare_offer")

    # One click: narrow stones, compare mode still on, the card gone.
    page.locator("#compare-offer-go").dispatch_event("click")
    wait_for(lambda: app.state().terrain == "narrow_stones", timeout=60, what="narrow stones loaded")
    state = app.state()
    assert state.scenario.compare == ["contactnet", "fixed"] and state.compare_offer is None
    offer.wait_for(state="hidden")
    page.locator("#compare-toggle[aria-pressed='true']").wait_for()

    # The difference, shown: the fixed gait's robot falls (simulate: at 9.6 s), ContactNet's walks on.
    page.evaluate("fetch('/api/settings', {method: 'POST', headers: {'Content-Type': 'application/json'},"
                  " body: JSON.stringify({speed: 2.0})})")
    def fell_or_past_it() -> bool:  # bounded in simulated time: a busy machine runs the session slower than real time
        state = app.state()
        return bool(state.compare and state.compare[0].fell) or state.t_s > 15.0

    wait_for(fell_or_past_it, timeout=600, poll_s=0.25, what="the fixed gait's robot to fall or 15 s on narrow stones")
    state = app.state()
    assert state.compare and state.compare[0].fell, f"the fixed gait's robot still walks at t = {state.t_s:.1f} s"
    assert not state.fell and state.compare[0].planner == "fixed"
    page.locator("#tracks .track.bad").first.wait_for()  # its progress bar says it fell
    shot(page, "compare_narrow_stones")

    # The split view: the 3D view's "Side by side" moves the fallen fixed-gait robot onto a copy of the terrain.
    app.viewer.panel.gait_planner.side_by_side.value = True  # as a click in the 3D view's panel
    wait_for(lambda: app.viewer.scene._lane_nodes, timeout=30, what="the lane drawn")
    time.sleep(2.0)
    shot(page, "compare_side_by_side")
