"""Playing a recording to study it, in a real headless browser (Debian chromium, playwright): a short run of the
live session with a push from the API is recorded, then played on the front page: the timeline in simulated
seconds marks the push, the plots' cursor follows viser's own scrubber (a click on it) and a click on the push
marker moves the player there; the header and progress bar show the recording's frame, not the live session; the
exported HTML (one file, opened from file://) does the same; a recording made before tracks says it has none.
Screenshots in artifacts/ (browser_playback.png, browser_playback_export.png)."""

from __future__ import annotations

import re
import shutil
import time

import httpx
import numpy as np
import pytest
from helpers import ARTIFACTS, browser_marks, chromium, light, new_page, served, wait_for

pytestmark = browser_marks()

PUSH = {"fx": 0.0, "fy": 3.0, "duration": 0.3}


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    """The tool walking on flat ground with ContactNet; a recording of about 3 simulated s pushed in the middle,
    and an old recording (no data track, no metadata)."""
    from app.api.server import ContactnetApp
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port
    from contactnet.cli import main

    folder = tmp_path_factory.mktemp("recordings")
    cli = tmp_path_factory.mktemp("cli")
    assert main(["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic", "--vx", "0.1",
                 "--duration", "1.0", "--record", str(cli / "run.viser")]) == 0
    shutil.copy(cli / "run.viser", folder / "old.viser")  # as made before data tracks: the .viser file alone
    app = ContactnetApp(ServeSettings(terrain="flat", planner="contactnet", vx_m_s=0.1, wait_for_viewer=False,
                                      viser_port=free_port(), recordings_dir=folder))
    with served(app) as port:
        url = f"http://127.0.0.1:{port}"
        with httpx.Client(base_url=url, timeout=60) as client:  # no cookie: the default session
            state = lambda: client.get("/api/state").json()  # noqa: E731
            wait_for(lambda: state()["t_s"] > 0.5, what="the robot walking", timeout=120)
            client.post("/api/recordings/start", json={"label": "pushed", "title": "Pushed sideways"})
            started = state()["t_s"]
            wait_for(lambda: state()["t_s"] > started + 1.2, what="1.2 s recorded", timeout=120)
            pushed = client.post("/api/push", json=PUSH)
            assert pushed.status_code == 200, pushed.text
            wait_for(lambda: state()["t_s"] > pushed.json()["t_s"] + 1.5, what="1.5 s more", timeout=120)
            entry = client.post("/api/recordings/stop").json()
            track = client.get(entry["track_url"]).json()
        yield app, url, entry, track
    app.close()


@pytest.fixture(scope="module")
def browser():
    with chromium() as browser:
        yield browser


@pytest.fixture(scope="module")
def page(live, browser):
    _, url, _, _ = live
    page = new_page(browser)
    page.goto(light(url + "/"))
    page.locator("body[data-ready]").wait_for(timeout=90_000)
    yield page
    page.close()


def panel_time(page) -> float | None:
    value = page.locator("#playback-panel").get_attribute("data-t")
    return None if value is None else float(value)


def scrubber(frame) -> tuple[float, float]:  # noqa: ANN001 - a playwright FrameLocator
    """viser's scrubber: (time, length) of the recording it plays, as its slider says."""
    slider = frame.locator(".mantine-Slider-root [role=slider]")
    return float(slider.get_attribute("aria-valuenow")), float(slider.get_attribute("aria-valuemax"))


def header_t(page) -> float:
    """The simulated time the page's header shows (``t 1.2 s``)."""
    match = re.search(r"· t (-?[0-9.]+) s", page.locator("#status-line").inner_text())
    assert match, page.locator("#status-line").inner_text()
    return float(match.group(1))


def stopped(frame) -> float | None:  # noqa: ANN001 - a playwright FrameLocator
    """The scrubber's time when it stands still (paused) over 0.4 s, else None."""
    t = scrubber(frame)[0]
    time.sleep(0.4)
    return t if scrubber(frame)[0] == t else None


def click_scrubber(page, frame, fraction: float) -> float:  # noqa: ANN001 - playwright objects
    """Click viser's scrubber at ``fraction`` of its width; the time it pauses at. A player already paused stands
    still before the click takes effect, so only a pause away from where it stood at the click counts. A click the
    busy renderer lost (no such pause within 20 s) is repeated, twice at most."""
    bar = frame.locator(".mantine-Slider-root")
    seen = []
    for _ in range(3):
        box = bar.bounding_box()
        before = scrubber(frame)[0]
        page.mouse.click(box["x"] + fraction * box["width"], box["y"] + box["height"] / 2)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            t = stopped(frame)
            if t is not None and t != before:
                return t
            seen.append(scrubber(frame)[0])
    raise AssertionError(f"the scrubber never paused after a click: it read {seen[-8:]}")


