"""The 3D view's pieces without a browser: candidate disks and what a click on one says, the legend,
the per-browser camera modes (with a stand-in browser that reports its camera late), the plots'
histories, the compare ghosts and the notice toasts."""

from __future__ import annotations

import asyncio
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from app.live.step_events import LiveCounts
from app.live.view import CandidateView, Notice
from app.scene.camera import CameraControl, top_down_pose
from app.scene.live_scene import (
    BEST_COLOR,
    RANK_FADE,
    UNSAFE_COLOR,
    WORST_COLOR,
    default_camera,
    describe_candidate,
    disk_style,
    safe_positions,
    shown_rank_color,
)
from app.viewer.panels.legend import legend_html
from app.viewer.panels.notices import NoticeToasts, toast_text
from app.viewer.panels.plots import PlotHistory, steps_shape

pytestmark = pytest.mark.app


def test_safe_positions_share_a_place_for_equal_ranks():
    safe = np.array([True, True, False, True, True])
    rank = np.array([7, 3, 0, 3, 9])  # the two cells of one trot action share rank 3
    np.testing.assert_array_equal(safe_positions(safe, rank), [1, 0, -1, 0, 2])
    colors, scales = disk_style(safe, rank)
    np.testing.assert_array_equal(colors[1], colors[3])
    np.testing.assert_array_equal(colors[1], BEST_COLOR.astype(np.uint8))
    np.testing.assert_array_equal(colors[2], UNSAFE_COLOR)
    assert scales[2, 0] < scales[4, 0] < scales[1, 0]  # unsafe smallest, fading ones shrink
    far = disk_style(np.ones(RANK_FADE + 3, bool), np.arange(RANK_FADE + 3))[0]
    np.testing.assert_array_equal(far[RANK_FADE:], np.tile(WORST_COLOR.astype(np.uint8), (3, 1)))


def test_a_clicked_disk_says_leg_rank_and_safety():
    cand = CandidateView(
        xy_world=np.array([[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]]),
        safe=np.array([True, False, True]),
        leg=np.array([0, 1, 3]),
        rank=np.array([4, 0, 2]),
        chosen=(2,),
    )
    legs = ("FL", "FR", "HL", "HR")
    chosen = describe_candidate(cand, 2, legs)
    assert (chosen.leg, chosen.rank, chosen.safe_position, chosen.chosen) == ("HR", 2, 0, True)
    assert chosen.text() == "HR · rank 2 (best safe) · chosen"
    assert describe_candidate(cand, 0, legs).text() == "FL · rank 4 (2nd safe) · safe"
    assert describe_candidate(cand, 1, legs).text() == "FR · rank 0 · unsafe"
    unranked = replace(cand, rank=None)
    assert describe_candidate(unranked, 1, legs).text() == "FR · unsafe"
    scored = SimpleNamespace(**vars(cand), score=np.array([0.9, 0.1, 0.5]), score_name="network score")
    assert describe_candidate(scored, 0, legs).text().endswith("· network score 0.9")


def test_the_legend_shows_every_colour_and_the_rank_scale():
    text = legend_html()
    for label in ("chosen foothold", "unsafe candidate", "planned steps", "planned step, unsafe", "planned CoM",
                  "actual CoM path", "foot forces", "push", "push, as estimated", "goal line", "compared robot"):
        assert label in text, label
    assert "linear-gradient" in text and f"{RANK_FADE}+" in text
    shown = shown_rank_color(np.arange(RANK_FADE + 1))
    assert shown[0, 1] > shown[0, 0] + 100  # the best one is green on screen, the last grey
    assert abs(int(shown[-1, 0]) - int(shown[-1, 1])) < 3


