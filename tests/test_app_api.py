"""The REST API (app/api/server.py) against a real live session and viser server (no browser)."""

from __future__ import annotations

import json
import re
import shutil
import time

import pytest
from fastapi.testclient import TestClient
from helpers import wait_for

from app.api.server import ContactnetApp
from app.live.settings import ServeSettings
from app.recordings.recorder import free_port
from contactnet import registry
from contactnet.terrain import Terrain, terrains_dir

pytestmark = pytest.mark.app  # the web tool: `pytest -m "not app"` skips these


def save_random_model(path, gait: str) -> None:
    """A model file with random weights (the API tests do not depend on the shipped models)."""
    import numpy as np
    import torch

    from contactnet.planning.network import ContactNet, Normalizer, save_model

    torch.manual_seed(0)
    u = np.random.default_rng(0).normal(size=(64, 14)) * 0.1 + np.r_[np.zeros(8), 0.22, np.zeros(5)]
    save_model(path, ContactNet(registry.gait_by_name(gait).n_actions).eval(), Normalizer.fit(u), {"gait": gait})


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    terrains = tmp_path_factory.mktemp("terrains")
    for path in terrains_dir().glob("*.json"):
        shutil.copy(path, terrains / path.name)
    models = tmp_path_factory.mktemp("models")
    save_random_model(models / "trot.pt", "trot")  # and no walk model: walk falls back to heuristic
    instance = ContactnetApp(
        ServeSettings(
            terrain="flat",
            planner="heuristic",
            vx_m_s=0.0,
            wait_for_viewer=False,
            viser_port=free_port(),
            terrains_dir=terrains,
            recordings_dir=tmp_path_factory.mktemp("rec"),
            models_dir=models,
        )
    )
    yield instance
    instance.close()


@pytest.fixture(scope="module")
def client(app):
    return TestClient(app.api, base_url="http://127.0.0.1:8000")  # a Host the tool answers to


def detail_locations(response) -> list:
    return [tuple(error["loc"]) for error in response.json()["detail"]]


def test_state_and_info(client, app):
    state = client.get("/api/state").json()
    assert state["terrain"] == "flat" and state["gait"] == "walk" and state["viser_port"] == app.viser_port
    assert client.get("/api/info").json()["viser_port"] == app.viser_port
    assert "/api/command" in client.get("/openapi.json").json()["paths"]


def test_state_says_the_run_the_notices_and_the_scenario(client, app):
    state = client.get("/api/state").json()
    assert state["session_id"] == client.get("/api/info").json()["session_id"] == app.session.session_id
    assert not state["waiting_for_viewer"] and state["loop"] and state["goal_x_m"] > state["start_x_m"]
    assert 0.0 <= state["progress"] <= 1.0 and state["status_text"]
    assert state["scenario"] == {"terrain": state["terrain"], "removed": None, "seed": None, "gait": "walk",
                                 "planner": state["planner"], "compare": None}
    state = client.post("/api/settings", json={"loop": False}).json()
    assert state["loop"] is False and state["restart_in_s"] is None
    assert client.post("/api/settings", json={"loop": True}).json()["loop"] is True


def test_compare_mode_over_rest(client):
    state = client.post("/api/compare", json={"planners": ["heuristic", "fixed"]}).json()
    assert state["compare"] is not None and len(state["compare"]) == 1
    assert set(state["compare"][0]) == {"planner", "x", "fell", "success", "steps", "rank_mean"}
    assert state["compare"][0]["planner"] == "fixed" and state["scenario"]["compare"] == ["heuristic", "fixed"]
    assert "Compare mode" in state["notices"][-1]["text"]
    for body, field in (({"planners": ["heuristic"]}, "two planner names"), ({"planners": ["a", "b"]}, "planners"),
                        ({"planners": ["heuristic", "fixed", "oracle"]}, "planners")):
        response = client.post("/api/compare", json=body)
        assert response.status_code == 422 and field in response.text, body
    state = client.post("/api/compare", json={"planners": []}).json()
    assert state["compare"] is None and state["scenario"]["compare"] is None


def test_state_schema_describes_every_field(client):
    """Units and meaning of every State field are in the OpenAPI schema (what /docs shows)."""
    schema = client.get("/openapi.json").json()["components"]["schemas"]["State"]["properties"]
    undescribed = [name for name, field in schema.items() if not field.get("description")]
    assert not undescribed, undescribed


