"""A robot per visitor (app/api/visits.py): each browser (cookie jar) drives its own live session, requests
without the cookie drive the default one, a full server says so, idle sessions are reclaimed, watching is
read-only, and --shared gives everyone the one session."""

import time

import pytest
from fastapi.testclient import TestClient

from app.api.visits import VISIT_COOKIE, default_max_sessions, visit_cookie
from tests.helpers import live_app

BASE = "http://127.0.0.1:8000"  # a Host the tool answers to


def browser(app) -> TestClient:  # noqa: ANN001 - a ContactnetApp
    """A visitor: its own cookie jar, the page opened once (which gives it its visit)."""
    client = TestClient(app.api, base_url=BASE)
    page = client.get("/")
    assert page.status_code == 200, page.text[:200]
    return client


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    instance = live_app(tmp_path_factory, terrain="flat", planner="heuristic", vx_m_s=0.0, wait_for_viewer=False,
                        max_sessions=2, terrains_dir=tmp_path_factory.mktemp("terrains"))
    yield instance
    instance.close()


@pytest.fixture(autouse=True)
def no_visitors(request):
    """Each test starts with only the default session, free (the others reclaimed as after an idle time)."""
    if "app" in request.fixturenames:
        app = request.getfixturevalue("app")
        app.visits.reap(now=time.monotonic() + app.visits.idle_s + 1)


def test_two_browsers_drive_two_robots(app):
    first, second = browser(app), browser(app)
    assert first.cookies[VISIT_COOKIE] != second.cookies[VISIT_COOKIE]
    mine = first.get("/api/visits").json()["sessions"]
    assert len(mine) == 2 and sum(v["yours"] for v in mine) == 1
    # the first browser was given the default session: a script (no cookie) drives the robot it sees
    assert next(v for v in mine if v["yours"])["default"]
    first_info, second_info = first.get("/api/info").json(), second.get("/api/info").json()
    assert first_info["viser_port"] != second_info["viser_port"]
    assert first_info["watch_id"] != second_info["watch_id"]

    assert second.post("/api/command", json={"vx": 0.1, "vy": 0.0}).status_code == 200
    assert second.post("/api/session/terrain", json={"name": "stepping_stones"}).status_code == 200
    pushed = second.post("/api/push", json={"fx": 0.0, "fy": 3.0, "duration": 0.2})
    assert pushed.status_code == 200, pushed.text
    one, two = first.get("/api/state").json(), second.get("/api/state").json()
    assert two["vel_cmd"][0] == pytest.approx(0.1) and two["terrain"] == "stepping_stones"
    assert one["vel_cmd"][0] == pytest.approx(0.0) and one["terrain"] == "flat"  # untouched
    assert one["session_id"] != two["session_id"]

    script = TestClient(app.api, base_url=BASE)  # no cookie: the default session, as before visits existed
    assert script.get("/api/state").json()["session_id"] == one["session_id"]


def test_a_full_server_says_so_and_offers_to_watch(app):
    browser(app), browser(app)  # both sessions taken (the module's app runs at most 2)
    assert len(app.visits) == 2
    third = TestClient(app.api, base_url=BASE)
    page = third.get("/")
    assert page.status_code == 503 and "Every robot is taken" in page.text
    assert VISIT_COOKIE not in third.cookies
    watch_ids = [v["watch_id"] for v in third.get("/api/visits").json()["sessions"]]
    assert all(f"/?watch={w}" in page.text for w in watch_ids)
    # a watcher's page takes no session
    assert third.get("/", params={"watch": watch_ids[0]}).status_code == 200


