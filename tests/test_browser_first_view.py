"""A first view that explains itself (issue 31, items 3 and 6), in a real headless browser (Debian chromium driven by
playwright): the loading view instead of viser's developer panel, keys that work without a click into the 3D view,
the `?` help overlay, the status that stays "walking" on the horizons a walking robot stands, P on the end-of-run
card, one notification channel, and a header that never wraps. Asserts on server state and the DOM, never on frame
timing: the guards are generous, the page sharing its main thread with a software renderer on a busy machine.
Screenshots (1280 x 800 and 390 x 844) go to $CONTACTNET_ARTIFACTS (else artifacts/)."""

from __future__ import annotations

import time

import pytest
from helpers import ARTIFACTS, browser_marks, chromium, light, live_app, new_context, serving, wait_for

from app.live.commands import Reset, SetLoop, SetPaused, SetPlanner, SetTerrain, SetVelocity
from contactnet.terrain import Terrain, flat

pytestmark = browser_marks()

#: Records, in the page, whether viser's developer panel (its "Server URL" box, the scene tree) was ever visible,
#: i.e. shown while the loading view did not cover the 3D view; and the toasts shown.
WATCH_PAGE = """
if (window === window.top) {
  window.__devPanelSeen = [];
  window.__toasts = [];
  // viser keeps its developer panel's elements in the document (in a closed tab): only a drawn one counts
  const drawn = (doc, needle) => [...doc.querySelectorAll("body *")].some((e) => {
    if (e.childElementCount || !(e.textContent || "").includes(needle)) return false;
    const box = e.getBoundingClientRect();
    return box.width > 0 && box.height > 0 && e.checkVisibility({ opacityProperty: true, visibilityProperty: true });
  });
  const look = () => {
    const loading = document.getElementById("loading");
    const frame = document.getElementById("viewer");
    let doc = null;
    try { doc = frame && frame.contentDocument && frame.contentDocument.body ? frame.contentDocument : null; }
    catch (e) { doc = null; }
    if (doc && loading && loading.hidden && (drawn(doc, "Scene tree") || drawn(doc, "Orbit Origin Tool"))) {
      window.__devPanelSeen.push(performance.now());
    }
  };
  setInterval(look, 250);
  new MutationObserver((records) => {
    for (const record of records) for (const node of record.addedNodes) {
      if (node.classList && node.classList.contains("toast")) window.__toasts.push(node.textContent);
    }
  }).observe(document, { childList: true, subtree: true });
}
"""


def short_flat(goal_x: float) -> Terrain:
    data = flat().to_dict()
    data.update(name="short_flat", goal_x=goal_x)
    return Terrain.from_dict(data)


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    # The heuristic planner walking on flat ground, running before any page opens (the first view lands mid-run);
    # its ContactNet models rank standing first (the status test: it stands every horizon).
    app = live_app(tmp_path_factory, stand_models=True, terrain="flat", planner="heuristic", gait="walk",
                   vx_m_s=0.05, wait_for_viewer=False, loop=True, loop_delay_s=30.0,
                   terrains_dir=tmp_path_factory.mktemp("terrains"))
    with serving(app) as served_app:
        yield served_app


@pytest.fixture(scope="module")
def browser():
    with chromium() as browser:
        yield browser


def open_page(browser, url: str, width: int = 1280, height: int = 800):  # noqa: ANN001, ANN201 - playwright
    context = new_context(browser, width, height)
    context.add_init_script(WATCH_PAGE)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    page.goto(light(url + "/"))
    page.locator("body[data-ready]").wait_for()
    return page, errors


def shot(page, name: str) -> None:  # noqa: ANN001
    time.sleep(0.5)
    page.screenshot(path=str(ARTIFACTS / f"first_view_{name}.png"), timeout=120_000)


def scene_shown(page) -> float:  # noqa: ANN001
    """Wait for the loading view to go (the 3D view drew its scene); seconds it took."""
    page.locator("body[data-viewer='shown']").wait_for(timeout=120_000)
    assert page.locator("#loading").is_hidden()
    return page.evaluate("Embed.loadSeconds()")


@pytest.fixture(scope="module")
def page(live, browser):
    """A visitor's page; while it is open, ``app.session``, ``app.state()``, ``app.viewer`` are its visit's."""
    from app.api.visits import CURRENT_VISIT, VISIT_COOKIE

    app, url = live
    page, errors = open_page(browser, url)
    cookie = next(c["value"] for c in page.context.cookies() if c["name"] == VISIT_COOKIE)
    token = CURRENT_VISIT.set(app.visits.get(cookie))
    yield page
    CURRENT_VISIT.reset(token)
    page.context.close()
    assert not errors, f"the page's scripts failed: {errors}"


