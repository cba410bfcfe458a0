"""The live session (app/live/session.py) without any web layer, the serve settings, the scene's fast robot
posing, and the recorder driven from a plain loop."""

from __future__ import annotations

import time
from functools import partial

import numpy as np
import pytest
from helpers import wait_for

from app.live.commands import (
    ApplyPush,
    NudgeVelocity,
    Reset,
    SetGait,
    SetPaused,
    SetPlanner,
    SetSpeed,
    SetTerrain,
    SetVelocity,
)
from app.live.planners import default_planner_factory
from app.live.session import LiveSession
from app.live.settings import ServeSettings
from app.live.view import ViewTracker, gait_chart
from contactnet import registry
from contactnet.terrain import flat, stepping_stones

pytestmark = pytest.mark.app  # the web tool: `pytest -m "not app"` skips these


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    live = LiveSession(
        ServeSettings(planner="heuristic", vx_m_s=0.0, wait_for_viewer=False),
        flat(),
        "flat",
        planner_factory=partial(default_planner_factory, model_dir=tmp_path_factory.mktemp("no_models")),
        robot_cache_dir=tmp_path_factory.mktemp("cache"),
    ).start()
    yield live
    live.stop()


def test_runs_in_real_time(session):
    """Simulated time keeps pace with the wall clock, never ahead of it. The session can only fall behind when
    another process takes the core, so on a busy machine a window may be slow: within 30 s there is one of 1.5 s in
    which it kept real time (within 20 %), and no window runs ahead."""
    session.call(Reset())
    rates = []

    def kept_up() -> bool:
        t0, wall0 = session.view.snapshot.t_s, time.monotonic()
        time.sleep(1.5)
        rates.append((session.view.snapshot.t_s - t0) / (time.monotonic() - wall0))
        return rates[-1] >= 0.8

    wait_for(kept_up, timeout=30.0, what="a second and a half in which the session kept real time")
    view = session.view
    assert view.status.running and view.status.planner_note is None
    assert all(rate <= 1.2 for rate in rates), rates


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
        NudgeVelocity(float("nan"), 0.0),
        NudgeVelocity(0.0, 0.7),
        ApplyPush(21.0, 0.0, 1.0),
        ApplyPush(15.0, 15.0, 1.0),
        ApplyPush(1.0, 0.0, 0.0),
        ApplyPush(1.0, 0.0, 6.0),
        SetSpeed(0.0),
        SetGait("gallop"),
        SetPlanner("teleport"),
        SetTerrain("flat", "flat"),
    ],
)
def test_bad_commands_never_reach_the_simulation(session, command):
    future = session.submit(command)
    with pytest.raises(ValueError):
        future.result(0)


def test_missing_model_falls_back_to_heuristic(session):
    for planner in ("contactnet", "fixed"):
        session.call(SetPlanner(planner))
        status = session.view.status
        assert (status.planner, status.planner_active) == (planner, "heuristic")
        assert "no trained walk model yet (walk.pt not found)" in status.planner_note
    session.call(SetPlanner("heuristic"))
    assert session.view.status.planner_note is None


def test_broken_model_falls_back_with_the_reason(tmp_path):
    from contactnet.motion.gait import WALK

    (tmp_path / "walk.pt").write_bytes(b"not a model")
    planner, active, note = default_planner_factory("contactnet", WALK, model_dir=tmp_path)
    assert active == "heuristic" and type(planner).__name__ == "HeuristicPlanner"
    assert "walk.pt" in note and "not a complete torch file" in note


def test_shipped_model_is_the_default(monkeypatch, random_models):
    """Without a model folder the factory loads contactnet/models/{gait}.pt."""
    from contactnet.motion.gait import WALK

    monkeypatch.setattr(registry, "MODELS_DIR", random_models)
    planner, active, note = default_planner_factory("contactnet", WALK)
    assert (type(planner).__name__, active, note) == ("ContactNetPlanner", "contactnet", None)