def test_api_docs_are_served_from_the_package_not_a_cdn(client):
    """Swagger UI and ReDoc load their scripts from this server (the machine may have no internet)."""
    for page_url in ("/docs", "/redoc"):
        page = client.get(page_url)
        assert page.status_code == 200, page_url
        assert "cdn" not in page.text.lower() and "https://" not in page.text
        assets = re.findall(r'(?:src|href)="(/static-offline-docs/[^"]+)"', page.text)
        assert assets, page.text[:300]
        for asset in assets:
            response = client.get(asset)
            assert response.status_code == 200 and len(response.content) > 1000, asset


def test_openapi_enums_are_the_registry_names(client):
    """The settings body offers exactly the registry's gaits and planners (no list of its own)."""
    schema = client.get("/openapi.json").json()
    properties = schema["components"]["schemas"]["SettingsCommand"]["properties"]

    def enum(field: str) -> tuple:
        (choice,) = [option for option in properties[field]["anyOf"] if "enum" in option]
        return tuple(choice["enum"])

    assert enum("gait") == registry.gait_names()
    assert enum("planner") == registry.planner_names()
    velocity = schema["components"]["schemas"]["VelocityCommand"]["properties"]["vx"]
    assert (velocity["minimum"], velocity["maximum"]) == (-0.3, 0.3)


def test_command_moves_the_robot(client):
    client.post("/api/reset")
    x0 = client.get("/api/state").json()["base_position"][0]
    state = client.post("/api/command", json={"vx": 0.1}).json()
    assert state["vel_cmd"] == [0.1, 0.0]
    wait_for(lambda: client.get("/api/state").json()["base_position"][0] - x0 > 0.1, timeout=30, poll_s=0.2,
             what="the robot 10 cm forward")  # about 2 s on an idle machine
    client.post("/api/command", json={"vx": 0.0, "vy": 0.0})


@pytest.mark.parametrize(
    "path, body, field",
    [
        ("/api/command", {"vx": 0.31}, "vx"),
        ("/api/command", {"vx": 0.0, "vy": -0.5}, "vy"),
        ("/api/command", {"vx": "fast"}, "vx"),
        ("/api/command", {"vx": True}, "vx"),
        ("/api/command", {}, "vx"),
        ("/api/command", {"vx": 0.1, "vz": 1.0}, "vz"),
        ("/api/push", {"fx": 25.0}, "fx"),
        ("/api/push", {"fy": -20.5}, "fy"),
        ("/api/push", {"fx": 5.0, "duration": 0.0}, "duration"),
        ("/api/push", {"fx": 5.0, "duration": 5.5}, "duration"),
        ("/api/settings", {"speed": 3.0}, "speed"),
        ("/api/settings", {"gait": "gallop"}, "gait"),
        ("/api/settings", {"planner": "teleport"}, "planner"),
        ("/api/settings", {"sim": "bullet"}, "sim"),
        ("/api/session/terrain", {"name": "../etc/passwd"}, "name"),
        ("/api/session/terrain", {"name": "random", "removed": 301}, "removed"),
    ],
)
def test_out_of_range_values_get_422_naming_the_field(client, path, body, field):
    before = client.get("/api/state").json()
    response = client.post(path, json=body)
    assert response.status_code == 422, response.text
    assert ("body", field) in detail_locations(response)
    after = client.get("/api/state").json()
    assert (after["vel_cmd"], after["pushes"], after["speed"], after["gait"]) == (
        before["vel_cmd"],
        before["pushes"],
        before["speed"],
        before["gait"],
    )


@pytest.mark.parametrize(
    "raw, field",
    [
        (b'{"vx": NaN}', "vx"),
        (b'{"vx": 0.1, "vy": Infinity}', "vy"),
        (b'{"vx": -Infinity}', "vx"),
    ],
)
def test_non_finite_values_get_422(client, raw, field):
    response = client.post("/api/command", content=raw, headers={"content-type": "application/json"})
    assert response.status_code == 422
    assert ("body", field) in detail_locations(response)
    response = client.post(
        "/api/push",
        content=raw.replace(b"vx", b"fx").replace(b"vy", b"fy"),
        headers={"content-type": "application/json"},
    )
    assert response.status_code == 422


def test_push_magnitude_is_limited(client):
    response = client.post("/api/push", json={"fx": 15.0, "fy": 15.0})
    assert response.status_code == 422
    assert "fx, fy" in response.json()["detail"][0]["msg"]


