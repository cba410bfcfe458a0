"""The front page around the 3D view, in a real headless browser (Debian chromium driven by playwright): the
first minute (the session waits for the page, counts down, runs, ends with a card and loops), compare mode,
refusals shown as toasts, shareable links, the layout from 390 to 1920 px wide, and the 3D view reconnecting
after a server restart. Asserts on server state and DOM, never on frame timing. Screenshots go to
$CONTACTNET_ARTIFACTS (else artifacts/, git-ignored)."""

from __future__ import annotations

import json
import time
from urllib.parse import parse_qs, urlsplit

import pytest
from helpers import (
    ARTIFACTS,
    LIGHT_VIEW,
    browser_marks,
    chromium,
    light,
    new_context,
    save_random_models,
    wait_for,
)

from app.live.commands import EditTerrain, Reset, SetCompare, SetGait, SetLoop, SetPaused

pytestmark = browser_marks()

#: A short walk on flat ground: the goal line 50 cm ahead, so a run ends within seconds.
SHORT_FLAT = {
    "name": "short_flat",
    "description": "flat ground, goal 50 cm ahead (browser tests)",
    "start": [0.0, 0.0],
    "goal_x": 0.5,
    "surface_z": 0.0,
    "regions": [{"shape": "rect", "center": [0.5, 0.0], "size": [4.0, 3.0], "yaw": 0.0}],
}


class Tool:
    """The web tool under test on fixed ports, so it can be stopped and started again as a user's server
    restart (same address, new session)."""

    def __init__(self, settings):
        from app.recordings.recorder import free_port

        self.settings = settings
        self.port = free_port()
        self.start()

    def start(self) -> None:
        from app.api.server import BackgroundServer, ContactnetApp

        self.app = ContactnetApp(self.settings)
        try:
            self.web = BackgroundServer(self.app.api, "127.0.0.1", self.port)
        except BaseException:
            self.app.close()
            raise

    def stop(self) -> None:
        self.web.stop()
        self.app.close()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def state(self):
        return self.app.state()


@pytest.fixture(scope="module")
def tool(tmp_path_factory):
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port

    models = tmp_path_factory.mktemp("models")
    save_random_models(models)
    terrains = tmp_path_factory.mktemp("terrains")
    (terrains / "short_flat.json").write_text(json.dumps(SHORT_FLAT))
    tool = Tool(
        ServeSettings(
            terrain=str(terrains / "short_flat.json"),
            terrains_dir=terrains,
            gait="trot",
            planner="heuristic",
            vx_m_s=0.2,
            wait_for_viewer=True,
            viewer_start_delay_s=2.0,
            loop=True,
            loop_delay_s=10.0,
            viser_port=free_port(),
            recordings_dir=tmp_path_factory.mktemp("recordings"),
            models_dir=models,
        )
    )
    yield tool
    tool.stop()


@pytest.fixture(scope="module")
def browser():
    with chromium() as browser:
        yield browser


@pytest.fixture(scope="module")
def page(browser):
    # The page shares its renderer's main thread with the embedded 3D view; with software WebGL and one core
    # busy it can take tens of seconds to poll or to run a check: its waits (new_context: up to 90 s) are guards
    # against a hang, not speed tests.
    context = new_context(browser)
    context.grant_permissions(["clipboard-read", "clipboard-write"])
    context.add_init_script(RECORD_TOASTS)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    yield page
    context.close()
    assert not errors, f"the page's scripts failed: {errors}"


def shot(page, name: str) -> None:
    time.sleep(0.6)  # the software renderer draws the last scene update
    page.screenshot(path=str(ARTIFACTS / f"page_{name}.png"), timeout=120_000)


#: Every toast the page shows, kept in window.__toasts: a toast lasts a few seconds, and a busy software
#: renderer may keep the test from looking at the page in that time.
RECORD_TOASTS = """
window.__toasts = [];
new MutationObserver((records) => {
  for (const record of records) {
    for (const node of record.addedNodes) {
      if (node.classList && node.classList.contains("toast")) {
        window.__toasts.push({ text: node.textContent, level: node.className });
      }
    }
  }
}).observe(document, { childList: true, subtree: true });
"""


