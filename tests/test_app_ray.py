"""Live sessions as Ray actors (``serve --engine ray``, app/live/ray_session.py) on a real local Ray of 2 CPUs: the
simulation runs in another process while the web process serves the API and draws the scene from the snapshots
it receives; /api/state advances; commands (velocity, push, terrain, an edit and its refusal) reach the robot;
the terrain crosses only when it changes; recording and compare mode work through the actor; a lost actor is one
line and its visit is reclaimed; closing the tool stops the actors (slow: Ray takes seconds to start)."""

from __future__ import annotations

import os
import signal

import pytest
from fastapi.testclient import TestClient

from app.api.visits import VISIT_COOKIE
from contactnet.jobs.ray_engine import session
from tests.helpers import live_app, wait_for

pytestmark = [pytest.mark.app]
slow = pytest.mark.slow  # the tests with Ray (it takes seconds to start) and simulations

BASE = "http://127.0.0.1:8000"  # a Host the tool answers to


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.fixture(scope="module")
def local_ray():
    """One local Ray of 2 CPUs for the module (loopback only); the tool uses it as it is and leaves it running."""
    with session(workers=2) as ray:
        assert ray.get_runtime_context().gcs_address.startswith("127.0.0.1:")
        yield ray
    assert not ray.is_initialized()


@pytest.fixture(scope="module")
def tool(local_ray, tmp_path_factory):
    app = live_app(tmp_path_factory, terrain="flat", planner="heuristic", vx_m_s=0.0, wait_for_viewer=False,
                   max_sessions=2, engine="ray", terrains_dir=tmp_path_factory.mktemp("terrains"))
    try:
        yield app
    finally:
        app.close()


@pytest.fixture
def client(tool):
    return TestClient(tool.api, base_url=BASE)


@slow
def test_the_simulation_runs_in_an_actor_and_the_state_advances(tool, client):
    from app.live.ray_session import RaySession

    session = tool.session
    assert isinstance(session, RaySession)
    assert session.worker_pid != os.getpid() and pid_alive(session.worker_pid)
    first = client.get("/api/state").json()
    later = wait_for(lambda: (s := client.get("/api/state").json())["t_s"] > first["t_s"] + 0.5 and s,
                     timeout=60, what="simulated time to grow")
    assert later["running"] and later["error"] is None and later["sim"] == "pybullet"
    assert client.get("/api/info").json()["session_id"] == session.session_id == later["session_id"]


@slow
def test_a_command_and_a_push_reach_the_robot(tool, client):
    start_x = client.get("/api/state").json()["base_position"][0]
    answer = client.post("/api/command", json={"vx": 0.15, "vy": 0.0})
    assert answer.status_code == 200 and answer.json()["vel_cmd"][0] == pytest.approx(0.15)  # the view after it
    wait_for(lambda: client.get("/api/state").json()["base_position"][0] > start_x + 0.05, timeout=60,
             what="the robot to walk forward")
    pushed = client.post("/api/push", json={"fx": 0.0, "fy": 3.0, "duration": 0.3})
    assert pushed.status_code == 200, pushed.text
    assert pushed.json()["pushes"] >= 1
    assert client.post("/api/command", json={"vx": 0.0, "vy": 0.0}).status_code == 200
    # a refused value never leaves the web process; a refusal of the session's comes back as itself (409)
    assert client.post("/api/command", json={"vx": 9.0, "vy": 0.0}).status_code == 422
    assert client.post("/api/pause", json={"paused": True}).status_code == 200
    refused = client.post("/api/push", json={"fx": 0.0, "fy": 3.0, "duration": 0.3})
    assert refused.status_code == 409 and "paused" in refused.json()["detail"]
    assert client.post("/api/pause", json={"paused": False}).status_code == 200