def test_push_is_registered(client):
    pushes = client.get("/api/state").json()["pushes"]
    state = client.post("/api/push", json={"fx": 5.0, "fy": 0.0, "duration": 1.0}).json()
    assert state["pushes"] == pushes + 1
    assert state["push_force"] == [5.0, 0.0, 0.0]


def test_pause_and_settings(client):
    assert client.post("/api/pause", json={"paused": True}).json()["paused"] is True
    t = client.get("/api/state").json()["t_s"]
    time.sleep(0.2)
    assert client.get("/api/state").json()["t_s"] == t
    state = client.post("/api/settings", json={"speed": 0.5, "planner": "contactnet"}).json()
    assert state["speed"] == 0.5
    assert state["planner"] == "contactnet" and state["planner_active"] == "heuristic"
    assert "no trained walk model yet" in state["planner_note"]
    state = client.post("/api/settings", json={"gait": "trot", "noise": True}).json()
    assert (state["gait"], state["planner_active"], state["noise"]) == ("trot", "contactnet", True)
    assert state["planner_note"] is None and state["paused"]  # a rebuild keeps the pause
    texts = [n["text"] for n in state["notices"][-2:]]
    assert "Gait set to trot" in texts[0] and "noise on" in texts[1]  # each restart is said
    client.post("/api/pause", json={"paused": False})
    wait = time.monotonic() + 20
    while (state := client.get("/api/state").json())["rank_chosen"] is None and time.monotonic() < wait:
        time.sleep(0.1)
    assert state["rank_chosen"] is not None and state["rank_chosen"] >= 0
    state = client.post("/api/settings", json={"speed": 1.0, "gait": "walk", "noise": False,
                                               "planner": "heuristic"}).json()
    assert (state["gait"], state["noise"], state["planner_note"]) == ("walk", False, None)
    assert client.post("/api/reset").json()["running"] is True


def test_the_physics_engine_switch(client):
    """POST /api/settings {"sim": ...} restarts the robot in that engine; the state and /api/info say which."""
    assert client.get("/api/state").json()["sim"] == "pybullet" == client.get("/api/info").json()["sim"]
    state = client.post("/api/settings", json={"sim": "mujoco"}).json()
    assert state["sim"] == "mujoco" and "MuJoCo: the robot restarted" in state["notices"][-1]["text"]
    t0 = state["t_s"]
    client.post("/api/pause", json={"paused": False})
    wait = time.monotonic() + 20
    while (state := client.get("/api/state").json())["t_s"] < t0 + 1.0 and time.monotonic() < wait:
        time.sleep(0.1)
    assert state["t_s"] >= t0 + 1.0 and state["fall_reason"] is None  # it runs in MuJoCo
    assert client.post("/api/settings", json={"sim": "pybullet"}).json()["sim"] == "pybullet"


def test_terrain_round_trip(client, app):
    listing = client.get("/api/terrains").json()
    assert {"flat", "stepping_stones"} <= {t["name"] for t in listing["terrains"]}
    stones = client.get("/api/terrains/stepping_stones").json()
    assert Terrain.from_dict(stones).name == "stepping_stones"
    stones["regions"].append({"shape": "circle", "center": [0.5, 0.4], "radius": 0.05})
    response = client.put("/api/terrains/my_stones", json=stones)
    assert response.status_code == 200, response.text
    saved = client.get("/api/terrains/my_stones").json()
    assert saved["name"] == "my_stones" and saved["regions"] == stones["regions"]
    state = client.post("/api/session/terrain", json={"name": "my_stones"}).json()
    assert state["terrain"] == "my_stones" and state["t_s"] < 0.1 and state["running"]  # from the start
    assert "my_stones loaded" in state["notices"][-1]["text"]
    assert state["scenario"]["terrain"] == "my_stones"
    state = client.post("/api/session/terrain", json={"name": "random", "removed": 60, "seed": 3}).json()
    assert state["terrain"].startswith("random")
    assert {k: state["scenario"][k] for k in ("terrain", "removed", "seed")} == {
        "terrain": "random", "removed": 60, "seed": 3}
    assert client.post("/api/session/terrain", json={"name": "nowhere"}).status_code == 404
    client.post("/api/session/terrain", json={"name": "flat"})
    client.post("/api/pause", json={"paused": False})