def toast(page, text: str, level: str | None = None) -> str:
    """The text of a toast (of ``level``) holding ``text``, shown since the page was loaded (waits for it)."""
    found = page.wait_for_function(
        """([text, level]) => (window.__toasts || []).find(
             (t) => t.text.includes(text) && (!level || t.level.includes("toast-" + level)))""",
        arg=[text, level],
        timeout=90_000,
        polling=250,
    )
    return found.json_value()["text"]


# Clicks are DOM click events sent straight to the element: a pointer click first waits for the element to
# be stable over animation frames, which the software renderer can delay for long.


def connected(page, timeout_ms: int = 90_000) -> None:
    page.frame_locator("#viewer").get_by_text("Connected").first.wait_for(timeout=timeout_ms)


def opened(tool, page):
    """The page on the tool with the tests' 3D view resolution (`light`): the first test opens it without, to see the
    page's own choice; the next test, or a test run alone, opens it here."""
    if not page.url.startswith(tool.url) or "fixedDpr=" not in page.evaluate("location.href"):
        page.goto(light(tool.url + "/"))
        connected(page)
    return page


def test_the_session_waits_for_the_page_then_runs(tool, page):
    time.sleep(1.0)
    state = tool.state()
    assert state.waiting_for_viewer and not state.running and state.t_s == 0.0  # nobody watches: it waits

    page.goto(tool.url + "/")
    start = page.locator("#start-card")
    start.wait_for()  # over the 3D view while the scene loads
    assert page.locator("#start-title").inner_text() in ("Starting…",) or "starts in" in start.inner_text()
    shot(page, "first_minute_start")
    connected(page)
    # Without a GPU (here: headless chromium's SwiftShader) the page asks the 3D view for half resolution itself,
    # and says so; with one, the address alone decides.
    software = page.evaluate("Embed.softwareRendering()")
    assert ("fixedDpr=0.5" in page.locator("#viewer").get_attribute("src")) == software
    if software:
        toast(page, "at half resolution to keep up")
    wait_for(lambda: tool.state().starts_in_s is not None or tool.state().t_s > 0, what="the count-down")
    wait_for(lambda: tool.state().t_s > 0.2, timeout=30, what="the robot to move after the count-down")
    start.wait_for(state="hidden")
    assert "waiting" not in page.locator("#status-line").inner_text()
    bar = page.locator("#tracks .track-bar").first
    wait_for(lambda: int(bar.get_attribute("aria-valuenow")) > 0, timeout=30, what="the progress bar to move")
    shot(page, "first_minute")


def test_end_of_run_card_and_the_loop(tool, page):
    opened(tool, page)
    # The software renderer keeps the page's main thread busy: the page may show a state a few seconds old,
    # so the loop's count-down (10 s here) leaves time to see the card.
    card = page.locator("#run-card")
    wait_for(lambda: tool.state().restart_in_s is not None, timeout=90, what="a run to end")
    card.wait_for()
    # The card against the state the page holds (read together: the page polls on), and that against the server.
    run, title, stats = page.evaluate(
        "[lastState.last_run, ...['run-title', 'run-stats'].map((id) => document.getElementById(id).textContent)]"
    )
    assert run["index"] <= tool.state().runs
    assert ("Goal reached" in title) == run["success"]
    assert f"steps{run['steps']}rank" in stats and "rank mean / max" in stats and "time" in stats
    assert f"stood / useless{run['stand_steps']} / {run['useless_steps']}" in stats  # issue 14's counts
    assert f"swing retargets{run['swing_retargets']}capture steps{run['capture_steps']}reached" in stats
    wait_for(lambda: "next run in" in page.locator("#run-next").inner_text(), what="the loop's count-down")
    shot(page, "end_of_run")

    page.locator("#run-stay").dispatch_event("click")  # loop off: the robot stays at the end of the run
    wait_for(lambda: not tool.state().loop and tool.state().restart_in_s is None, what="loop off")
    wait_for(lambda: "loop off" in page.locator("#run-next").inner_text(), what="the card to say loop off")
    # The page may draw a state a few seconds old (a run the loop started before the click ends within a second
    # here): the card is there once the page has caught up with the server's ended run.
    wait_for(card.is_visible, what="the card to stay with the loop off")
    runs = tool.state().runs
    assert tool.state().done is not None

    # Runs last about a second here, less than the page may lag behind: the server says when a run started.
    page.locator("#run-restart").dispatch_event("click")  # with the loop off, only this starts the next run
    wait_for(lambda: tool.state().runs > runs, timeout=30, what="Restart now to start a run (that ended)")
    wait_for(lambda: page.locator("#run-index").inner_text() == f"run {runs + 1}", what="the next run's card")

    page.locator("#run-loop").dispatch_event("click")  # loop on again: the next run starts after the count-down
    wait_for(lambda: tool.state().loop, what="loop on")
    wait_for(lambda: tool.state().runs > runs + 1, timeout=60, what="the loop to run again")
    wait_for(lambda: int(page.locator("#run-index").inner_text().split()[1]) > runs + 1, what="the new card")