def test_watching_is_a_second_view_without_the_control_panel(app):
    visitor = browser(app)
    watch_id = visitor.get("/api/info").json()["watch_id"]
    watcher = TestClient(app.api, base_url=BASE)
    watch = watcher.get(f"/api/visits/{watch_id}/watch").json()
    visit = app.visits.by_watch_id(watch_id)
    assert watch["viser_port"] not in (visit.viewer.port, app.visits.default.viewer.port)
    watch_view = visit.viewer._watch
    assert watch_view is not None and watch_view.server is not visit.viewer.server
    assert watch_view.port == watch["viser_port"]
    # viser's registry of shared GUI inputs (private, no public listing): the control panel's on the visit's server,
    # none on the watchers' (their camera block is per browser)
    assert visit.viewer.server.gui._gui_input_handle_from_uuid
    assert not watch_view.server.gui._gui_input_handle_from_uuid
    # the cookie is the secret, the watch id is not: a watch id as a cookie drives nothing
    impostor = TestClient(app.api, base_url=BASE, cookies={VISIT_COOKIE: watch_id})
    assert impostor.post("/api/command", json={"vx": 0.2, "vy": 0.0}).status_code == 410
    assert watcher.get("/api/visits/000000000000/watch").status_code == 404


def test_an_idle_session_is_reclaimed_and_its_cookie_asks_for_a_reload(app):
    first, visitor = browser(app), browser(app)
    assert app.visits.get(first.cookies[VISIT_COOKIE]).default  # the first browser is given the default session
    visit = app.visits.get(visitor.cookies[VISIT_COOKIE])
    assert visit is not None and not visit.default
    reclaimed = app.visits.reap(now=time.monotonic() + app.visits.idle_s + 1)
    assert visit.watch_id in reclaimed and app.visits.get(visit.visit_id) is None
    assert app.visits.default in app.visits.visits() and not app.visits.default.claimed  # released, not closed
    gone = visitor.post("/api/command", json={"vx": 0.1, "vy": 0.0})
    assert gone.status_code == 410 and "closed after" in gone.json()["detail"]
    assert visitor.get("/").status_code == 200  # a reload: a session again
    assert app.visits.get(visitor.cookies[VISIT_COOKIE]) is not None
    assert app.visits.get(visitor.cookies[VISIT_COOKIE]).default  # the reload got the free default session
    # released again: under a new id, so the cookie of the browser that left does not share the next one's robot
    app.visits.reap(now=time.monotonic() + app.visits.idle_s + 1)
    assert visitor.post("/api/command", json={"vx": 0.1, "vy": 0.0}).status_code == 410
    rejoined = visitor.post("/api/visits")  # what the page does on a 410
    assert rejoined.status_code == 200 and rejoined.json()["yours"]
    assert visitor.post("/api/command", json={"vx": 0.1, "vy": 0.0}).status_code == 200


def test_a_cookie_of_an_earlier_server_says_the_server_restarted(app):
    stale = TestClient(app.api, base_url=BASE, cookies={VISIT_COOKIE: "0" * 40})
    answer = stale.get("/api/state")
    assert answer.status_code == 410 and "restarted" in answer.json()["detail"]
    assert answer.headers["cache-control"] == "no-store"  # a cached 410 kept the page from its new session
    assert stale.get("/api/visits").status_code == 200  # the visits routes answer, to rejoin


def test_shared_serves_one_session_to_everyone(tmp_path_factory):
    app = live_app(tmp_path_factory, terrain="flat", planner="heuristic", wait_for_viewer=False, shared=True,
                   terrains_dir=tmp_path_factory.mktemp("terrains"))
    try:
        a, b = TestClient(app.api, base_url=BASE), TestClient(app.api, base_url=BASE)
        assert a.get("/").status_code == 200 and b.get("/").status_code == 200
        assert VISIT_COOKIE not in a.cookies and len(app.visits) == 1
        a.post("/api/command", json={"vx": 0.1, "vy": 0.0})
        assert b.get("/api/state").json()["vel_cmd"][0] == pytest.approx(0.1)
    finally:
        app.close()


def test_visit_cookie_parsing_and_the_default_limit():
    assert visit_cookie([(b"cookie", f"a=1; {VISIT_COOKIE}=abc".encode())]) == "abc"
    assert visit_cookie([(b"cookie", b"a=1")]) is None
    assert visit_cookie([(b"cookie", b'\x00bad="')]) is None
    assert default_max_sessions() >= 1