def test_contactnet_session_shows_the_ranking(random_models, tmp_path):
    """A ContactNet planner session (random weights) yields ranked candidates with the chosen cell:
    every candidate ranked before the chosen one is unsafe (the planner takes the first safe one)."""
    live = LiveSession(
        ServeSettings(planner="contactnet", wait_for_viewer=False),
        stepping_stones(),
        "stepping_stones",
        planner_factory=partial(default_planner_factory, model_dir=random_models),
        robot_cache_dir=tmp_path,
    ).start()
    try:
        assert live.view.status.planner_active == "contactnet" and live.view.status.planner_note is None
        view = live.wait_view(lambda v: v.snapshot.steps >= 3 and v.candidates is not None, timeout=60)
        cand = view.candidates
        assert cand.rank is not None and len(cand.chosen) == 1
        n = len(cand.xy_world)
        assert n == 100 and cand.safe.shape == cand.rank.shape == cand.leg.shape == (n,)  # 4 legs x 25 cells
        assert sorted(np.bincount(cand.leg).tolist()) == [25] * 4
        (chosen,) = cand.chosen
        assert cand.safe[chosen]
        assert cand.leg[chosen] in view.snapshot.planned_steps[0].legs
        assert not np.any(cand.safe & (cand.rank < cand.rank[chosen]))
        assert cand.rank[chosen] == view.snapshot.planned_steps[0].rank
        np.testing.assert_allclose(
            cand.xy_world[chosen], view.snapshot.planned_steps[0].footholds_xy_world[0], atol=1e-9
        )
        assert set(np.unique(cand.rank).tolist()) == set(range(100))  # walk: one action per cell
    finally:
        live.stop()
    # drawn: one disk per candidate at its place, coloured and sized as disk_style says
    from app.recordings.recorder import quiet_viser_server, stop_quietly
    from app.scene.live_scene import HIDDEN_POS, LiveScene, disk_style
    from contactnet.robots import load_robot

    server = quiet_viser_server()
    try:
        scene = LiveScene(server, load_robot("solo12"))
        scene.update(view)
        positions, colors = scene.disks.batched_positions, scene.disks.batched_colors
        np.testing.assert_allclose(positions[:n, :2], cand.xy_world, atol=1e-6)
        assert np.all(positions[n:] == HIDDEN_POS)
        expected_colors, expected_scales = disk_style(cand.safe, cand.rank, cand.chosen)
        np.testing.assert_array_equal(colors[:n], expected_colors)
        np.testing.assert_allclose(scene.disks.batched_scales[:n], expected_scales)
    finally:
        stop_quietly(server)


def test_disk_colours_follow_the_ranking():
    from app.scene.live_scene import BEST_COLOR, CHOSEN_COLOR, UNSAFE_COLOR, WORST_COLOR, disk_style

    rank = np.array([5, 0, 1, 9, 2, 40, 3])
    safe = np.array([True, False, True, True, True, True, False])
    colors, scales = disk_style(safe, rank, chosen=(2,))
    np.testing.assert_array_equal(colors[~safe], [UNSAFE_COLOR, UNSAFE_COLOR])
    np.testing.assert_array_equal(colors[2], CHOSEN_COLOR)  # rank 1, the first safe one
    assert scales[2, 0] > 1.5 and scales[2, 2] > 2 and np.all(scales[~safe, :2] < 1)
    # the other safe ones, best first (ranks 2, 5, 9, 40): from the best colour toward grey
    order = [4, 0, 3, 5]
    distance_to_best = np.linalg.norm(colors[order].astype(float) - BEST_COLOR, axis=1)
    assert np.all(np.diff(distance_to_best) > 0) and np.all(np.diff(scales[order, 0]) < 0)
    colors, _ = disk_style(safe, rank)
    np.testing.assert_array_equal(colors[2], BEST_COLOR.astype(np.uint8))  # best safe: the full colour
    colors, _ = disk_style(np.ones(40, dtype=bool), np.arange(40)[::-1])
    assert np.linalg.norm(colors[0].astype(float) - WORST_COLOR) < 10  # 40th safe one: grey
    colors, scales = disk_style(safe)  # a planner without a ranking: safe or not
    assert len({tuple(c) for c in colors[safe]}) == 1 and np.all(colors[~safe] == UNSAFE_COLOR)


