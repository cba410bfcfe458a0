"""The live session (app/live.py) without any web layer, the scene's fast robot posing, and the
recorder driven from a plain loop."""

from __future__ import annotations

import time

import numpy as np
import pytest

from app.live import (
    ApplyPush,
    LiveSession,
    Reset,
    SessionConfig,
    SetGait,
    SetPaused,
    SetPlanner,
    SetSpeed,
    SetTerrain,
    SetVelocity,
    ViewTracker,
    gait_chart,
)
from contactnet.terrain import flat, stepping_stones


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    live = LiveSession(
        SessionConfig(terrain=flat(), terrain_label="flat", planner="heuristic", vx=0.0),
        robot_cache_dir=tmp_path_factory.mktemp("cache"),
    ).start()
    yield live
    live.stop()


def test_runs_in_real_time(session):
    session.call(Reset())
    t0, wall0 = session.view.snapshot.t_s, time.monotonic()
    time.sleep(1.5)
    view = session.view
    assert view.status.running and view.status.planner_note is None
    assert (view.snapshot.t_s - t0) / (time.monotonic() - wall0) == pytest.approx(1.0, abs=0.2)


def test_velocity_command_moves_the_robot(session):
    session.call(Reset())
    x0 = session.view.snapshot.q[0]
    session.call(SetVelocity(0.1, 0.0))
    view = session.wait_view(lambda v: v.snapshot.t_s > 2.5, timeout=10)
    assert view.snapshot.vel_cmd_xy == (0.1, 0.0)
    assert view.snapshot.q[0] - x0 > 0.1
    assert len(view.com_path) > 10 and view.candidates is not None
    session.call(SetVelocity(0.0, 0.0))


def test_push_is_registered_and_shown(session):
    session.call(Reset())
    session.call(ApplyPush(5.0, 0.0, 0.5))
    view = session.view
    assert view.status.pushes == 1
    assert view.push_force_world.tolist() == [5.0, 0.0, 0.0]
    view = session.wait_view(lambda v: not np.any(v.push_force_world), timeout=5)
    assert view.status.pushes == 1


def test_pause_stops_the_clock_and_reset_restarts(session):
    session.call(SetPaused(True))
    t0 = session.view.snapshot.t_s
    time.sleep(0.3)
    assert session.view.snapshot.t_s == t0 and session.view.status.paused
    session.call(Reset())
    assert session.view.status.running and session.view.snapshot.t_s < 0.1


@pytest.mark.parametrize(
    "command",
    [
        SetVelocity(0.5, 0.0),
        SetVelocity(float("nan"), 0.0),
        SetVelocity(0.0, float("inf")),
        ApplyPush(21.0, 0.0, 1.0),
        ApplyPush(15.0, 15.0, 1.0),
        ApplyPush(1.0, 0.0, 0.0),
        ApplyPush(1.0, 0.0, 6.0),
        SetSpeed(0.0),
        SetGait("gallop"),
        SetPlanner("oracle"),
        SetTerrain("flat", "flat"),
    ],
)
def test_bad_commands_never_reach_the_simulation(session, command):
    future = session.submit(command)
    with pytest.raises(ValueError):
        future.result(0)


def test_unbuilt_planner_falls_back_to_heuristic(session):
    session.call(SetPlanner("contactnet"))
    status = session.view.status
    assert (status.planner, status.planner_active) == ("contactnet", "heuristic")
    assert "not built" in status.planner_note
    session.call(SetPlanner("heuristic"))
    assert session.view.status.planner_note is None


def test_gait_and_terrain_rebuild_the_world(session):
    version = session.view.terrain_version
    session.call(SetGait("trot"))
    assert session.view.gait.name == "trot" and session.view.status.running
    session.call(SetTerrain(stepping_stones(), "stones"))
    view = session.view
    assert view.terrain_version == version + 1 and view.status.terrain == "stones"
    assert view.status.paused  # an edited terrain waits for "run"
    session.call(SetGait("walk"))
    session.call(SetTerrain(flat(), "flat"))
    session.call(SetPaused(False))


def test_a_fall_pauses_the_session(session):
    session.call(SetTerrain(stepping_stones(), "stones"))  # the heuristic planner steps into a hole
    session.call(SetSpeed(2.0))
    session.call(SetVelocity(0.05, 0.0))
    session.call(SetPaused(False))
    view = session.wait_view(lambda v: v.status.done is not None, timeout=15)
    assert view.status.done.startswith("fell") and not view.status.running
    t = view.snapshot.t_s
    time.sleep(0.2)
    assert session.view.snapshot.t_s == t
    session.call(SetSpeed(1.0))
    session.call(SetVelocity(0.0, 0.0))
    session.call(SetTerrain(flat(), "flat"))
    session.call(SetPaused(False))


def test_gait_chart_is_a_step_shape(session):
    session.call(Reset())
    view = session.wait_view(lambda v: v.snapshot.t_s > 1.0, timeout=10)
    t, past, planned = gait_chart(view)
    assert t.shape[0] == past.shape[0] == planned.shape[0] and past.shape[1] == 4
    assert np.all(np.diff(t) >= 0)
    assert set(np.unique(past)) <= {0.0, 1.0} and set(np.unique(planned)) <= {0.0, 1.0}
    assert past.min() == 0.0 and planned.max() == 1.0  # a leg swung; the plan goes on