def test_a_page_opened_mid_run_shows_a_loading_view_then_the_drawn_scene(live, browser):
    app, url = live
    wait_for(lambda: app.state().t_s > 1.0, timeout=60, what="the session to run before any page")
    for width, height, name in ((1280, 800, "desktop"), (390, 844, "phone")):
        page, errors = open_page(browser, url, width, height)
        try:
            assert page.locator("#loading").is_visible() or page.locator("body[data-viewer='shown']").count()
            if page.locator("#loading").is_visible():
                shot(page, f"{name}_loading")
            seconds = scene_shown(page)
            assert 0 < seconds < 90, seconds  # this machine's figure goes in the note (target: 10 s), not a timing test
            print(f"{name}: scene drawn {seconds:.1f} s after the 3D view began to load")
            frame = page.frame_locator("#viewer")
            frame.get_by_text("Connected").first.wait_for()
            opacity = page.evaluate("document.getElementById('viewer').contentDocument.querySelector('canvas').style.opacity")
            assert opacity in ("", "1")  # not the faded canvas of a scene still being lit
            time.sleep(1.0)
            assert page.evaluate("window.__devPanelSeen") == []  # never the websocket box or the scene tree
            shot(page, f"{name}_scene")
        finally:
            page.context.close()
        assert not errors, errors


def test_keys_work_without_a_click_and_not_while_typing(live, page):
    app, _ = live
    session = app.session
    scene_shown(page)
    session.call(SetVelocity(0.0, 0.0))
    page.keyboard.press("i")  # nobody clicked anything: the page has the focus it opened with
    wait_for(lambda: app.state().vel_cmd == (0.05, 0.0), what="I to add 0.05 m/s")
    page.keyboard.press("i")
    page.keyboard.press("j")
    wait_for(lambda: app.state().vel_cmd == (0.1, 0.05), what="I and J to add up")
    page.keyboard.press("l")
    page.keyboard.press("k")
    wait_for(lambda: app.state().vel_cmd == (0.05, 0.0), what="K and L")
    page.keyboard.press("x")
    wait_for(lambda: app.state().vel_cmd == (0.0, 0.0), what="X to stop")
    page.keyboard.press("p")
    wait_for(lambda: app.state().paused, what="P to pause")
    page.locator("#paused-chip").wait_for()
    page.keyboard.press("p")
    wait_for(lambda: not app.state().paused, what="P to run")
    app.session.call(SetVelocity(0.05, 0.0))

    # Typing in a field: the keys are letters, not commands.
    page.evaluate("""() => { const input = document.createElement('input'); input.id = 'typing';
                             document.body.append(input); input.focus(); }""")
    page.keyboard.type("ikjlxp")
    assert page.locator("#typing").input_value() == "ikjlxp"
    time.sleep(1.0)
    state = app.state()
    assert state.vel_cmd == (0.05, 0.0) and not state.paused
    page.evaluate("document.getElementById('typing').remove()")

    # The camera keys go to the 3D view (viser's camera listens on its document).
    page.evaluate("""() => { window.__cameraKeys = [];
        document.getElementById('viewer').contentDocument.addEventListener('keydown',
            (e) => window.__cameraKeys.push(e.code)); }""")
    page.keyboard.down("w")
    page.keyboard.up("w")
    assert page.evaluate("window.__cameraKeys") == ["KeyW"]


def test_question_mark_opens_the_help_with_every_key_and_term(live, page):
    scene_shown(page)
    help_box = page.locator("#help")
    assert help_box.is_hidden()
    page.keyboard.press("?")
    help_box.wait_for()
    keys = page.locator("#help-keys").inner_text()
    for key in ("I", "K", "J", "L", "X", "P", "R", "W / S", "?", "Esc"):
        assert key in keys, key
    terms = page.locator("#help-terms").inner_text()
    for term in ("stood", "useless", "rank", "RTF", "steps", "cmd", "swing retargets"):
        assert term in terms, term
    shot(page, "desktop_help")
    page.keyboard.press("i")  # keys do not drive while the help is open
    page.keyboard.press("Escape")
    help_box.wait_for(state="hidden")
    # From inside the 3D view (focused by a click there): ? opens it as well.
    page.evaluate("document.getElementById('viewer').contentWindow.focus()")
    page.frame_locator("#viewer").locator("body").press("?")
    help_box.wait_for()
    page.keyboard.press("Escape")
    help_box.wait_for(state="hidden")
    # The status words explain themselves.
    wait_for(lambda: page.locator("#status-line .term").count() >= 3, what="the status terms")
    titles = page.locator("#status-line .term").evaluate_all("(spans) => spans.map((s) => s.textContent + ': ' + s.title)")
    assert any(t.startswith("steps") and "step horizons" in t for t in titles), titles
    detail = page.locator("#status-detail .term").evaluate_all("(spans) => spans.map((s) => s.textContent)")
    assert any(t.startswith("RTF") for t in detail), detail