def test_shipped_terrains_need_confirmation(client, app):
    flat = client.get("/api/terrains/flat").json()
    before = (app.terrains.store.directory / "flat.json").read_bytes()
    response = client.put("/api/terrains/flat", json=flat | {"goal_x": 5.0})
    assert response.status_code == 409 and "confirm" in response.json()["detail"]
    assert (app.terrains.store.directory / "flat.json").read_bytes() == before
    assert client.put("/api/terrains/flat?overwrite=true", json=flat | {"goal_x": 5.0}).status_code == 200
    assert client.get("/api/terrains/flat").json()["goal_x"] == 5.0


@pytest.mark.parametrize("name", ["..%2F..%2Fetc%2Fpasswd", "..", "a.b", "%2Etmp", "x%00y", "-lead"])
def test_path_traversal_is_refused(client, app, name):
    body = client.get("/api/terrains/flat").json()
    files = sorted(p.name for p in app.terrains.store.directory.parent.rglob("*"))
    assert client.get(f"/api/terrains/{name}").status_code in (404, 422)
    assert client.put(f"/api/terrains/{name}", json=body).status_code in (404, 405, 422)
    assert sorted(p.name for p in app.terrains.store.directory.parent.rglob("*")) == files


def test_bad_and_huge_uploads_change_nothing(client, app):
    directory = app.terrains.store.directory
    files = {p.name: p.read_bytes() for p in directory.iterdir()}
    bad = client.put(
        "/api/terrains/broken",
        content=b'{"name": "x", "start": [0, 0], "goal_x": 1, "regions": '
        b'[{"shape": "rect", "center": [0, 0], "size": [0.1]}]}',
        headers={"content-type": "application/json"},
    )
    assert bad.status_code == 422 and "regions[0].size" in bad.json()["detail"]
    assert (
        client.put(
            "/api/terrains/broken", content=b"{not json", headers={"content-type": "application/json"}
        ).status_code
        == 422
    )
    huge = json.dumps({"name": "x", "pad": "y" * 1_100_000}).encode()
    response = client.put("/api/terrains/huge", content=huge, headers={"content-type": "application/json"})
    assert response.status_code == 413 and "limit" in response.json()["detail"]
    assert {p.name: p.read_bytes() for p in directory.iterdir()} == files


def test_recordings(client, app):
    assert client.post("/api/recordings/stop").status_code == 409
    status = client.post("/api/recordings/start", json={"label": "api test"}).json()
    assert status["recording"] and status["name"].endswith("-api-test.viser")
    assert client.post("/api/recordings/start").status_code == 409
    wait_for(lambda: app.recorder.status()["frames"] >= 3, what="frames recorded")  # a loaded machine is slow
    entry = client.post("/api/recordings/stop").json()
    assert entry["name"] == status["name"] and entry["size_bytes"] > 10_000
    assert entry["name"] in [r["name"] for r in client.get("/api/recordings").json()]
    download = client.get(entry["download_url"])
    assert download.status_code == 200 and len(download.content) == entry["size_bytes"]
    html = client.get(entry["html_url"])
    assert html.status_code == 200 and "__VISER_EMBED_DATA__" in html.text
    assert "attachment" in html.headers["content-disposition"]
    assert entry["play_url"] == f"/viewer/?playbackPath={entry['download_url']}"
    assert client.get("/api/recordings/missing.viser").status_code == 404
    assert client.get("/api/recordings/..%2Fx.viser").status_code in (404, 422)


def test_pages(client):
    page = client.get("/")
    assert page.status_code == 200 and 'id="viewer"' in page.text and "/docs" in page.text
    viewer = client.get("/viewer/")
    assert viewer.status_code == 200 and "<html" in viewer.text.lower()
    assert client.get("/static/app.js").status_code == 200
    icon = client.get("/favicon.ico")
    assert icon.status_code == 200 and icon.headers["content-type"].startswith("image/svg+xml")
    assert 'rel="icon"' in page.text


def test_the_api_s_examples_are_sensible_commands(client):
    """Swagger's "Try it out" fills in each field's example: the velocity command's must not be a full-speed
    reverse (without an example it takes the minimum, -0.3 m/s)."""
    schema = client.get("/openapi.json").json()["components"]["schemas"]["VelocityCommand"]["properties"]
    assert schema["vx"]["examples"] == [0.05] and schema["vy"]["examples"] == [0.0]