def cursor_at(page, t: float, duration: float) -> None:
    """The timeline's cursor stands at recording time ``t`` (within 2 px)."""
    geometry = page.evaluate("""() => {
        const svg = document.querySelector('#playback-panel .pb-timeline');
        const lane = svg.querySelector('.pb-lane');
        return {x: parseFloat(svg.querySelector('.pb-cursor').getAttribute('x1')),
                left: parseFloat(lane.getAttribute('x')), width: parseFloat(lane.getAttribute('width'))};
    }""")
    assert geometry["x"] == pytest.approx(geometry["left"] + geometry["width"] * t / duration, abs=2.0)


def check_player(page, frame, track: dict, screenshot: str) -> None:  # noqa: ANN001 - playwright objects
    """What both players show: markers, the cursor following viser's scrubber and the push marker's seek."""
    panel = page.locator("#playback-panel")
    panel.wait_for(timeout=60_000)
    assert panel.get_attribute("data-track") == "yes"
    frame.locator(".mantine-Slider-root").wait_for(timeout=120_000)  # the player has loaded the recording
    wait_for(lambda: panel_time(page) is not None, what="the panel following the player", timeout=60)
    # the timeline's markers: the push where it was, no fall, no goal
    pushes = [e for e in track["events"] if e["kind"] == "push"]
    markers = page.locator(".pb-marker[data-kind=push]")
    assert markers.count() == len(pushes) == 1
    assert float(markers.first.get_attribute("data-rec-t")) == pytest.approx(pushes[0]["rec_t"], abs=1e-3)
    assert page.locator(".pb-marker[data-kind=fall]").count() == 0
    assert page.locator(".pb-marker[data-kind=stand]").count() == sum(e["kind"] == "stand" for e in track["events"])
    assert page.locator(".pb-tick-label").count() >= 3
    # viser's own scrubber, clicked at 25 % and 75 % (a click seeks and pauses there): the cursor of the timeline
    # and of the plots follows it
    _, duration = scrubber(frame)
    seen = []
    for fraction in (0.25, 0.75):
        t = click_scrubber(page, frame, fraction)
        assert all(abs(t - other) > 0.05 * duration for other in seen)  # it moved
        seen.append(t)
        wait_for(lambda t=t: panel_time(page) == pytest.approx(t, abs=1e-6), what="the panel at the scrubber", timeout=30)
        cursor_at(page, t, duration)  # the timeline spans the player's length
        xs = page.evaluate("() => [...document.querySelectorAll('#playback-panel .pb-cursor')].map(l => l.getAttribute('x1'))")
        assert len(xs) == 4 and len(set(xs)) == 1  # timeline, rank, velocity, planner: one time
        i = int(page.locator("#playback-panel").get_attribute("data-frame"))
        sim = track["frames"]["sim_t"][i]
        assert track["frames"]["rec_t"][i] <= t + 1e-6
        assert header_t(page) == pytest.approx(sim, abs=0.051)
    # a click on the push marker: the player goes there (and stays, paused); a click the busy page lost is repeated
    for attempt in range(3):
        markers.first.dispatch_event("click")
        try:
            wait_for(lambda: abs(scrubber(frame)[0] - pushes[0]["rec_t"]) < 0.01, what="the player at the push",
                     timeout=20)
            break
        except AssertionError:
            if attempt == 2:
                raise AssertionError(f"the player is at {scrubber(frame)}, not at the push {pushes[0]}") from None
    wait_for(lambda: "push (+0.0, +3.0) N" in page.locator(".pb-event").inner_text(), what="the push named", timeout=30)
    time.sleep(2.0)  # the 3D view draws the frame (software rendering)
    assert abs(scrubber(frame)[0] - pushes[0]["rec_t"]) < 0.01  # paused there
    # the header follows the player's frame (a busy machine's page may take a while: seen 1.9 s still shown): the
    # frame at or before the push, whose simulated time is the push's less at most the gap to the next frame (a busy
    # machine records frames further apart: seen 65 ms, the header 3.8 s for a push at 3.906 s)
    sim_t = np.asarray(track["frames"]["sim_t"])
    at = int(np.searchsorted(np.asarray(track["frames"]["rec_t"]), pushes[0]["rec_t"] + 1e-9) - 1)
    assert sim_t[at] <= pushes[0]["sim_t"] + 1e-6 and (at + 1 == len(sim_t) or sim_t[at + 1] >= pushes[0]["sim_t"] - 1e-6)
    try:
        wait_for(lambda: page.locator("#status-line").inner_text().startswith("▶ recording")
                 and header_t(page) == pytest.approx(sim_t[at], abs=0.051), what="the header at the push", timeout=60)
    except AssertionError:
        panel = page.locator("#playback-panel")
        raise AssertionError(f"the header reads {page.locator('#status-line').inner_text()!r} at the push {pushes[0]} "
                             f"(frame {at}, sim t {sim_t[at]}); the panel at frame {panel.get_attribute('data-frame')} "
                             f"(sim t {panel.get_attribute('data-sim-t')}, t {panel.get_attribute('data-t')}), the "
                             f"scrubber at {scrubber(frame)}") from None
    # one notification channel: viser's own toasts (its "software WebGL" warning on this machine) stay hidden in
    # the player, as in the live 3D view
    toasts = frame.locator(".mantine-Notifications-root")
    assert toasts.count() >= 1
    assert toasts.evaluate_all("roots => roots.map(r => getComputedStyle(r).display)") == ["none"] * toasts.count()
    page.screenshot(path=str(ARTIFACTS / screenshot), timeout=120_000)