def test_the_status_stays_walking_while_the_planner_stands_horizons(live, page):
    """The model stands every horizon while told to walk: the header says walking in one colour all along (no flip
    every horizon), "stood N" counts the horizons, and the 3D view's label above the robot stays hidden."""
    app, _ = live
    scene_shown(page)
    app.session.call(SetPlanner("contactnet"))  # a model that stands every horizon
    app.session.call(SetVelocity(0.01, 0.0))  # told to walk, slowly (standing against a faster command tilts it)
    app.session.call(Reset())
    stood0 = app.state().stand_steps
    seen = set()
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and app.state().stand_steps < stood0 + 4:
        word, cls = page.evaluate("""() => { const s = document.querySelector('#status-line span');
                                             return s ? [s.textContent, s.className] : [null, null]; }""")
        if word is not None and app.state().done is None:
            seen.add((word, cls))
        assert not app.viewer.scene.marks.stand_label.visible  # the outline marks a stand horizon, no blinking label
        time.sleep(0.2)
    assert app.state().stand_steps >= stood0 + 4, "the model should stand horizon after horizon"
    assert seen == {("walking", "state-running")}, seen
    wait_for(lambda: "stood " in page.locator("#status-line").inner_text(), what="stood N in the header")
    app.session.call(SetPlanner("heuristic"))
    app.session.call(SetVelocity(0.05, 0.0))


def test_p_on_the_end_of_run_card_stays_and_refusals_say_what_comes(live, page):
    app, _ = live
    session = app.session
    scene_shown(page)
    session.call(SetLoop(True))
    session.call(SetTerrain(short_flat(0.05), "short_flat"))
    session.call(SetPaused(False))
    session.call(SetVelocity(0.3, 0.0))
    wait_for(lambda: app.state().restart_in_s is not None, timeout=120, what="a run to end (loop on)")
    runs = app.state().runs
    page.locator("#run-card").wait_for()
    # A push now: refused, saying the loop starts the next run (not "reset it first"), once, on the page.
    page.evaluate("act('Push', () => post('/api/push', {fx: 5, duration: 0.5}))")
    wait_for(lambda: any("Push: 409" in t for t in page.evaluate("window.__toasts")), timeout=60, what="the toast")
    refusal = [t for t in page.evaluate("window.__toasts") if "Push: 409" in t]
    assert len(refusal) == 1 and "next run starts in" in refusal[0] and "reset it first" not in refusal[0], refusal
    page.keyboard.press("p")  # stay on the card (the loop's count-down is 30 s: a slow page is in time)
    wait_for(lambda: app.state().paused, what="P to hold the card")
    held = app.state().restart_in_s
    time.sleep(3.0)
    state = app.state()
    assert state.done is not None and state.runs == runs and state.paused and state.restart_in_s == held  # held
    assert page.locator("#run-card").is_visible()
    wait_for(lambda: "paused" in page.locator("#status-line").inner_text(), what="the header to say paused")
    shot(page, "desktop_end_of_run_held")
    page.keyboard.press("p")  # the count-down goes on: the next run comes
    wait_for(lambda: app.state().done is None, timeout=90, what="the next run after P again")
    session.call(SetVelocity(0.05, 0.0))
    session.call(SetTerrain(flat(), "flat"))


def test_one_notification_channel(live, page):
    """A session notice is one toast of the page; viser's own toasts are hidden in the embedded 3D view."""
    app, _ = live
    scene_shown(page)
    before = len(page.evaluate("window.__toasts"))
    page.evaluate("act('Noise', () => post('/api/settings', {noise: true}))")
    wait_for(lambda: any("noise" in t.lower() for t in page.evaluate("window.__toasts")[before:]), timeout=60,
             what="the notice's toast")
    time.sleep(2.0)
    said = [t for t in page.evaluate("window.__toasts")[before:] if "noise" in t.lower()]
    assert len(said) == 1, said
    hidden = page.evaluate("""() => { const doc = document.getElementById('viewer').contentDocument;
        const roots = [...doc.querySelectorAll('.mantine-Notifications-root')];
        return roots.length > 0 && roots.every((r) => doc.defaultView.getComputedStyle(r).display === 'none'); }""")
    assert hidden
    page.evaluate("act('Noise', () => post('/api/settings', {noise: false}))")


def test_the_header_never_wraps(live, page):
    """Desktop and phone: the header keeps one height whatever the status says (one line each, ellipsis; 1400 and
    1920 px: tests/test_browser_page.py)."""
    scene_shown(page)
    for width, height in ((1280, 800), (390, 844)):
        page.set_viewport_size({"width": width, "height": height})
        heights = set()
        for _ in range(4):
            heights.add(round(page.locator("header").bounding_box()["height"]))
            line = page.locator("#status-line").bounding_box()["height"]
            assert line < 24, line  # one line, never two
            time.sleep(0.5)
        assert len(heights) == 1, heights  # nothing below it moves
        assert page.evaluate("document.documentElement.scrollWidth") <= width
        if width == 390:
            shot(page, "phone_running")
    page.set_viewport_size({"width": 1280, "height": 800})