def test_clicks_in_the_3d_view_edit_the_terrain(client, app):
    """The editor's click path without a browser: a ray from above hits the plane z = surface_z."""
    from types import SimpleNamespace

    from app.live import editor
    from app.viewer.panels.terrain_editor import ray_to_plane

    assert ray_to_plane((0.3, 0.1, 1.0), (0.0, 0.0, -1.0), 0.0) == pytest.approx((0.3, 0.1))
    assert ray_to_plane((0.3, 0.1, 1.0), (0.0, 0.0, 1.0), 0.0) is None  # looking up
    assert ray_to_plane((0.3, 0.1, 1.0), (1.0, 0.0, 0.0), 0.0) is None  # parallel
    client.post("/api/session/terrain", json={"name": "stepping_stones"})
    panel = app.viewer.panel.editor
    before = Terrain.from_dict(app.terrains.current).steppable.area
    version = app.session.view.terrain_version

    def click(x: float, y: float) -> None:
        panel._on_click(
            SimpleNamespace(ray_origin=(x - 0.5, y, 1.0), ray_direction=(0.5, 0.0, -1.0), client=None)
        )

    panel.tool.value = "punch hole"
    click(0.12, 0.12)
    assert Terrain.from_dict(app.terrains.current).steppable.area == pytest.approx(before - 0.0025)
    assert app.session.view.terrain_version == version + 1
    assert client.get("/api/state").json()["terrain"] == "stepping_stones (edited)"
    panel.tool.value = "add star"
    click(0.7, 0.4)
    assert app.terrains.current["regions"][-1]["shape"] == "star"
    panel.tool.value = "select stone"
    click(0.7, 0.4)
    assert panel._selected == len(app.terrains.current["regions"]) - 1
    panel._gizmo.position = (0.8, 0.45, 0.01)  # as if dragged
    panel._on_moved(SimpleNamespace(phase="end", client=None))
    assert editor.region_pose(app.terrains.current["regions"][-1])[0] == pytest.approx((0.8, 0.45))
    panel._on_delete(SimpleNamespace(client=None))

    def history(button: str) -> None:  # as if clicked: setting a button group's value runs its callback
        panel.history_buttons.value = button

    history("Undo")
    assert app.terrains.current["regions"][-1]["shape"] == "star"
    for _ in range(3):
        history("Undo")
    assert Terrain.from_dict(app.terrains.current).steppable.area == pytest.approx(before)
    history("Redo")  # the hole comes back
    assert Terrain.from_dict(app.terrains.current).steppable.area == pytest.approx(before - 0.0025)
    panel.tool.value = "off"
    client.post("/api/session/terrain", json={"name": "flat"})
    client.post("/api/pause", json={"paused": False})


def test_serve_command_line(capsys):
    from contactnet.cli import EXIT_USER_ERROR, build_parser, cmd_serve, main

    args = build_parser().parse_args(["serve", "--port", "8123", "--viser-port", "8124", "--gait", "trot"])
    assert args.func is cmd_serve and (args.port, args.viser_port, args.gait) == (8123, 8124, "trot")
    assert main(["serve", "--terrain", "no_such_terrain"]) == EXIT_USER_ERROR  # before anything starts
    assert "no_such_terrain" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["serve", "--port", "70000"])


def test_retargeting_is_a_setting_off_by_default(client, app):
    """POST /api/settings {"retarget": ...} turns swing retargeting on and off in the live robot, no restart."""
    properties = client.get("/openapi.json").json()["components"]["schemas"]["SettingsCommand"]["properties"]
    assert "retarget" in properties and properties["retarget"]["description"]
    client.post("/api/pause", json={"paused": False})
    state = client.get("/api/state").json()
    assert state["retarget"] is False and app.session._loco.config.retarget is None
    for field in ("stand_steps", "useless_steps", "swing_retargets", "capture_steps"):
        assert isinstance(state[field], int) and state[field] >= 0, field
    assert isinstance(state["standing"], bool)
    wait_for(lambda: client.get("/api/state").json()["t_s"] > 0.2, what="the robot to run")
    state = client.post("/api/settings", json={"retarget": True}).json()
    assert state["retarget"] is True and app.session._loco.config.retarget is not None
    assert state["t_s"] > 0.2 and "retargeting on" in state["notices"][-1]["text"].lower()  # no restart
    response = client.post("/api/settings", json={"retarget": "yes"})
    assert response.status_code == 422 and ("body", "retarget") in detail_locations(response)
    assert client.get("/api/state").json()["retarget"] is True
    state = client.post("/api/settings", json={"retarget": False}).json()
    assert state["retarget"] is False and app.session._loco.config.retarget is None