@slow
def test_the_terrain_crosses_only_when_it_changes(tool, client):
    from app.live import editor

    session = tool.session
    before = session.transfer.with_terrain
    views = session.transfer.views
    wait_for(lambda: session.transfer.views > views + 20, timeout=30, what="views to arrive")
    assert session.transfer.with_terrain == before  # no terrain in the views of an unchanged terrain
    assert 0 < session.transfer.bytes_mean < 30_000
    state = client.post("/api/session/terrain", json={"name": "stepping_stones"})
    assert state.status_code == 200 and state.json()["terrain"] == "stepping_stones"
    assert session.view.terrain.name == "stepping_stones" and session.view.terrain_dict["name"] == "stepping_stones"
    # once with the command's answer; a poll already in flight (asked with the old version) may carry it too
    assert before + 1 <= session.transfer.with_terrain <= before + 2
    crossed = session.transfer.with_terrain
    views = session.transfer.views
    wait_for(lambda: session.transfer.views > views + 20, timeout=30, what="views to arrive")
    assert session.transfer.with_terrain == crossed  # and not again
    # an edit is a function sent to the actor; far from the robot it applies in place (a new terrain version)
    goal = session.view.terrain.goal_x
    assert tool.terrains.edit(editor.punch_hole, (goal - 0.02, 0.0))
    assert session.view.terrain_dict != tool.terrains.store.load("stepping_stones").to_dict()
    assert session.view.status.terrain == "stepping_stones (edited)"
    tool.terrains.undo()
    with pytest.raises(editor.EditError):  # the session's own error, through Ray
        tool.terrains.undo()
    assert client.post("/api/session/terrain", json={"name": "flat"}).status_code == 200


@slow
def test_recording_and_compare_work_through_the_actor(tool, client):
    assert client.post("/api/recordings/start", json={"label": "through-ray"}).status_code == 200
    wait_for(lambda: client.get("/api/recordings/status").json()["frames"] >= 5, timeout=60,
             what="frames recorded from the actor's views")
    saved = client.post("/api/recordings/stop")
    assert saved.status_code == 200, saved.text
    compared = client.post("/api/compare", json={"planners": ["heuristic", "fixed"]})
    assert compared.status_code == 200, compared.text
    state = wait_for(lambda: (s := client.get("/api/state").json())["compare"] and s, timeout=30, what="compare")
    assert [robot["planner"] for robot in state["compare"]] == ["fixed"]
    assert client.post("/api/compare", json={"planners": []}).status_code == 200


@slow
def test_a_lost_actor_is_one_line_and_its_visit_is_reclaimed(tool):
    first = TestClient(tool.api, base_url=BASE)
    assert first.get("/").status_code == 200  # the default visit
    second = TestClient(tool.api, base_url=BASE)
    assert second.get("/").status_code == 200  # a visit of its own: a second actor
    visit = tool.visits.get(second.cookies[VISIT_COOKIE])
    assert visit is not None and not visit.default
    pid = visit.session.worker_pid
    assert pid != tool.visits.default.session.worker_pid
    os.kill(pid, signal.SIGKILL)  # the worker dies (as with a lost node)
    error = wait_for(lambda: second.get("/api/state").json().get("error")
                     or second.get("/api/state").status_code == 410, timeout=60, what="the loss to show")
    refused = second.post("/api/command", json={"vx": 0.1, "vy": 0.0})
    assert refused.status_code in (410, 503)
    assert "lost" in refused.json()["detail"] and "\n" not in refused.json()["detail"]
    tool.visits.reap_lost()
    gone = second.get("/api/state")
    assert gone.status_code == 410 and "Ray actor" in gone.json()["detail"] and "lost" in gone.json()["detail"]
    assert error is True or "lost" in error
    assert first.get("/api/state").json()["error"] is None  # the other visitor's robot is untouched
    # the default visit's actor lost: the tool gets a new default session (a new actor), the old cookie a 410
    default = tool.visits.default
    os.kill(default.session.worker_pid, signal.SIGKILL)
    wait_for(lambda: tool.visits.default is not default, timeout=90, what="a new default session")
    assert tool.visits.default.session.worker_pid not in (None, default.session.worker_pid)
    assert first.get("/api/state").status_code == 410
    script = TestClient(tool.api, base_url=BASE)  # no cookie: the new default session
    fresh = wait_for(lambda: (s := script.get("/api/state").json())["t_s"] > 0.2 and s, timeout=60,
                     what="the new default session to run")
    assert fresh["error"] is None