def test_candidates_of_the_swinging_leg(robot):
    from contactnet.cli import make_planner
    from contactnet.gait import WALK
    from contactnet.locomotion import Locomotion

    terrain = stepping_stones()
    with Locomotion(robot, terrain, WALK, make_planner("heuristic", WALK), vel_cmd_xy=(0.05, 0.0)) as loco:
        tracker = ViewTracker(robot, terrain, WALK)
        loco.advance(5)
        snap = loco.snapshot()
        parts = tracker.update(snap)
    cand = parts["candidates"]
    legs = snap.planned_steps[0].legs
    assert cand.xy_world.shape == (25 * len(legs), 2)
    assert set(cand.leg.tolist()) == set(legs)
    np.testing.assert_array_equal(cand.safe, terrain.is_safe(cand.xy_world))
    spacing = np.sort(np.unique(np.round(cand.xy_world[:, 0], 6)))
    assert np.allclose(np.diff(spacing), WALK.grid_spacing_m, atol=1e-3)


def test_fast_robot_pose_matches_yourdfpy(robot):
    """The scene poses the robot with its own joint rotations; check them against ViserUrdf's
    reference update (yourdfpy's scene graph), joint by joint."""
    from app.recordings import quiet_viser_server, stop_quietly
    from app.scene import _RobotPose

    server = quiet_viser_server()
    try:
        pose = _RobotPose(server, robot.files.urdf)
        assert pose._fast is not None
        rng = np.random.default_rng(0)
        q = robot.q_standing.copy()
        q[7:] += rng.uniform(-0.5, 0.5, 12)
        pose.set(q)
        handles = pose._fast[0]
        fast = np.array([h.wxyz for h in handles])
        pose.urdf.update_cfg(q[7:][pose.cfg_from_pin])
        slow = np.array([h.wxyz for h in handles])
        sign = np.sign(np.sum(fast * slow, axis=1))[:, None]
        np.testing.assert_allclose(fast, sign * slow, atol=1e-6)
        names = pose.urdf.get_actuated_joint_names()
        assert [names[i] for i in np.argsort(pose.cfg_from_pin)] == list(robot.model.names)[2:]
    finally:
        stop_quietly(server)


def test_recorder_from_a_plain_loop(robot, tmp_path):
    from app.recordings import SceneRecorder, view_of, viser_html
    from contactnet.gait import WALK
    from contactnet.locomotion import Locomotion
    from contactnet.planner import HeuristicPlanner
    from contactnet.sim import Push

    terrain = flat()
    with (
        Locomotion(robot, terrain, WALK, HeuristicPlanner(WALK), vel_cmd_xy=(0.1, 0.0)) as loco,
        SceneRecorder(rate_hz=10.0) as recorder,
    ):
        loco.push(Push(0.5, 0.5, (5.0, 0.0, 0.0)))
        tracker = ViewTracker(robot, terrain, WALK)
        recorded = 0
        while loco.t_s < 2.0:
            loco.advance(10)
            recorded += recorder.add(view_of(loco, tracker))
        data = recorder.finish()
    assert recorded == recorder.frames == pytest.approx(20, abs=2)
    assert recorder.duration_s == pytest.approx(1.9, abs=0.15)
    assert int.from_bytes(data[:8], "little") > len(data) > 10_000  # zstd-compressed .viser payload
    html = viser_html(data)
    assert "__VISER_EMBED_DATA__" in html and len(html) > len(data)


def test_camera_follows_until_the_user_moves_it(session):
    """The follow logic with a fake browser: our own (late, repeated) camera reports keep it on; an
    orbit or a pan by the user switches it off; re-centring switches it on again."""
    import asyncio
    from dataclasses import replace
    from types import SimpleNamespace

    from app.gui import _CameraFollow

    class Camera:
        def __init__(self, client):
            self.client, self.position, self.look_at = client, np.zeros(3), np.zeros(3)

    class Client:
        client_id = 7

        def __init__(self):
            self.camera = Camera(self)

    client = Client()
    initial = SimpleNamespace(position=np.array([9.0, 9.0, 9.0]), look_at=np.array([8.0, 8.0, 8.0]))
    server = SimpleNamespace(
        on_client_connect=lambda f: f,
        on_client_disconnect=lambda f: f,
        initial_camera=initial,
        get_clients=lambda: {7: client},
    )
    follow = _CameraFollow(server)

    def report(position, look_at):
        camera = Camera(client)
        camera.position, camera.look_at = np.asarray(position, float), np.asarray(look_at, float)
        asyncio.run(follow._on_camera(camera))

    session.call(Reset())
    view = session.view
    follow.step(view)
    follow.recenter(client)
    ours = (client.camera.position.copy(), client.camera.look_at.copy())
    report(initial.position, initial.look_at)  # the page's initial camera, reported late: ignored
    report(*ours)  # synced
    moved = view.snapshot.q.copy()
    moved[0] += 0.02
    follow.step(replace(view, snapshot=replace(view.snapshot, q=moved)))
    assert client.camera.position[0] == pytest.approx(ours[0][0] + 0.02)
    report(*ours)  # a report from before our last step
    report(client.camera.position, client.camera.look_at)
    assert follow.following(7)
    report(client.camera.position + [0.0, 0.0, 0.2], client.camera.look_at)  # the user orbits
    assert not follow.following(7)
    follow.recenter(client)
    assert follow.following(7)