def test_the_disturbance_observer_is_a_setting_on_by_default(client, app):
    """POST /api/settings {"observer": ...} turns the disturbance observer on and off in the live robot, no restart;
    toggling retargeting leaves it as it is."""
    properties = client.get("/openapi.json").json()["components"]["schemas"]["SettingsCommand"]["properties"]
    assert "observer" in properties and properties["observer"]["description"]
    client.post("/api/pause", json={"paused": False})
    state = client.get("/api/state").json()
    assert state["observer"] is True and app.session._loco.observer is not None  # on by default, like the library
    wait_for(lambda: client.get("/api/state").json()["t_s"] > 0.2, what="the robot to run")
    state = client.post("/api/settings", json={"observer": False}).json()
    assert state["observer"] is False and app.session._loco.observer is None
    assert state["t_s"] > 0.2 and "observer off" in state["notices"][-1]["text"].lower()  # no restart
    state = client.post("/api/settings", json={"observer": True}).json()
    assert state["observer"] is True and app.session._loco.observer is not None
    assert app.session._loco.config.observer is not None
    assert state["t_s"] > 0.2 and "observer on" in state["notices"][-1]["text"].lower()  # no restart
    client.post("/api/settings", json={"retarget": True})
    assert app.session._loco.observer is not None  # the other switch keeps it
    assert client.get("/api/state").json()["estimated_push"] is None  # undisturbed: below its threshold
    client.post("/api/push", json={"fx": 0.0, "fy": 5.0, "duration": 1.0})
    wait_for(lambda: client.get("/api/state").json()["estimated_push"] is not None, what="the push to be estimated")
    estimate = client.get("/api/state").json()["estimated_push"]
    assert estimate[1] > 2.0 and abs(estimate[0]) < estimate[1] and estimate[2] == 0.0  # along +y, as pushed
    response = client.post("/api/settings", json={"observer": "maybe"})
    assert response.status_code == 422 and ("body", "observer") in detail_locations(response)
    state = client.post("/api/settings", json={"observer": False, "retarget": False}).json()
    assert state["observer"] is False and app.session._loco.observer is None and app.session._loco.config.observer is None
    assert client.post("/api/settings", json={"observer": True}).json()["observer"] is True  # the default again


def test_a_planner_that_stands_shows_in_the_state(client):
    """Zero command on flat: the oracle stands (by choice); /api/state counts the stands and says so."""
    client.post("/api/pause", json={"paused": False})
    client.post("/api/command", json={"vx": 0.0, "vy": 0.0})
    client.post("/api/settings", json={"planner": "oracle", "gait": "walk"})
    state = wait_for(lambda: (s := client.get("/api/state").json())["stand_steps"] >= 2 and s, timeout=60,
                     what="two stand horizons")
    assert state["standing"] and state["steps"] == 0 and state["useless_steps"] == 0
    assert state["status_text"].startswith("standing (planner's choice) · ")
    assert f"stood {state['stand_steps']}" in state["status_text"]
    client.post("/api/command", json={"vx": 0.1, "vy": 0.0})  # a command: it walks again
    state = wait_for(lambda: (s := client.get("/api/state").json())["steps"] >= 1 and s, timeout=60, what="a step")
    assert state["stand_steps"] >= 2  # the run's count stays
    client.post("/api/command", json={"vx": 0.0, "vy": 0.0})
    client.post("/api/settings", json={"planner": "heuristic"})


def test_one_table_maps_library_errors_to_statuses():
    """`app.api.errors.ERROR_STATUS`: a subclass is matched before its base (a stored terrain that is not valid
    is a 409, not the 422 of other edit errors; a command conflict a 409, not the 503 of a stopped session)."""
    from app.api.errors import ERROR_STATUS, status_of
    from app.live.commands import CommandConflict
    from app.live.editor import EditError, ShippedTerrainError
    from app.live.terrain_files import StoredTerrainError
    from app.recordings.live_recorder import RecordingBusy

    cases = {FileNotFoundError("x"): 404, CommandConflict("x"): 409, StoredTerrainError("x"): 409,
             ShippedTerrainError("x"): 409, RecordingBusy("x"): 409, FileExistsError("x"): 409, EditError("x"): 422,
             ValueError("x"): 422, TimeoutError(): 504, RuntimeError("x"): 503, KeyError("x"): None}
    assert {type(e).__name__: status_of(e) for e in cases} == {type(e).__name__: s for e, s in cases.items()}
    for i, (kind, _) in enumerate(ERROR_STATUS):  # no entry is shadowed by an earlier, more general one
        assert not any(issubclass(kind, earlier) for earlier, _ in ERROR_STATUS[:i]), kind