def test_gait_and_terrain_rebuild_the_world(session):
    version = session.view.terrain_version
    session.call(SetGait("trot"))
    assert session.view.gait.name == "trot" and session.view.status.running
    session.call(SetTerrain(stepping_stones(), "stones"))
    view = session.view
    assert view.terrain_version == version + 1 and view.status.terrain == "stones"
    assert view.status.running and view.snapshot.t_s < 0.1  # a loaded terrain: the robot starts from its start
    assert "stones loaded" in view.notices[-1].text and "Gait set to trot" in view.notices[-2].text
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
    from contactnet.locomotion import Locomotion
    from contactnet.motion.gait import WALK

    terrain = stepping_stones()
    planner = registry.make_planner("heuristic", WALK, robot)
    with Locomotion(robot, terrain, WALK, planner, vel_cmd_xy=(0.05, 0.0)) as loco:
        tracker = ViewTracker(robot, terrain, WALK)
        loco.advance(5)
        snap = loco.snapshot()
        parts = tracker.update(snap)
    cand = parts["candidates"]
    legs = snap.planned_steps[0].legs
    assert cand.xy_world.shape == (25 * len(legs), 2)
    assert set(cand.leg.tolist()) == set(legs)
    np.testing.assert_array_equal(cand.safe, terrain.is_safe(cand.xy_world))
    spacing = np.sort(np.unique(np.round(cand.xy_world[:, 0], 4)))  # to 0.1 mm: a cell's x may end in ...5e-7
    assert np.allclose(np.diff(spacing), WALK.grid_spacing_m, atol=1e-3)


@pytest.mark.parametrize("robot_name, collada", [("solo12", True), ("go2", True), ("go2", False)])
def test_fast_robot_pose_matches_yourdfpy(robot_name, collada, tmp_path, monkeypatch):
    """The scene poses the robot with its own joint rotations; check them against ViserUrdf's
    reference update (yourdfpy's scene graph), joint by joint. Go2's COLLADA visuals load and are
    decimated to the triangle budget like Solo12's STL meshes; where trimesh cannot read COLLADA
    (no pycollada), its collision meshes are shown instead."""
    import trimesh

    from app.recordings.recorder import quiet_viser_server, stop_quietly
    from app.scene.robot_display import ROBOT_MESH_CELL_M, ROBOT_TRIANGLE_BUDGET, RobotDisplay
    from contactnet.robots import load_robot

    if not collada:
        formats = [f for f in trimesh.available_formats() if f != "dae"]
        monkeypatch.setattr(trimesh, "available_formats", lambda: formats)
    robot = load_robot(robot_name, tmp_path)
    server = quiet_viser_server()
    try:
        pose = RobotDisplay(server, robot)
        assert pose.display.visual == collada and pose.display.triangles <= ROBOT_TRIANGLE_BUDGET
        if robot_name == "solo12":
            assert pose.display.cell_m == ROBOT_MESH_CELL_M  # as before: 4 mm cells
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
    from app.recordings.recorder import SceneRecorder, view_of, viser_html
    from contactnet.locomotion import Locomotion
    from contactnet.motion.gait import WALK
    from contactnet.planning.heuristic import HeuristicPlanner
    from contactnet.sim.pybullet_world import Push

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


def test_arrow_segments_have_a_shaft_and_a_symmetric_head():
    from app.scene.live_scene import arrow_segments

    tails = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    tips = np.array([[0.0, 0.0, 1.0], [1.0, 2.0, 0.0], [0.0, 2.0, 0.0]])  # vertical, horizontal, zero
    seg = arrow_segments(tails, tips).reshape(3, 3, 2, 3).astype(float)
    for tail, tip, arrow in zip(tails, tips, seg, strict=True):
        np.testing.assert_allclose(arrow[0], [tail, tip], atol=1e-6)
        np.testing.assert_allclose(arrow[1:, 0], [tip, tip], atol=1e-6)  # both strokes start at the tip
        mid = arrow[1:, 1].mean(axis=0)  # their ends are symmetric about the shaft, a quarter back
        np.testing.assert_allclose(mid, tip - 0.25 * (tip - tail), atol=1e-6)
        length = np.linalg.norm(tip - tail)
        np.testing.assert_allclose(np.linalg.norm(arrow[1, 1] - arrow[2, 1]), 0.25 * length, atol=1e-6)


