"""Issue 11, the web side, replayed as a hostile but fair tester would: a big terrain upload must not freeze
the API (finding 1), no body is unbounded and no error echoes its input (5), other sites and other Host
names get nowhere (6), Ctrl-C/SIGTERM keeps a recording in progress (8), the OpenAPI schema tells the truth
(9), and schemathesis with all checks finds nothing (a short run here; tests/schemathesis.toml)."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import httpx
import pytest
from helpers import served_flat_tool, wait_for

from app.live.settings import ServeSettings
from app.recordings.recorder import free_port, read_recording
from contactnet.terrain import Terrain, terrains_dir

pytestmark = pytest.mark.app

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    with served_flat_tool(tmp_path_factory.mktemp("data")) as live:
        yield live


@pytest.fixture(scope="module")
def app(live):
    return live[0]


@pytest.fixture(scope="module")
def client(live):
    with httpx.Client(base_url=f"http://127.0.0.1:{live[1]}", timeout=120) as client:
        yield client


@pytest.fixture
def running(client, app):
    """The robot walking (on flat ground, standing still), whatever an earlier test did."""
    client.post("/api/session/terrain", json={"name": "flat"})
    client.post("/api/reset")
    wait_for(lambda: app.state().running, what="the robot to run")


def one_line(response: httpx.Response) -> str:
    """The response's detail, checked to be one short line (FastAPI's field-error lists: their messages)."""
    detail = response.json()["detail"]
    text = detail if isinstance(detail, str) else " ".join(error["msg"] for error in detail)
    assert "\n" not in text and len(response.content) < 2_000, response.text[:500]
    return text


# ---- finding 1: a large upload runs off the event loop, validated once --------------------------------------
@pytest.mark.slow
def test_state_keeps_answering_while_a_large_terrain_is_uploaded(live):
    from app.bench.upload import grid_terrain, state_during_upload

    app, port = live
    body = json.dumps(grid_terrain(500, 500, 20_000)).encode()  # the 232 KB terrain
    idle, during = state_during_upload(port, body, name="big_grid", idle_s=1.0)
    print(f"\nGET /api/state during a {during['upload_kB']} kB terrain upload ({during['upload_s']} s, "
          f"answer {during['upload_status']}): {during['state_answers']} answers, p50 {during['state_p50_ms']} ms, "
          f"p99 {during['state_p99_ms']} ms, max {during['state_max_ms']} ms (no upload: p99 {idle['state_p99_ms']} ms)")
    assert during["upload_status"] in (200, 422)  # valid, or refused by the terrain budget with one line
    assert during["state_answers"] >= 5  # the API kept answering while the terrain was validated (before: 0)


def test_an_upload_is_validated_once(client, app, monkeypatch):
    constructed = []
    original = Terrain.__post_init__

    def counting(self):
        constructed.append(self.name)
        original(self)

    monkeypatch.setattr(Terrain, "__post_init__", counting)
    stones = json.loads((terrains_dir() / "stepping_stones.json").read_bytes())
    response = client.put("/api/terrains/once", json=stones)
    assert response.status_code == 200, response.text
    assert constructed == ["once"]  # one validation (the file is then written as validated)


# ---- finding 5: body limits, no echo, strict JSON ---------------------------------------------------------
def test_oversized_bodies_get_413_by_length_and_while_streaming(client, app):
    before = app.state()
    big = json.dumps({"vx": 0.1, "pad": "x" * 100_000}).encode()
    response = client.post("/api/command", content=big, headers={"content-type": "application/json"})
    assert response.status_code == 413 and "limit" in one_line(response)

    def chunks():  # no Content-Length: refused once the stream passes the limit
        yield b'{"vx": 0.1, "pad": "'
        for _ in range(100):
            yield b"x" * 10_000
        yield b'"}'

    response = client.post("/api/command", content=chunks(), headers={"content-type": "application/json"})
    assert response.status_code == 413 and "limit" in one_line(response)

    def terrain_chunks():
        for _ in range(120):
            yield b" " * 10_000

    response = client.put("/api/terrains/huge", content=terrain_chunks(),
                          headers={"content-type": "application/json"})
    assert response.status_code == 413 and "1000000" in one_line(response)
    assert not (app.terrains.store.directory / "huge.json").exists()
    assert app.state().vel_cmd == before.vel_cmd


def test_a_50_mb_command_gets_a_short_answer(app):
    from fastapi.testclient import TestClient

    client = TestClient(app.api, base_url="http://127.0.0.1:8000")
    body = json.dumps({"vx": [0.1] * 10_000_000}).encode()  # 50 MB: came back as a 100 MB 422 before
    assert len(body) > 50_000_000
    response = client.post("/api/command", content=body, headers={"content-type": "application/json"})
    assert response.status_code == 413 and len(response.content) < 300


def test_422_quotes_at_most_an_excerpt_of_the_input(client):
    body = json.dumps({"vx": "y" * 60_000}).encode()  # under the limit, but no float
    response = client.post("/api/command", content=body, headers={"content-type": "application/json"})
    assert response.status_code == 422 and len(response.content) < 1_000
    (error,) = response.json()["detail"]
    assert error["loc"] == ["body", "vx"] and len(str(error["input"])) <= 80
    listed = json.dumps({"vx": list(range(8_000))}).encode()
    response = client.post("/api/command", content=listed, headers={"content-type": "application/json"})
    assert response.status_code == 422 and len(response.content) < 1_000


@pytest.mark.parametrize(
    "raw, words",
    [
        (b'{"vx": 0.1, "vx": 0.2}', "duplicate key"),
        (b'{"vx": 1' + b"0" * 5000 + b"}", "number of 5001 characters"),
        (b'{"vx": ' + b"[" * 100 + b"]" * 100 + b"}", "nested deeper"),
        (b'{"vx": 0.1', "not valid JSON"),
        (b'{"vx": "\xff"}', "not UTF-8"),
    ],
)
def test_bad_json_is_one_line_422(client, app, raw, words):
    before = app.state().vel_cmd
    response = client.post("/api/command", content=raw, headers={"content-type": "application/json"})
    assert response.status_code == 422, response.text[:300]
    assert words in one_line(response)
    assert app.state().vel_cmd == before


@pytest.mark.parametrize(
    "raw, words",
    [
        (b'{"name": "x", "name": "y", "start": [0, 0], "goal_x": 1, "regions": []}', "duplicate key"),
        (b'{"name": "x", "start": [0, 0], "goal_x": 1' + b"0" * 4400 + b', "regions": []}', "characters"),
    ],
)
def test_bad_terrain_json_is_one_line_422_and_writes_nothing(client, app, raw, words):
    folder = app.terrains.store.directory
    files = sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []
    response = client.put("/api/terrains/hostile", content=raw, headers={"content-type": "application/json"})
    assert response.status_code == 422 and words in one_line(response)
    assert (sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []) == files


# ---- finding 6: Host, cross-site requests, viser's websocket, the data folder --------------------------------
@pytest.mark.parametrize("host", ["attacker.example", "attacker.example:8000", "127.0.0.1.nip.io", "[::2]:80", ""])
def test_other_host_names_are_refused(client, app, host):
    t0 = app.state().t_s
    for method, path in (("GET", "/api/state"), ("POST", "/api/reset"), ("GET", "/"), ("GET", "/docs")):
        response = client.request(method, path, headers={"host": host})
        assert response.status_code in (400, 421), (method, path, response.status_code)
    assert app.state().t_s >= t0  # not reset


def test_allowed_host_names(client):
    port = client.base_url.port
    for host in ("127.0.0.1", f"127.0.0.1:{port}", f"localhost:{port}", "LOCALHOST", f"[::1]:{port}"):
        assert client.get("/api/state", headers={"host": host}).status_code == 200, host


def test_a_text_plain_post_from_another_page_changes_nothing(client, app, running):
    """What a <form enctype=text/plain> or a no-cors fetch of any web page sends."""
    pushes, t0 = app.state().pushes, app.state().t_s
    for path, body in (("/api/reset", "{}"), ("/api/recordings/start", '{"label": "x"}'),
                       ("/api/push", '{"fx": 5}')):
        response = client.post(path, content=body, headers={"content-type": "text/plain"})
        assert response.status_code == 415 and "application/json" in one_line(response)
        response = client.post(path, content="a=b", headers={"content-type": "application/x-www-form-urlencoded"})
        assert response.status_code == 415
    state = app.state()
    assert state.pushes == pushes and state.t_s >= t0 and not state.recording


def test_cross_site_requests_are_refused(client, app, running):
    port = client.base_url.port
    t0 = app.state().t_s
    for headers in ({"origin": "https://attacker.example"}, {"origin": "null"},
                    {"origin": f"http://localhost:{port + 1}"}, {"sec-fetch-site": "cross-site"},
                    {"sec-fetch-site": "same-site"}):
        response = client.post("/api/reset", json={}, headers=headers)
        assert response.status_code == 403 and "cross-site" in one_line(response), headers
    assert app.state().t_s >= t0
    same = client.post("/api/command", json={"vx": 0.0}, headers={"origin": f"http://127.0.0.1:{port}",
                                                                  "sec-fetch-site": "same-origin"})
    assert same.status_code == 200


def test_viser_accepts_websockets_only_from_the_page(live):
    import viser
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    app, port = live
    uri = f"ws://127.0.0.1:{app.viser_port}/"
    protocol = [f"viser-v{viser.__version__}"]
    with connect(uri, subprotocols=protocol, origin=f"http://127.0.0.1:{port}", open_timeout=10) as ws:
        assert ws.recv(timeout=10)  # the page's origin: the scene comes
    with connect(uri, subprotocols=protocol, open_timeout=10) as ws:  # no Origin: not a browser
        assert ws.recv(timeout=10)
    for origin, host, status in (("https://attacker.example", None, 403),
                                 (f"http://127.0.0.1:{app.viser_port + 1}", None, 403),
                                 (f"http://attacker.example:{port}", "attacker.example", 421)):
        headers = {"Host": host} if host else None
        with pytest.raises(InvalidStatus) as refused:
            connect(uri, subprotocols=protocol, origin=origin, additional_headers=headers, open_timeout=10)
        assert refused.value.response.status_code == status
    assert httpx.get(f"http://127.0.0.1:{app.viser_port}/", headers={"host": "attacker.example"}).status_code == 421


def test_viser_share_link_is_disabled(app):
    from viser import _messages

    assert app.viewer.server.request_share_url() is None  # no relay contacted
    buffer = app.viewer.server._websock_server.get_message_buffer()
    themes = [m for m in buffer.message_from_id.values() if isinstance(m, _messages.ThemeConfigurationMessage)]
    assert themes and not themes[-1].show_share_button


def test_beyond_loopback_a_token_is_required():
    from fastapi import FastAPI
    from fastapi.testclient import TestClient

    from app.security.guards import TOKEN_COOKIE, AccessPolicy, RequestGuard, viser_refusal

    policy = AccessPolicy(ServeSettings(host="0.0.0.0", port=8000))
    assert policy.needs_token and len(policy.token) >= 24
    assert AccessPolicy(ServeSettings(host="0.0.0.0", token="t" * 20)).token == "t" * 20
    assert AccessPolicy(ServeSettings()).token is None  # loopback
    inner = FastAPI()
    inner.get("/api/state")(lambda: {"ok": True})
    inner.post("/api/reset")(lambda: {"ok": True})
    client = TestClient(RequestGuard(inner, policy, lambda method, path: 1000), base_url="http://192.168.1.20:8000")
    assert client.get("/api/state").status_code == 401
    assert client.get("/api/state", headers={"x-contactnet-token": "wrong" * 5}).status_code == 401
    assert client.get("/api/state", headers={"x-contactnet-token": policy.token}).status_code == 200
    assert client.get("/api/state", headers={"authorization": f"Bearer {policy.token}"}).status_code == 200
    opened = client.get(f"/api/state?token={policy.token}")  # the address printed at start-up
    assert opened.status_code == 200 and "HttpOnly" in opened.headers["set-cookie"]
    assert client.cookies.get(TOKEN_COOKIE) == policy.token
    assert client.post("/api/reset", json={}).status_code == 200  # the page, with its cookie
    assert client.get("/api/state", headers={"host": "attacker.example"}).status_code == 421
    ws = {"Host": "192.168.1.20:8080", "Upgrade": "websocket", "Origin": "http://192.168.1.20:8000"}
    assert viser_refusal(policy, ws, "/") == (401, "access token missing")
    assert viser_refusal(policy, ws | {"Cookie": f"{TOKEN_COOKIE}={policy.token}"}, "/") is None


def test_user_files_live_in_the_data_folder_and_shipped_terrains_stay_read_only(client, app, monkeypatch, tmp_path):
    monkeypatch.setenv("CONTACTNET_DATA", str(tmp_path))
    settings = ServeSettings()
    assert settings.user_terrains_dir() == tmp_path / "terrains"
    assert settings.recordings_folder() == tmp_path / "recordings"
    with pytest.raises(ValueError, match="^terrains_dir must be"):
        ServeSettings(terrains_dir=terrains_dir())
    shipped = {p.name: p.read_bytes() for p in terrains_dir().glob("*.json")}
    flat = client.get("/api/terrains/flat").json()
    assert client.put("/api/terrains/flat", json=flat | {"goal_x": 4.0}).status_code == 409
    response = client.put("/api/terrains/flat?overwrite=true", json=flat | {"goal_x": 4.0})
    assert response.status_code == 200
    assert response.json()["path"] == "flat.json"  # its name, never a folder of the machine
    assert (app.terrains.store.directory / "flat.json").is_file()  # the user's copy
    assert client.get("/api/terrains/flat").json()["goal_x"] == 4.0  # shadows the shipped file
    assert {p.name: p.read_bytes() for p in terrains_dir().glob("*.json")} == shipped
    assert {t["name"]: t["shipped"] for t in client.get("/api/terrains").json()["terrains"]}["flat"] is True


# ---- finding 8 (serve half): Ctrl-C / SIGTERM keep the recording in progress ---------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_serve_saves_the_recording_in_progress_on_a_signal(tmp_path, signum):
    port, viser_port = free_port(), free_port()
    env = os.environ | {"CONTACTNET_DATA": str(tmp_path), "CONTACTNET_LOG": "WARNING"}
    process = subprocess.Popen(
        [sys.executable, "-m", "contactnet.cli", "serve", "--port", str(port), "--viser-port", str(viser_port),
         "--terrain", "flat", "--planner", "heuristic", "--vx", "0", "--no-wait"],  # walks with no browser
        cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        base = f"http://127.0.0.1:{port}"

        def up() -> bool:
            try:
                return httpx.get(f"{base}/api/state", timeout=2).status_code == 200
            except httpx.TransportError:
                assert process.poll() is None, process.communicate()[1]
                return False

        wait_for(up, timeout=120, what="contactnet serve")
        name = httpx.post(f"{base}/api/recordings/start", json={"label": "interrupted"}).json()["name"]
        wait_for(lambda: httpx.get(f"{base}/api/recordings/status").json()["frames"] >= 6, timeout=30,
                 what="a few recorded frames")
        process.send_signal(signum)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 0, err
    assert f"saved the recording in progress: {name}" in err
    saved = tmp_path / "recordings" / name
    assert read_recording(saved.read_bytes()).duration_s > 0.3
    assert "Traceback" not in err


# ---- finding 9: the schema tells the truth ------------------------------------------------------------------
def test_get_of_a_post_route_is_405(client):
    for path, allowed in (("/api/recordings/start", "POST"), ("/api/recordings/stop", "POST"),
                          ("/api/reset", "POST")):
        response = client.get(path)
        assert response.status_code == 405 and response.headers["allow"] == allowed, path
    response = client.request("DELETE", "/api/terrains/flat")
    assert response.status_code == 405 and response.headers["allow"] == "GET, PUT"


def test_zero_push_is_422_and_a_push_that_cannot_act_is_409(client, app, running):
    pushes = app.state().pushes
    for body in ({"fx": 0.0, "fy": 0.0}, {}, {"fx": 0, "duration": 1.0}):
        response = client.post("/api/push", json=body)
        assert response.status_code == 422 and "more than 0 N" in one_line(response)
    client.post("/api/pause", json={"paused": True})
    response = client.post("/api/push", json={"fx": 5.0})
    assert response.status_code == 409 and "paused" in one_line(response)
    assert app.state().pushes == pushes and not app.state().push_force[0]
    client.post("/api/pause", json={"paused": False})
    assert client.post("/api/push", json={"fx": 5.0, "duration": 0.2}).json()["pushes"] == pushes + 1


def test_a_push_along_an_angle_and_an_impulse(client, app, running):
    pushes = app.state().pushes
    state = client.post("/api/push/angle", json={"angle_deg": 90.0, "force": 5.0, "duration": 3.0}).json()
    assert state["pushes"] == pushes + 1 and state["push_force"][:2] == pytest.approx([0.0, 5.0], abs=1e-6)
    state = client.post("/api/push/impulse", json={"angle_deg": 180.0, "impulse": 1.0}).json()  # 10 N over 0.1 s
    assert state["pushes"] == pushes + 2
    for route, body, field in (("/api/push/angle", {"angle_deg": 0.0, "force": 5.0, "impulse": 1.0}, "impulse"),
                               ("/api/push/angle", {"angle_deg": 10.0}, "force"),
                               ("/api/push/impulse", {"angle_deg": 10.0, "impulse": 2.5}, "impulse"),
                               ("/api/push/angle", {"angle_deg": 1e9, "force": 1}, "angle_deg")):
        response = client.post(route, json=body)
        assert response.status_code == 422, body
        assert [error["loc"] for error in response.json()["detail"]] == [["body", field]], response.text[:300]
        one_line(response)
    assert app.state().pushes == pushes + 2


HOSTILE = [
    ("GET", "/api/terrains/nowhere", None),
    ("GET", "/api/terrains/broken_file", None),
    ("PUT", "/api/terrains/flat", b"{}"),
    ("PUT", "/api/terrains/mine", b'{"name": "x", "start": [0, 0], "goal_x": 1, "regions": [{"shape": "blob"}]}'),
    ("PUT", "/api/terrains/mine", b"[1, 2]"),
    ("POST", "/api/session/terrain", b'{"name": "nowhere"}'),
    ("POST", "/api/session/terrain", b'{"name": "broken_file"}'),
    ("POST", "/api/session/terrain", b'{"name": "random"}'),
    ("POST", "/api/command", b'{"vx": 0.1, "vx": 0.2}'),
    ("POST", "/api/push", b'{"fx": 30}'),
    ("POST", "/api/settings", b'{"gait": "gallop"}'),
    ("POST", "/api/recordings/stop", None),
    ("GET", "/api/recordings/missing.viser", None),
    ("GET", "/api/recordings/missing.viser/html?download=maybe", None),
    ("POST", "/api/pause", b'{"paused": "yes"}'),
]


def test_every_error_is_declared_with_its_model_and_shows_no_path(client, app):
    (app.terrains.store.directory / "broken_file.json").write_text('{"name": "broken_file", "start": [0, 0]')
    schema = client.get("/openapi.json").json()
    components = schema["components"]["schemas"]
    secret_dirs = {str(app.terrains.store.directory), str(app.recordings.directory), str(REPO), str(Path.home())}
    for method, path, body in HOSTILE:
        headers = {"content-type": "application/json"} if body is not None else {}
        response = client.request(method, path, content=body, headers=headers)
        assert 400 <= response.status_code < 500, (method, path, response.status_code, response.text)
        template = next(
            p for p in schema["paths"]
            if re.fullmatch(re.sub(r"\{[^}]+\}", "[^/]+", p), path.split("?")[0]) and method.lower() in schema["paths"][p]
        )
        declared = schema["paths"][template][method.lower()]["responses"]
        assert str(response.status_code) in declared, (method, path, response.status_code)
        ref = declared[str(response.status_code)]["content"]["application/json"]["schema"]["$ref"].split("/")[-1]
        detail = response.json()["detail"]
        if ref == "Problem":
            assert isinstance(detail, str)
        else:
            assert components[ref]["properties"]["detail"]
            assert isinstance(detail, str) or all({"loc", "msg", "type"} <= set(e) for e in detail)
        text = response.text
        assert not any(d in text for d in secret_dirs), text
        assert not re.search(r"(?<![\w.])/(home|root|tmp|work|usr|var)/", text), text


def test_422_detail_matches_the_declared_schema(client):
    schema = client.get("/openapi.json").json()
    declared = schema["paths"]["/api/command"]["post"]["responses"]["422"]["content"]["application/json"]
    assert declared["schema"]["$ref"].endswith("/ValidationProblem")
    problem = schema["components"]["schemas"]["ValidationProblem"]["properties"]["detail"]
    assert {"type": "string"} in problem["anyOf"]
    for body in ({"vx": "fast"}, {"vx": 0.1, "vz": 1}):
        detail = client.post("/api/command", json=body).json()["detail"]
        assert isinstance(detail, list) and all(set(e) <= {"loc", "msg", "type", "input"} for e in detail)


# ---- schemathesis, all checks, a short run against the live server (the last test: it changes the session) ---
@pytest.mark.slow
def test_schemathesis_finds_nothing(live, tmp_path):
    pytest.importorskip("schemathesis")
    _, port = live
    command = [sys.executable, "-m", "schemathesis.cli", "--config-file", str(REPO / "tests" / "schemathesis.toml"),
               "run", f"http://127.0.0.1:{port}/openapi.json", "--checks", "all", "--max-examples", "15",
               "--seed", "11", "--generation-database", "none", "--no-color", "--phases", "coverage,fuzzing"]
    result = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    summary = result.stdout[-3000:]
    print(summary)
    assert result.returncode == 0, summary
    assert "failure" not in summary.splitlines()[-1] and "error" not in summary.splitlines()[-1], summary