def test_playback_shows_the_recording_with_markers_and_synced_plots(live, page):
    app, url, entry, track = live
    page.locator("#recordings-toggle").dispatch_event("click")
    item = page.locator("#recording-list li", has_text="Pushed sideways")
    item.wait_for(timeout=60_000)
    item.get_by_role("link", name="Play").dispatch_event("click")
    page.locator("#recordings-close").dispatch_event("click")
    check_player(page, page.frame_locator("#viewer"), track, "browser_playback.png")
    # the header and progress bar are the recording's while it plays: the live session walks on meanwhile
    progress = page.locator("#tracks .track")
    assert progress.count() == 1 and "pb-track" in progress.get_attribute("class")
    assert "recording" in progress.locator(".track-detail").inner_text()
    live_t = httpx.get(url + "/api/state").json()["t_s"]
    assert live_t > track["frames"]["sim_t"][-1]  # the live robot is further on than the recording ever got
    time.sleep(2.5)  # two polls of the live state: the header is not overwritten
    assert page.locator("#status-line").inner_text().startswith("▶ recording")
    page.locator("#back-to-live").dispatch_event("click")
    wait_for(lambda: page.locator("#playback-panel").count() == 0, what="the panel gone")
    wait_for(lambda: "▶ recording" not in page.locator("#status-line").inner_text(), what="the live header again")


def test_a_recording_without_a_track_says_so(live, page):
    page.locator("#recordings-toggle").dispatch_event("click")
    item = page.locator("#recording-list li", has_text="old.viser")
    item.wait_for(timeout=60_000)
    item.get_by_role("link", name="Play").dispatch_event("click")
    page.locator("#recordings-close").dispatch_event("click")
    panel = page.locator("#playback-panel")
    panel.wait_for(timeout=60_000)
    assert panel.get_attribute("data-track") == "no"
    assert "no data track" in panel.locator(".pb-note").inner_text()
    assert page.locator(".pb-marker").count() == 0
    wait_for(lambda: "▶ recording" in page.locator("#status-line").inner_text(), what="the header", timeout=60)
    page.locator("#back-to-live").dispatch_event("click")


def test_the_exported_html_plays_the_same_offline(live, page, tmp_path):
    """The page of the tests above opens the file (one page drawing a 3D view at a time: software WebGL takes a core
    and more for each)."""
    _, url, entry, track = live
    path = tmp_path / "pushed.html"
    path.write_text(httpx.get(url + entry["html_url"], timeout=60).text)
    page.goto("about:blank")  # the live page's own requests end here
    requests = []
    page.on("request", lambda request: requests.append(request.url))
    page.goto(path.as_uri())
    page.locator("body[data-ready]").wait_for(timeout=60_000)
    check_player(page, page.frame_locator("#viewer"), track, "browser_playback_export.png")
    assert page.title().startswith("Pushed sideways")
    fetched = [u for u in requests if u.startswith(("http:", "https:"))]
    assert not fetched, f"the one-file player fetched {fetched[:5]}"  # nothing from a network