def test_the_session_owns_the_terrain_and_its_history(tmp_path):
    """Loads, edits, undos and renames are session commands: every published view's terrain, terrain
    dict, undo state and label belong together (the terrain service keeps no copy)."""
    from app.live import editor
    from app.live.commands import EditTerrain, RenameTerrain, UndoTerrainEdit
    from contactnet.terrain import Terrain

    published = []

    class RecordedSession(LiveSession):
        def _publish(self) -> None:
            super()._publish()
            published.append(self._view)

    live = RecordedSession(
        ServeSettings(planner="heuristic", vx_m_s=0.0, wait_for_viewer=False), flat(), "flat",
        planner_factory=partial(default_planner_factory, model_dir=tmp_path), robot_cache_dir=tmp_path,
    ).start()
    try:
        assert live.view.terrain_dict == flat().to_dict() and not live.view.terrain_can_undo
        live.call(SetTerrain(stepping_stones(), "stones"))
        version = live.view.terrain_version
        assert live.call(EditTerrain(editor.punch_hole, ((0.12, 0.12),))) is True
        view = live.view
        assert (view.status.terrain, view.terrain_can_undo, view.terrain_version) == (
            "stones (edited)", True, version + 1)
        assert Terrain.from_dict(view.terrain_dict).steppable.area == pytest.approx(
            stepping_stones().steppable.area - 0.0025)
        assert live.call(EditTerrain(editor.fill_hole, ((0.0, 0.0),))) is False  # solid ground: no change
        assert live.view.terrain_version == version + 1
        live.call(UndoTerrainEdit())
        assert live.view.terrain_dict == stepping_stones().to_dict() and not live.view.terrain_can_undo
        with pytest.raises(editor.EditError, match="nothing to undo"):
            live.call(UndoTerrainEdit())
        live.call(RenameTerrain("my_stones"))
        assert live.view.status.terrain == "my_stones" and live.view.terrain_version == version + 2
        live.call(EditTerrain(editor.punch_hole, ((0.12, 0.12),)))
        assert live.view.status.terrain == "my_stones (edited)"
    finally:
        live.stop()
    for view in published:
        assert view.terrain.to_dict() == Terrain.from_dict(view.terrain_dict).to_dict()


def test_every_command_has_its_handler():
    """Each command of `app.live.commands.Command` is handled by a method of its own (no fallback to the error)."""
    import typing

    from app.live import commands
    from app.live.session_commands import SessionCommands

    assert issubclass(LiveSession, SessionCommands)
    handled = SessionCommands.__dict__["_handle"].dispatcher.registry
    kinds = typing.get_args(commands.Command)
    assert len(kinds) == 22 and all(kind in handled for kind in kinds)
    assert set(handled) - set(kinds) == {object}


def test_a_session_in_mujoco_walks(tmp_path_factory):
    """``serve --sim mujoco``: the live session runs its robot in MuJoCo."""
    live = LiveSession(
        ServeSettings(planner="heuristic", vx_m_s=0.1, wait_for_viewer=False, sim="mujoco"),
        flat(),
        "flat",
        planner_factory=partial(default_planner_factory, model_dir=tmp_path_factory.mktemp("no_models")),
        robot_cache_dir=tmp_path_factory.mktemp("cache"),
    ).start()
    try:
        view = live.wait_view(lambda v: v.snapshot.t_s > 2.5, timeout=20)
        assert view.snapshot.q[0] > 0.1 and view.status.done is None
        assert live._loco.sim.engine == "mujoco"
    finally:
        live.stop()
    with pytest.raises(ValueError, match="sim must be one of pybullet, mujoco"):
        ServeSettings(sim="bullet")