@slow
def test_closing_the_tool_stops_its_actors(local_ray, tmp_path_factory):
    app = live_app(tmp_path_factory, terrain="flat", planner="heuristic", vx_m_s=0.0, wait_for_viewer=False,
                   engine="ray")
    try:
        pid = app.session.worker_pid
        assert pid != os.getpid() and pid_alive(pid)
    finally:
        app.close()
    wait_for(lambda: not pid_alive(pid), timeout=30, what="the actor's process to end")
    assert local_ray.is_initialized()  # a Ray the tool did not start is left running


# ---- without Ray: the settings, the command line and the seam ----------------------------------------------------
def test_the_engine_is_a_setting_and_an_address_needs_ray():
    from app.live.settings import ServeSettings, settings_from_args

    assert ServeSettings().engine == "local" and ServeSettings().address is None
    assert settings_from_args({"engine": "ray", "address": "127.0.0.1:6379"}).address == "127.0.0.1:6379"
    with pytest.raises(ValueError, match="engine must be one of local, ray"):
        ServeSettings(engine="dask")
    with pytest.raises(ValueError, match="needs --engine ray"):
        ServeSettings(address="127.0.0.1:6379")


def test_serve_takes_engine_and_address(capsys):
    from contactnet.cli import EXIT_USER_ERROR, build_parser, main

    args = build_parser().parse_args(["serve", "--engine", "ray", "--address", "auto"])
    assert (args.engine, args.address) == ("ray", "auto")
    assert build_parser().parse_args(["serve"]).engine is None  # the setting's default: local
    assert main(["serve", "--address", "127.0.0.1:6379"]) == EXIT_USER_ERROR  # before anything starts
    err = capsys.readouterr().err.strip()
    assert "--engine ray" in err and len(err.splitlines()) == 1


def test_both_sessions_are_session_backends(tmp_path):
    from app.live.backend import SessionBackend
    from app.live.ray_session import RaySession
    from app.live.session import LiveSession
    from app.live.settings import ServeSettings
    from contactnet.terrain import flat

    settings = ServeSettings(terrain="flat")
    for kind in (LiveSession, RaySession):
        backend = kind(settings, flat(), "flat")  # not started
        assert isinstance(backend, SessionBackend) and not backend.alive and backend.lost is None


def test_a_poll_during_a_command_leaves_a_new_terrain_to_the_commands_answer(monkeypatch):
    """`SessionActor.latest` with ``carry_static`` False (a command is awaited): a view whose terrain or gait the
    receiver lacks is not sent (each such poll would carry the terrain again); one it can complete is."""
    from types import SimpleNamespace

    from app.live import ray_session
    from app.live.ray_session import SessionActor

    actor = SessionActor.__new__(SessionActor)  # no LiveSession: only `latest` is asked
    view = SimpleNamespace(seq=7, terrain_version=3, gait=SimpleNamespace(name="walk"))
    actor._session = SimpleNamespace(view=view, stats=None)
    packed = []
    monkeypatch.setattr(ray_session, "pack", lambda v, stats, known: packed.append(known) or b"view")
    assert actor.latest(7, (3, "walk"), False) is None  # not newer
    assert actor.latest(6, (2, "walk"), False) is None  # a new terrain: the command's answer brings it
    assert actor.latest(6, (3, "trot"), False) is None  # a new gait too
    assert actor.latest(6, (3, "walk"), False) == b"view"
    assert actor.latest(6, (2, "walk")) == b"view"  # no command awaited: the terrain crosses with the poll
    assert packed == [(3, "walk"), (2, "walk")]