def test_steps_shape_and_plot_history():
    t, y = steps_shape(np.array([0.0, 1.0, 2.0]), np.array([3.0, 1.0, 2.0]))
    np.testing.assert_array_equal(t, [0, 1, 1, 2, 2])
    np.testing.assert_array_equal(y, [3, 3, 1, 1, 2])
    history = PlotHistory()

    def view(t_s, steps, rank, vx, plans=0):
        step = SimpleNamespace(rank=rank)
        snap = SimpleNamespace(t_s=t_s, steps=steps, planned_steps=[step], vel_cmd_xy=(0.1, 0.0), com_vel=(vx, 0.0, 0.0))
        return SimpleNamespace(snapshot=snap, counts=LiveCounts(plans=plans))

    for k in range(40):
        history.observe(view(0.05 * k, k // 4, k // 4 % 3, 0.1 + 0.02 * (-1) ** k))
    assert [r for _, r in history.ranks] == [k % 3 for k in range(10)]
    t, cmd, measured, smooth = history.velocity_series()
    assert len(t) == 40 and np.all(cmd == 0.1)
    assert np.abs(smooth[-20:] - 0.1).max() < 0.003 < np.abs(measured - 0.1).max()  # the mean smooths the sway
    history.observe(view(0.0, 0, 0, 0.0))  # a reset starts over
    assert len(history.ranks) == 1 and len(history.velocity) == 1
    history.observe(view(0.3, 0, 5, 0.0, plans=1))  # a stand horizon: a new plan (with its rank), no new step
    assert [r for _, r in history.ranks] == [0, 5]


class FakeCamera:
    def __init__(self, client):
        self.client = client
        self.position, self.look_at = np.array([-0.75, -1.0, 0.85]), np.array([0.25, 0.0, 0.05])
        self.up_direction = np.array([0.0, 0.0, 1.0])
        self._state = SimpleNamespace(image_width=1400, image_height=900, fov=math.radians(50.0))

    def on_update(self, callback):  # noqa: ANN001
        pass


class FakeClient:
    """A browser as the camera code sees it: setters land at once (reports come when `report` is called)."""

    client_id = 7

    def __init__(self):
        self.camera = FakeCamera(self)
        self.gui = SimpleNamespace(add_folder=lambda *a, **k: _Nothing(), add_dropdown=lambda *a, **k: _Handle("follow"),
                                   add_button=lambda *a, **k: _Handle(None))
        self._websock_connection = SimpleNamespace(queue_message=lambda message: None)

    def atomic(self):
        return _Nothing()


class _Nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


class _Handle:
    def __init__(self, value):
        self.value = value

    def on_update(self, f):  # noqa: ANN001
        return f

    def on_click(self, f):  # noqa: ANN001
        return f


@pytest.fixture
def camera_setup():
    client = FakeClient()
    initial = SimpleNamespace(position=np.array([9.0, 9.0, 9.0]), look_at=np.array([8.0, 8.0, 8.0]))
    server = SimpleNamespace(on_client_connect=lambda f: f, on_client_disconnect=lambda f: f,
                             initial_camera=initial, get_clients=lambda: {7: client})
    control = CameraControl(server)
    terrain = SimpleNamespace(bounds=(-0.25, -0.25, 1.75, 0.25), start_xy=np.zeros(2), goal_x=1.4, surface_z=0.0,
                              ground_z=lambda xy: 0.0)
    q = np.zeros(19)
    q[2], q[6] = 0.24, 1.0
    view = SimpleNamespace(snapshot=SimpleNamespace(q=q), terrain=terrain, terrain_version=0)
    control.step(view)
    control._on_connect(client)
    return control, client, view


def moved(view, dx):
    q = view.snapshot.q.copy()
    q[0] += dx
    return SimpleNamespace(snapshot=SimpleNamespace(q=q), terrain=view.terrain, terrain_version=view.terrain_version)


def report(control, client, position, look_at):
    camera = FakeCamera(client)
    camera.position, camera.look_at = np.asarray(position, float), np.asarray(look_at, float)
    asyncio.run(control._on_camera(camera))


def test_follow_keeps_the_users_orbit_and_follows_on(camera_setup):
    control, client, view = camera_setup
    assert control.following(7)
    position, look_at = client.camera.position.copy(), client.camera.look_at.copy()
    default_position, default_look_at = default_camera(view)
    np.testing.assert_allclose(position - look_at, default_position - default_look_at)  # the default angle
    assert look_at[0] > default_look_at[0]  # shifted so the robot is drawn left of the panel
    report(control, client, position, look_at)  # our own pose, reported back: nothing changes
    for k in range(1, 30):  # the robot walks 30 cm: the camera comes along (smoothed)
        control.step(moved(view, 0.01 * k))
    assert client.camera.look_at[0] == pytest.approx(look_at[0] + 0.29, abs=0.03)
    report(control, client, position, look_at)  # a late report of an old pose of ours: still ours
    orbit = client.camera.look_at + np.array([0.5, -0.9, 1.2])  # the user orbits and zooms out
    report(control, client, orbit, client.camera.look_at)
    assert control.following(7)
    held = client.camera.position.copy()
    control.step(moved(view, 0.35))
    np.testing.assert_array_equal(client.camera.position, held)  # hands off while the user is moving it
    control._browsers[7].hold_until = 0.0  # the user let go
    control.step(moved(view, 0.40))
    np.testing.assert_allclose(client.camera.position - client.camera.look_at, [0.5, -0.9, 1.2])  # their angle
    assert client.camera.look_at[0] > look_at[0] + 0.25  # still on the robot


def test_free_top_down_and_recenter(camera_setup):
    control, client, view = camera_setup
    control.set_mode(client, "free")
    parked = client.camera.position.copy()
    control.step(moved(view, 0.2))
    np.testing.assert_array_equal(client.camera.position, parked)  # free: never moved by us
    control.set_mode(client, "top-down")
    position, look_at = client.camera.position, client.camera.look_at
    expected = top_down_pose(view, math.radians(50.0), 1400 / 900, panel_fraction=424 / 1400)
    np.testing.assert_allclose(position, expected[0])
    assert position[2] > 1.0 and look_at[0] > 0.75  # above the terrain, its middle left of the panel
    no_panel = top_down_pose(view, math.radians(50.0), 1400 / 900)
    assert no_panel[1][0] == pytest.approx(0.75) and no_panel[0][2] < position[2]
    # Everything from the start pad to the goal line in the part of the view the panel leaves free (1400 px: its
    # right 424 px; a phone: the upper half), with room for the robot standing above its footprint.
    terrain = view.terrain
    for aspect, right, bottom in ((1400 / 900, 424 / 1400, 0.0), (390 / 700, 0.0, 0.5)):
        position, look_at = top_down_pose(view, math.radians(50.0), aspect, right, bottom)
        half_h = position[2] * math.tan(math.radians(25.0))  # half the view's height on the ground
        half_w = half_h * aspect
        left, top = look_at[0] - half_w, look_at[1] + half_h
        free_right, free_bottom = left + 2 * half_w * (1 - right), top - 2 * half_h * (1 - bottom)
        start_x, start_y = terrain.start_xy
        assert left < start_x - 0.45 and free_right > terrain.goal_x  # the start and the goal line, with room
        assert top > start_y + 0.3 and free_bottom < start_y - 0.3
    with pytest.raises(ValueError):
        control.set_mode(client, "sideways")
    control.set_mode(client, "follow")
    client.camera.position = np.array([5.0, 5.0, 5.0])  # wherever the browser is, re-center brings it back
    control.recenter(client)
    assert np.linalg.norm(client.camera.position - default_camera(control.view)[0]) < 0.3


def test_notices_are_toasted_once_to_every_browser():
    sent = []

    class Client:
        def __init__(self, name):
            self.name = name

        def add_notification(self, title, body, **kwargs):  # noqa: ANN001, ANN003
            sent.append((self.name, title, body))

    clients = {1: Client("a"), 2: Client("b")}
    toasts = NoticeToasts(SimpleNamespace(get_clients=lambda: clients))
    toasts.refresh(SimpleNamespace(notices=(Notice(1, "info", "old news"),)))  # there before: not shown
    toasts.refresh(SimpleNamespace(notices=(Notice(1, "info", "old news"),
                                            Notice(2, "info", "Gait set to trot: the robot restarted"))))
    toasts.refresh(SimpleNamespace(notices=(Notice(2, "info", "Gait set to trot: the robot restarted"),)))
    assert sent == [("a", "Gait set to trot", "the robot restarted"), ("b", "Gait set to trot", "the robot restarted")]
    assert toast_text("no colon here") == ("no colon here", "")
