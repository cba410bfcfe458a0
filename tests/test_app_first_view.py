"""A first view that explains itself (issue 31, items 3 and 6), the Python side: the status sentence's state word
(`status_kind`: no flip between walking and standing on a walking robot's stand horizons), the P key at the end of
a run (holds the loop's count-down, never starts the next run), the REST routes the page's keys use (nudge,
toggle), the state stream the page follows (GET /api/state/stream), and a refused control of the 3D view told
through the session's notices (one notification channel). The browser side: tests/test_browser_first_view.py."""

from __future__ import annotations

import dataclasses
import json
import time

import pytest
from helpers import make_session, served, short_flat, wait_for

from app.live.commands import ApplyPush, Notify, SetLoop, SetPaused, SetSpeed, TogglePause
from app.live.view import STANDING, ViewTracker, is_stand, status_kind, status_line
from app.recordings.recorder import view_of
from app.viewer.panels.common import submit
from contactnet import registry
from contactnet.locomotion import Locomotion
from contactnet.sim.pybullet_world import SimConfig
from contactnet.terrain import flat

pytestmark = pytest.mark.app


def test_a_walking_robot_that_stands_a_horizon_stays_walking(robot):
    """The oracle stands on flat ground with a zero command: "standing" (its state); the same view told to walk is
    "walking" (a stand horizon is counted in "stood N", once, not a change of state)."""
    gait = registry.gait_by_name("walk")
    planner = registry.make_planner("oracle", gait, robot)
    with Locomotion(robot, flat(), gait, planner, SimConfig(), vel_cmd_xy=(0.0, 0.0)) as loco:
        tracker = ViewTracker(robot, loco.terrain, gait)
        while loco.t_s < 1.0:
            loco.advance(20)
            view = view_of(loco, tracker)
    assert is_stand(view.snapshot)
    assert status_kind(view) == "standing" and status_line(view).startswith(STANDING)
    told_to_walk = dataclasses.replace(view, snapshot=dataclasses.replace(view.snapshot, vel_cmd_xy=(0.05, 0.0)))
    assert status_kind(told_to_walk) == "walking" and status_line(told_to_walk).startswith("walking · ")
    assert f"stood {view.counts.stand_steps}" in status_line(told_to_walk)
    paused = dataclasses.replace(told_to_walk, status=dataclasses.replace(view.status, paused=True))
    assert status_kind(paused) == "paused"


def test_p_at_the_end_of_a_run_holds_the_card_and_never_starts_a_run(tmp_path):
    live = make_session(tmp_path, short_flat(), vx_m_s=0.2, wait_for_viewer=False, loop_delay_s=1.0)
    try:
        live.call(SetSpeed(2.0))
        live.wait_view(lambda v: v.run.runs == 1, timeout=30)
        live.call(TogglePause())  # P on the end-of-run card: stay
        view = live.view
        assert view.status.paused and view.status.done == "goal reached" and view.run.restart_in_s is not None
        time.sleep(2.0)  # twice the loop's delay: still the same finished run
        view = live.view
        assert view.status.done == "goal reached" and view.run.runs == 1 and status_kind(view) == "goal"
        live.call(TogglePause())  # P again: the count-down goes on, and the loop starts the next run
        live.wait_view(lambda v: v.status.done is None and v.snapshot.t_s > 0.0, timeout=10)
        live.wait_view(lambda v: v.run.runs == 2, timeout=30)
        live.call(SetLoop(False))
        live.call(TogglePause())  # loop off, at the end: P pauses (no new run either)
        assert live.view.status.done is not None and live.view.run.runs == 2
    finally:
        live.stop()


def test_a_refused_control_is_told_once_through_the_sessions_notices(tmp_path):
    live = make_session(tmp_path, flat())
    try:
        live.call(SetPaused(True))
        seq = max((n.seq for n in live.view.notices), default=0)
        submit(live, ApplyPush(5.0, 0.0, 0.5), title="Push not applied")  # what a panel's button does
        view = live.wait_view(lambda v: any(n.seq > seq for n in v.notices), timeout=10)
        notice = [n for n in view.notices if n.seq > seq][-1]
        assert notice.level == "error" and notice.text.startswith("Push not applied: cannot push now")
        with pytest.raises(ValueError, match="level"):
            live.call(Notify("x", "shout"))
    finally:
        live.stop()


def test_rest_routes_of_the_keys_and_the_state_stream(tmp_path_factory):
    from fastapi.testclient import TestClient
    from helpers import live_app

    app = live_app(tmp_path_factory, terrain="flat", planner="heuristic", vx_m_s=0.0, wait_for_viewer=False)
    try:
        client = TestClient(app.api, base_url="http://127.0.0.1")
        for _ in range(3):  # quick presses add up (the session applies them in order)
            assert client.post("/api/command/nudge", json={"dvx": 0.05}).status_code == 200
        state = client.post("/api/command/nudge", json={"dvy": -0.05}).json()
        assert state["vel_cmd"] == [0.15, -0.05] and state["status_kind"] in ("walking", "standing")
        assert client.post("/api/command/nudge", json={"dvx": 9}).status_code == 422
        assert client.post("/api/pause/toggle").json()["paused"] is True
        assert client.post("/api/pause/toggle").json()["paused"] is False
        with served(app) as port:  # a real server: the stream's events as a browser's EventSource reads them
            import http.client

            connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
            connection.request("GET", "/api/state/stream")
            response = connection.getresponse()
            assert response.status == 200 and response.getheader("Content-Type").startswith("text/event-stream")
            events = []

            def read_event() -> bool:
                line = response.readline().decode()
                if line.startswith("data: "):
                    events.append(json.loads(line[6:]))
                return len(events) >= 2

            wait_for(read_event, timeout=30, what="two states on the stream", poll_s=0.0)
            assert events[0]["session_id"] == app.session.session_id and events[1]["t_s"] >= events[0]["t_s"]
            assert {"status_text", "status_kind", "vel_cmd"} <= set(events[0])
            connection.close()
    finally:
        app.close()