def test_compare_mode_shows_both_robots(tool, page):
    opened(tool, page)
    tool.app.session.call(SetLoop(False))  # the end-of-run card stays
    page.locator("#compare-toggle").dispatch_event("click")
    wait_for(lambda: tool.state().compare is not None, timeout=30, what="compare mode")
    state = tool.state()
    assert [c.planner for c in state.compare] == ["fixed"] and state.scenario.compare == ["heuristic", "fixed"]
    toast(page, "Compare mode")  # the session's notice
    page.locator("#compare-toggle[aria-pressed='true']").wait_for()
    tracks = page.locator("#tracks .track")
    wait_for(lambda: tracks.count() == 2, what="two progress bars")
    assert [tracks.nth(i).get_attribute("data-planner") for i in range(2)] == ["heuristic", "fixed"]
    wait_for(lambda: tool.state().t_s > 1.0, timeout=30, what="both robots walking")
    shot(page, "compare")

    wait_for(lambda: tool.state().done is not None and tool.state().last_run.compare, timeout=90,
             what="the compared run to end")
    page.locator("#run-compare").wait_for()
    rows = page.locator("#run-compare tbody tr")
    assert rows.count() == 2
    assert rows.nth(0).get_attribute("data-planner") == "heuristic"
    assert rows.nth(1).get_attribute("data-planner") == "fixed"
    shot(page, "compare_end")

    page.locator("#compare-toggle").dispatch_event("click")  # off again
    wait_for(lambda: tool.state().compare is None, timeout=30, what="compare mode off")
    wait_for(lambda: tracks.count() == 1, what="one progress bar")
    tool.app.session.call(SetLoop(True))


def test_a_push_refused_while_paused_is_a_toast(tool, page):
    opened(tool, page)
    tool.app.session.call(Reset())  # a run under way (not its end) ...
    tool.app.session.call(SetPaused(True))  # ... paused
    page.locator("#paused-chip").wait_for()
    page.evaluate("act('Push', () => post('/api/push', {fx: 5, duration: 0.5}))")  # the page's REST path
    refusal = toast(page, "Push: 409", "error")
    assert "paused" in refusal
    shot(page, "push_refused")
    assert tool.state().pushes == 0
    page.locator("#paused-run").dispatch_event("click")  # the chip's Run button
    wait_for(lambda: not tool.state().paused, what="Run from the paused chip")
    page.locator("#paused-chip").wait_for(state="hidden")


def test_share_link_round_trip(tool, page):
    opened(tool, page)
    session = tool.app.session
    session.call(SetCompare(("heuristic", "fixed")))
    page.locator("#compare-toggle[aria-pressed='true']").wait_for()
    page.locator("#share-button").dispatch_event("click")
    toast(page, "short_flat")
    link = page.locator("#share-button").get_attribute("data-url")
    assert parse_qs(urlsplit(link).query) == {
        "terrain": ["short_flat"], "gait": ["trot"], "planner": ["heuristic"], "compare": ["heuristic,fixed"],
    }

    # Someone else's session: another terrain, gait, no compare; the link brings the scenario back.
    tool.app.terrains.load("flat")
    session.call(SetGait("walk"))
    session.call(SetCompare(()))
    page.goto(link + "&" + LIGHT_VIEW)
    wait_for(lambda: tool.state().scenario.model_dump() == {
        "terrain": "short_flat", "removed": None, "seed": None, "gait": "trot", "planner": "heuristic",
        "compare": ["heuristic", "fixed"],
    }, timeout=60, what="the shared scenario applied")
    # (location.href: playwright's page.url does not always follow history.replaceState)
    wait_for(lambda: "terrain=" not in page.evaluate("location.href"), timeout=60,
             what="the scenario out of the address bar")
    assert LIGHT_VIEW in page.evaluate("location.href")
    assert LIGHT_VIEW in page.locator("#viewer").get_attribute("src")  # other parameters reach the viewer
    connected(page)

    # An edited terrain cannot be shared until it is saved.
    from contactnet.terrain.edits import add_stone

    session.call(EditTerrain(add_stone, ("circle", (1.5, 1.0))))
    wait_for(lambda: tool.state().scenario.terrain is None, what="the edited terrain")
    page.locator("#share-button").dispatch_event("click")
    toast(page, "Save the edited terrain", "warning")

    # A link naming a terrain that does not exist: a toast, and the rest of the link still applies.
    page.goto(light(tool.url + "/?terrain=no_such_terrain&gait=walk&planner=heuristic"))
    toast(page, "terrain no_such_terrain refused (404", "error")
    wait_for(lambda: tool.state().gait == "walk" and tool.state().compare is None, timeout=60,
             what="the link's gait and compare mode off")
    connected(page)


def test_layout_from_390_to_1920_px(tool, page):
    opened(tool, page)
    tool.app.terrains.load("stepping_stones")
    page.set_viewport_size({"width": 390, "height": 844})
    wait_for(lambda: "stepping_stones" in page.locator("#status-detail").inner_text(), what="the new terrain")
    assert page.evaluate("document.documentElement.scrollWidth") <= 390  # nothing sticks out sideways
    header = page.locator("header").bounding_box()
    assert header["height"] < 130
    assert page.locator("#compare-toggle").is_visible() and page.locator("#share-button").is_visible()
    assert not page.locator("#recordings-toggle").is_visible()  # in the menu
    shot(page, "390")
    page.locator("#menu-toggle").dispatch_event("click")
    page.locator("#nav").wait_for()  # the menu opens
    page.locator("#recordings-toggle").dispatch_event("click")
    aside = page.locator("#recordings")
    aside.wait_for()
    box = aside.bounding_box()
    assert box["width"] == 390 and box["y"] > 844 / 4  # a bottom sheet over the 3D view
    shot(page, "390_recordings")
    page.locator("#recordings-close").dispatch_event("click")
    aside.wait_for(state="hidden")

    for width, height in ((1400, 900), (1920, 1080)):
        page.set_viewport_size({"width": width, "height": height})
        status = page.locator("#status-line")
        assert page.evaluate("document.documentElement.scrollWidth") <= width
        # One line that never wraps (the layout below never shifts): a sentence longer than the header (a fall's
        # whole reason) ends in an ellipsis, and the whole of it is the header's tooltip.
        assert status.bounding_box()["height"] < 24
        assert status.evaluate("e => e.scrollWidth <= e.clientWidth || document.getElementById('status').title"
                               ".startsWith(e.textContent.replace(/…$/, '').slice(0, 40))")
        assert page.locator("#recordings-toggle").is_visible()
        shot(page, str(width))


def test_the_3d_view_reconnects_after_a_server_restart(tool, page):
    opened(tool, page)
    page.set_viewport_size({"width": 1400, "height": 900})
    connected(page)
    old = tool.state().session_id
    tool.stop()
    page.locator("#offline-card").wait_for(timeout=15_000)
    assert "unreachable" in page.locator("#status-line").inner_text()
    tool.start()  # same ports, a new session that waits for its first viewer
    assert tool.state().session_id != old
    toast(page, "The server restarted", "info")
    connected(page)
    wait_for(lambda: not tool.state().waiting_for_viewer, timeout=60, what="the new session to see the page")
    page.locator("#offline-card").wait_for(state="hidden")
    shot(page, "reconnected")
