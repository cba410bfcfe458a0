"""Every control of the viser panel and the terrain editor, driven the way the browser drives them:
a websocket client speaking viser's protocol sends the messages the viser page sends (GUI value
updates, button clicks, hotkey commands, clicks in the 3D view, gizmo drags, file uploads) to the
real viser server of a real app; the tests check what reaches the live session. (The browser
test, tests/test_browser_e2e.py, checks a few of these through chromium itself.)"""

from __future__ import annotations

import contextlib
import math
import shutil
import threading
import time
import uuid

import msgspec
import numpy as np
import pytest
import viser
from helpers import camera_offset, save_random_models, wait_for
from viser import _messages as messages
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from app.api.server import ContactnetApp
from app.live.commands import ApplyPush, SetObserver, SetPaused, SetRetarget, SetSim
from app.live.settings import ServeSettings
from app.recordings.recorder import free_port
from contactnet.terrain import Terrain, terrains_dir

pytestmark = pytest.mark.app  # the web tool: `pytest -m "not app"` skips these


class ViserProtocolClient:
    """A stand-in for the viser page: connects like it and sends what its components send."""

    def __init__(self, port: int):
        self.ws = connect(
            f"ws://127.0.0.1:{port}", subprotocols=[f"viser-v{viser.__version__}"], max_size=None
        )
        self.received = 0
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        # viser counts a page as connected once it reports its camera
        self.send(messages.ViewerCameraMessage((1.0, 0.0, 0.0, 0.0), (-0.75, -1.0, 0.85), 1.0, 0.01, 100.0,
                                               720, 1280, (0.25, 0.0, 0.05), (0.0, 0.0, 1.0)))

    def _read(self) -> None:  # drain what the server sends (scene, GUI, notifications)
        try:
            for _ in self.ws:
                self.received += 1
        except ConnectionClosed:
            pass

    def send(self, message: messages.Message) -> None:
        self.ws.send(msgspec.msgpack.encode(message.as_serializable_dict()))

    def set(self, handle, value) -> None:  # noqa: ANN001 - a slider, number, dropdown, checkbox, text
        self.send(messages.GuiUpdateMessage(handle._impl.uuid, {"value": value}))

    def click(self, button, option: str | None = None) -> None:  # noqa: ANN001 - button (group)
        self.send(messages.GuiUpdateMessage(button._impl.uuid, {"value": True if option is None else option}))

    def key(self, command) -> None:  # noqa: ANN001 - a hotkey command
        self.send(messages.CommandTriggerMessage(command._impl.uuid))

    def click_node(self, name: str, instance: int | None = None) -> None:
        """A click on a (clickable) scene node, e.g. one disk of the batched candidate disks."""
        self.send(messages.SceneNodeClickMessage(name, instance, (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.5, 0.5), None))

    def click_scene(self, xy: tuple[float, float], z: float = 0.0) -> None:
        """A click in the 3D view on the point (x, y, z), seen from above and behind."""
        origin = (xy[0] - 0.5, xy[1] - 0.3, z + 1.0)
        direction = np.array([0.5, 0.3, -1.0]) / np.linalg.norm([0.5, 0.3, -1.0])
        self.send(messages.ScenePointerMessage("click", origin, tuple(direction), ((0.5, 0.5),), None))

    def drag_gizmo(self, name: str, position: tuple[float, float, float], yaw: float) -> None:
        wxyz = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        self.send(messages.TransformControlsDragStartMessage(name))
        self.send(messages.TransformControlsUpdateMessage(name, wxyz, position))
        self.send(messages.TransformControlsDragEndMessage(name))

    def upload(self, button, filename: str, content: bytes) -> None:  # noqa: ANN001
        transfer = str(uuid.uuid4())
        self.send(messages.FileTransferStartUpload(button._impl.uuid, transfer, filename, "application/json",
                                                   1, len(content)))
        self.send(messages.FileTransferPart(button._impl.uuid, transfer, 0, content))

    def close(self) -> None:
        self.ws.close()


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    terrains = tmp_path_factory.mktemp("terrains")
    for path in terrains_dir().glob("*.json"):
        shutil.copy(path, terrains / path.name)
    models = tmp_path_factory.mktemp("models")
    save_random_models(models)
    instance = ContactnetApp(
        ServeSettings(terrain="flat", planner="heuristic", vx_m_s=0.0, viser_port=free_port(), terrains_dir=terrains,
                  recordings_dir=tmp_path_factory.mktemp("recordings"), models_dir=models)
    )
    yield instance
    instance.close()


@pytest.fixture(scope="module")
def browser(app):
    client = ViserProtocolClient(app.viser_port)
    wait_for(lambda: app.viewer.server.get_clients(), what="the client to connect")
    yield client
    client.close()


def state(app):
    return app.state()


def test_velocity_sliders_stop_and_hotkeys(app, browser):
    panel = app.viewer.panel.drive
    browser.set(panel.vx, 0.12)
    browser.set(panel.vy, -0.04)
    wait_for(lambda: state(app).vel_cmd == (0.12, -0.04), what="the sliders' velocity")
    browser.click(panel.stop_button)
    wait_for(lambda: state(app).vel_cmd == (0.0, 0.0), what="Stop")
    keys = panel.shortcuts
    for key, expected in (
        ("I", (0.05, 0.0)), ("I", (0.1, 0.0)), ("J", (0.1, 0.05)), ("L", (0.1, 0.0)), ("L", (0.1, -0.05)),
        ("K", (0.05, -0.05)), ("X", (0.0, 0.0)),
    ):
        browser.key(keys[key])
        wait_for(lambda expected=expected: state(app).vel_cmd == expected, what=f"key {key} -> {expected}")
    for _ in range(8):  # the limit holds
        browser.key(keys["I"])
    wait_for(lambda: state(app).vel_cmd == (0.3, 0.0), what="vx capped at 0.3")
    browser.key(keys["X"])
    wait_for(lambda: state(app).vel_cmd == (0.0, 0.0), what="X")


def test_pause_run_reset_and_speed(app, browser):
    panel = app.viewer.panel.drive
    browser.key(panel.shortcuts["P"])
    wait_for(lambda: state(app).paused, what="P pauses")
    browser.key(panel.shortcuts["P"])
    wait_for(lambda: not state(app).paused, what="P runs")
    browser.click(panel.run_button)  # labelled "Pause" while running
    wait_for(lambda: state(app).paused, what="the Pause button")
    wait_for(lambda: panel.run_button.label == "Run", what="the button to say Run")
    browser.click(panel.run_button)
    wait_for(lambda: not state(app).paused, what="the Run button")
    wait_for(lambda: state(app).t_s > 0.5, what="0.5 s of simulation")
    browser.click(panel.reset_button)
    wait_for(lambda: state(app).t_s < 0.3, what="Reset")
    browser.set(panel.speed, 0.5)
    wait_for(lambda: state(app).speed == 0.5, what="speed 0.5")
    # Half speed: never faster than asked, and as asked over a second in which the session kept up: on schedule at
    # both ends and no debt dropped (on a busy machine it falls up to Pacing.max_lag_s behind before it drops the
    # debt, app/live/session.py: a wall-time rate over a second it fell behind in says nothing).
    samples = []
    stats = app.session.stats

    def kept_up() -> bool:
        lags, t0, wall0, behind0 = stats.lag_resets, state(app).t_s, time.monotonic(), stats.behind_s
        time.sleep(1.0)
        on_schedule = stats.lag_resets == lags and max(behind0, stats.behind_s) < 0.05
        samples.append(((state(app).t_s - t0) / (time.monotonic() - wall0), on_schedule))
        return on_schedule

    with contextlib.suppress(AssertionError):  # a machine too busy for even half speed: the upper bound only
        wait_for(kept_up, timeout=20.0, what="a second in which the session kept up")
    assert all(rate <= 0.5 + 0.15 for rate, _ in samples), samples
    assert all(rate == pytest.approx(0.5, abs=0.15) for rate, ok in samples if ok), samples
    browser.set(panel.speed, 1.0)
    wait_for(lambda: state(app).speed == 1.0, what="speed 1")


def test_push_buttons_use_the_force_and_duration_sliders(app, browser):
    panel = app.viewer.panel.push
    # a push before the robot walks is refused ("about to start"): on a busy machine the start takes longer
    wait_for(lambda: state(app).running and state(app).t_s > 0.5, timeout=60, what="the robot walking")
    browser.set(panel.push_force, 3.0)
    browser.set(panel.push_duration, 5.0)
    wait_for(lambda: (panel.push_force.value, panel.push_duration.value) == (3.0, 5.0), what="sliders")
    pushes = state(app).pushes
    for direction, total in (("+x", (3, 0)), ("-y", (3, -3)), ("-x", (0, -3)), ("+y", (0, 0))):
        browser.click(panel.push_buttons, direction)  # 5 s pushes: each adds to those still active
        wait_for(lambda total=total: np.allclose(state(app).push_force[:2], total), what=f"push {direction}")
    assert state(app).pushes == pushes + 4
    browser.set(panel.push_angle, 135.0)  # along a direction: the force for the duration, then an impulse
    wait_for(lambda: panel.push_angle.value == 135.0, what="the direction slider")
    browser.click(panel.along_buttons, "Force")
    wait_for(lambda: np.allclose(state(app).push_force[:2], (-2.1213, 2.1213), atol=1e-3), what="a push at 135 deg")
    browser.click(panel.along_buttons, "Impulse")
    wait_for(lambda: state(app).pushes == pushes + 6, what="an impulse")
    browser.click(app.viewer.panel.drive.reset_button)
    wait_for(lambda: state(app).pushes == 0, what="reset")


def test_gait_planner_and_noise(app, browser):
    panel = app.viewer.panel.gait_planner
    browser.set(panel.gait, "trot")
    wait_for(lambda: state(app).gait == "trot", what="trot")
    browser.set(panel.planner, "contactnet")
    wait_for(lambda: state(app).planner_active == "contactnet", what="the ContactNet planner")
    browser.set(panel.noise, True)
    wait_for(lambda: state(app).noise, what="noise on")
    s = state(app)
    assert (s.gait, s.planner, s.planner_note, s.noise) == ("trot", "contactnet", None, True)
    wait_for(lambda: app.session.view.candidates is not None and app.session.view.candidates.rank is not None,
             what="ranked candidates")
    assert len(app.session.view.candidates.chosen) == 2  # trot: two legs per step
    browser.set(panel.noise, False)
    browser.set(panel.planner, "heuristic")
    browser.set(panel.gait, "walk")
    wait_for(lambda: (state(app).gait, state(app).planner, state(app).noise) == ("walk", "heuristic", False),
             what="back to walk / heuristic / no noise")


def test_the_physics_dropdown(app, browser):
    """The "Physics" dropdown restarts the robot in MuJoCo and back; a change from elsewhere (REST) shows in it."""
    panel = app.viewer.panel.gait_planner
    assert panel.sim.value == "pybullet" and "mujoco" in panel.sim.options
    browser.set(panel.sim, "mujoco")
    wait_for(lambda: state(app).sim == "mujoco", what="the robot in MuJoCo")
    assert app.session._loco.sim.engine == "mujoco"
    app.session.call(SetSim("pybullet"))
    wait_for(lambda: panel.sim.value == "pybullet", what="the dropdown to follow")


def test_the_retarget_switch(app, browser):
    """The "Retarget swings" checkbox turns swing retargeting on and off without a restart; REST shows in it."""
    panel = app.viewer.panel.gait_planner
    assert panel.retarget.value is False and not state(app).retarget  # off by default, like the library
    browser.set(panel.retarget, True)
    wait_for(lambda: state(app).retarget, what="retargeting on")
    assert app.session._loco.config.retarget is not None
    browser.set(panel.retarget, False)
    wait_for(lambda: not state(app).retarget, what="retargeting off")
    assert app.session._loco.config.retarget is None
    app.session.call(SetRetarget(True))  # from elsewhere (REST): the checkbox follows
    wait_for(lambda: panel.retarget.value is True, what="the checkbox to follow")
    app.session.call(SetRetarget(False))
    wait_for(lambda: panel.retarget.value is False, what="the checkbox to follow back")


def test_the_resist_pushes_switch(app, browser):
    """The "Resist pushes" checkbox turns the disturbance observer on and off without a restart; REST shows it."""
    panel = app.viewer.panel.gait_planner
    assert panel.observer.value is True and state(app).observer  # on by default, like the library
    browser.set(panel.observer, False)
    wait_for(lambda: not state(app).observer, what="the observer off")
    assert app.session._loco.observer is None
    browser.set(panel.observer, True)
    wait_for(lambda: state(app).observer, what="the observer on")
    assert app.session._loco.observer is not None
    was_paused = state(app).paused
    app.session.call(SetPaused(False))
    arrow = app.viewer.scene.estimated_push
    assert float(np.max(arrow.points[..., 2])) < -50.0  # hidden while nothing pushes
    app.session.call(ApplyPush(0.0, 5.0, 1.0))
    wait_for(lambda: float(np.max(arrow.points[..., 2])) > -50.0, what="the estimated push drawn")
    tip = arrow.points[0, 1]  # the shaft's end: over the base, the estimate pointing +y into it
    assert arrow.points[0, 1, 1] > arrow.points[0, 0, 1] and abs(tip[1] - app.session.view.snapshot.q[1]) < 0.2
    app.session.call(SetPaused(was_paused))
    browser.set(panel.observer, False)
    wait_for(lambda: not state(app).observer, what="the observer off")
    assert app.session._loco.observer is None
    app.session.call(SetObserver(True))  # from elsewhere (REST): the checkbox follows
    wait_for(lambda: panel.observer.value is True, what="the checkbox to follow")
    app.session.call(SetObserver(False))
    wait_for(lambda: panel.observer.value is False, what="the checkbox to follow back")
    app.session.call(SetObserver(True))  # the default again, for the tests after this one
    wait_for(lambda: panel.observer.value is True, what="the checkbox to follow")


def test_terrain_picker_files_and_random_field(app, browser):
    panel = app.viewer.panel.terrain
    assert panel.terrain_pick.value == "flat"  # the picker starts on the session's terrain
    browser.set(panel.terrain_pick, "random")
    wait_for(lambda: panel.removed.visible and panel.seed.visible, what="N and seed to show")
    browser.set(panel.removed, 50)
    browser.set(panel.seed, 7)
    wait_for(lambda: (panel.removed.value, panel.seed.value) == (50, 7), what="N and seed")
    browser.click(panel.load_button)
    wait_for(lambda: state(app).terrain == "random (removed 50, seed 7)", what="the random field")
    # The picker follows the session's terrain on the viewer's next refresh: let that happen before the next pick
    # (else the refresh, coming after it, puts the picker back on "random").
    wait_for(lambda: panel._label == "random (removed 50, seed 7)", what="the picker to see the load")
    cells = [r for r in app.session.view.terrain.to_dict()["regions"] if r["shape"] == "grid"]
    assert len(cells) == 1 and len(cells[0]["removed"]) == 50
    browser.set(panel.terrain_pick, "stepping_stones")
    wait_for(lambda: not panel.removed.visible, what="N and seed to hide")
    browser.click(panel.load_button)
    wait_for(lambda: state(app).terrain == "stepping_stones", what="stepping stones")
    notice = app.session.view.notices[-1]  # the restart is said, in a toast to every browser
    assert notice.text.startswith("Terrain stepping_stones loaded")
    wait_for(lambda: app.viewer.panel.toasts.shown_seq == notice.seq, what="the toast")
    wait_for(lambda: panel._label == "stepping_stones", what="the picker to see the load")
    assert panel.terrain_pick.value == "stepping_stones"
    browser.set(panel.terrain_pick, "flat")
    browser.click(panel.load_button)
    wait_for(lambda: state(app).terrain == "flat", what="flat")


def test_record_button(app, browser):
    from app.live.commands import SetPaused

    panel = app.viewer.panel.recording
    app.session.call(SetPaused(False))  # a loaded terrain starts at once (a toast says it restarted)
    browser.click(panel.record_button)
    wait_for(lambda: app.recorder.recording, what="recording")
    wait_for(lambda: panel.record_button.label == "Stop recording", what="the button to say Stop")
    wait_for(lambda: app.recorder.status()["frames"] >= 10, what="10 frames")
    browser.click(panel.record_button)
    wait_for(lambda: not app.recorder.recording and app.recorder.last_saved, what="the recording to be saved")
    (entry,) = app.recordings.list()
    assert entry.name == app.recorder.last_saved and entry.size_bytes > 10_000


def test_terrain_editor(app, browser):
    from app.live import editor
    panel = app.viewer.panel.editor
    app.terrains.load("stepping_stones")
    area = Terrain.from_dict(app.terrains.current).steppable.area
    n = len(app.terrains.current["regions"])

    browser.set(panel.tool, "punch hole")
    wait_for(lambda: panel.tool.value == "punch hole", what="the punch tool")
    browser.click_scene((0.12, 0.12))
    wait_for(lambda: Terrain.from_dict(app.terrains.current).steppable.area < area - 1e-6, what="a hole")
    assert Terrain.from_dict(app.terrains.current).steppable.area == pytest.approx(area - 0.0025)
    assert state(app).terrain == "stepping_stones (edited)"
    punched = Terrain.from_dict(app.terrains.current).steppable.area
    browser.set(panel.tool, "fill hole")
    wait_for(lambda: panel.tool.value == "fill hole", what="the fill tool")
    browser.click_scene((0.12, 0.12))
    wait_for(lambda: Terrain.from_dict(app.terrains.current).steppable.area > punched + 1e-6, what="filled")
    assert Terrain.from_dict(app.terrains.current).steppable.area == pytest.approx(area)

    regions = lambda: app.terrains.current["regions"]  # noqa: E731
    for shape, xy in (("rect", (0.3, 0.45)), ("circle", (0.6, 0.45)), ("star", (0.9, 0.45))):
        before = len(regions())
        browser.set(panel.tool, f"add {shape}")
        wait_for(lambda shape=shape: panel.tool.value == f"add {shape}", what=f"the {shape} tool")
        browser.click_scene(xy)
        wait_for(lambda before=before: len(regions()) == before + 1, what=f"a {shape}")
        assert regions()[-1]["shape"] == shape
        assert editor.region_pose(regions()[-1])[0] == pytest.approx(xy, abs=0.03)

    browser.set(panel.tool, "select stone")
    wait_for(lambda: panel.tool.value == "select stone", what="the select tool")
    browser.click_scene((0.6, 0.45))
    star_index = len(regions()) - 1
    wait_for(lambda: panel._selected == star_index - 1 and panel._gizmo is not None, what="the circle selected")
    assert not panel.delete_button.disabled
    browser.drag_gizmo(panel._gizmo.name, (0.65, 0.5, 0.01), 0.3)
    wait_for(lambda: editor.region_pose(regions()[star_index - 1])[0] == pytest.approx((0.65, 0.5), abs=1e-6),
             what="the circle moved")
    wait_for(lambda: panel._selected == star_index - 1 and not panel.delete_button.disabled,
             what="the moved circle selected again")  # as a user sees the delete button come back
    browser.click(panel.delete_button)
    wait_for(lambda: len(regions()) == star_index, what="the circle deleted")
    assert regions()[-1]["shape"] == "star"
    browser.click(panel.history_buttons, "Undo")
    wait_for(lambda: len(regions()) == star_index + 1, what="undo of the delete")
    assert app.terrains.can_redo
    browser.click(panel.history_buttons, "Redo")
    wait_for(lambda: len(regions()) == star_index, what="redo of the delete")
    wait_for(lambda: panel.info.content.startswith("Redone"), what="the redo said")
    browser.click(panel.history_buttons, "Undo")
    wait_for(lambda: len(regions()) == star_index + 1, what="undo again")

    browser.set(panel.name, "gui_saved")
    wait_for(lambda: panel.name.value == "gui_saved", what="the name")
    browser.click(panel.save_button)
    saved = app.terrains.store.path("gui_saved")
    wait_for(saved.exists, what="the saved file")
    assert Terrain.load(saved).to_dict()["regions"] == app.terrains.current["regions"]
    wait_for(lambda: state(app).terrain == "gui_saved", what="the label to follow the saved name")
    wait_for(lambda: app.viewer.panel.terrain.terrain_pick.value == "gui_saved", what="the picker to follow")

    browser.set(panel.tool, "add rect")  # one more edit, then save again under the same name: asks first
    wait_for(lambda: panel.tool.value == "add rect", what="the rect tool")
    browser.click_scene((1.2, 0.45))
    wait_for(lambda: state(app).terrain == "gui_saved (edited)", what="an edit")
    before = saved.read_bytes()
    wait_for(lambda: panel.name.value == "gui_saved", what="the name to stay")
    browser.click(panel.save_button)
    wait_for(lambda: panel.save_button.label == "Overwrite gui_saved?" and panel.cancel_button.visible,
             what="the confirm step")
    assert saved.read_bytes() == before  # nothing written yet
    browser.click(panel.cancel_button)
    wait_for(lambda: panel.save_button.label == "Save terrain" and not panel.cancel_button.visible, what="cancel")
    browser.click(panel.save_button)
    wait_for(lambda: panel.save_button.label == "Overwrite gui_saved?", what="the confirm step again")
    browser.click(panel.save_button)
    wait_for(lambda: saved.read_bytes() != before, what="the confirmed overwrite")
    assert Terrain.load(saved).to_dict()["regions"] == app.terrains.current["regions"]

    shipped = terrains_dir() / "flat.json"  # a shipped name: asks too, and never touches the shipped file
    shipped_bytes = shipped.read_bytes()
    browser.set(panel.name, "flat")
    wait_for(lambda: panel.name.value == "flat", what="the name")
    browser.click(panel.save_button)
    wait_for(lambda: panel.save_button.label == "Overwrite flat?", what="the confirm step for a shipped name")
    browser.set(panel.name, "flat2")  # a new name ends the confirm step
    wait_for(lambda: panel.save_button.label == "Save terrain", what="confirm dropped")
    assert shipped.read_bytes() == shipped_bytes

    browser.set(panel.tool, "select stone")  # a click that misses every stone says so
    wait_for(lambda: panel.tool.value == "select stone", what="the select tool")
    browser.click_scene((0.3, 3.0))
    wait_for(lambda: panel.info.content.startswith("No stone here"), what="the miss said")
    browser.set(panel.tool, "fill hole")
    wait_for(lambda: panel.tool.value == "fill hole", what="the fill tool")
    browser.click_scene((0.3, 0.45))  # on the rect added above: nothing to fill
    wait_for(lambda: panel.info.content.startswith("No hole here"), what="the no-op fill said")

    browser.set(panel.tool, "off")
    for _ in range(12):  # all the way back to the loaded terrain
        browser.click(panel.history_buttons, "Undo")
    wait_for(lambda: not app.terrains.can_undo, what="undo to the start")
    app.terrains.load("stepping_stones")
    wait_for(lambda: len(regions()) == n, what="the shipped terrain again")
    assert Terrain.from_dict(app.terrains.current).steppable.area == pytest.approx(area)


def test_terrain_upload(app, browser):
    panel = app.viewer.panel.editor
    narrow = (terrains_dir() / "narrow_stones.json").read_bytes()
    browser.upload(panel.upload, "narrow.json", narrow)
    wait_for(lambda: state(app).terrain == "narrow_stones (uploaded)", what="the uploaded terrain")
    assert app.session.view.terrain.to_dict()["regions"] == Terrain.from_dict(
        msgspec.json.decode(narrow)).to_dict()["regions"]
    current = app.terrains.current
    browser.upload(panel.upload, "bad.json", b'{"name": "x", "regions": [{"shape": "blob"}]}')
    time.sleep(1.0)
    assert app.terrains.current == current and state(app).terrain == "narrow_stones (uploaded)"


def test_a_height_map_upload_is_previewed_then_used_and_a_bad_one_said(app, browser):
    import io

    imports = app.viewer.panel.editor.imports
    heights = np.zeros((50, 200))
    heights[:, 80:88] = np.nan  # an 8 cm gap across the path
    heights[:, 120:] = 0.04  # a 4 cm step up
    buffer = io.BytesIO()
    np.save(buffer, heights)
    before = state(app).terrain
    browser.upload(imports.upload, "gap_and_step.npy", buffer.getvalue())
    wait_for(lambda: imports.pending is not None, timeout=60, what="the import's preview")  # matplotlib draws it
    # previewed, not used: the robot stays where it was; the report says what was kept
    assert state(app).terrain == before
    assert imports.use_button.visible and imports.image.visible
    # three tops: before the gap, between the gap and the step, on the step
    assert "3 top(s)" in imports.report.content and "gap_and_step.npy" in imports.report.content
    assert imports.image.image.shape[0] > 50  # the top view, not the empty placeholder
    browser.click(imports.use_button)
    wait_for(lambda: state(app).terrain == "gap_and_step (imported)", what="the imported terrain")
    # the preview closes once the terrain is loaded (a failed load keeps it): the same handler, a moment later
    wait_for(lambda: imports.pending is None and not imports.use_button.visible, what="the preview closed")
    wait_for(lambda: app.viewer.panel.editor.name.value == "gap_and_step", what="Save as: the file's name")
    terrain = app.session.view.terrain
    assert sorted(round(z, 3) for z, _ in terrain.levels) == [0.0, 0.04]
    assert not terrain.is_safe(np.array([[0.84, 0.25]]))[0] and terrain.is_safe(np.array([[0.5, 0.25]]))[0]
    # discarded: nothing changes
    browser.upload(imports.upload, "again.npy", buffer.getvalue())
    wait_for(lambda: imports.pending is not None, timeout=60, what="the second preview")
    browser.click(imports.discard_button)
    wait_for(lambda: imports.pending is None, what="the preview discarded")
    assert state(app).terrain == "gap_and_step (imported)"
    current = app.terrains.current
    browser.upload(imports.upload, "noise.npy", b"not an array")
    time.sleep(1.0)
    assert imports.pending is None
    assert app.terrains.current == current and state(app).terrain == "gap_and_step (imported)"


def test_camera_modes_per_browser(app, browser):
    camera = app.viewer.panel.camera
    client_id = next(iter(app.viewer.server.get_clients()))
    client = app.viewer.server.get_clients()[client_id]
    mode, recenter = camera.controls[client_id]  # this browser's own camera block
    assert mode.value == "follow" and camera.following(client_id)
    browser.set(mode, "top-down")
    wait_for(lambda: camera.mode(client_id) == "top-down", what="top-down")
    def from_above() -> bool:
        offset = camera_offset(app, client)
        return offset[2] > 0.5 and np.linalg.norm(offset[:2]) < 0.05 * offset[2]

    wait_for(from_above, what="the camera above the terrain, looking down")
    browser.set(mode, "free")
    wait_for(lambda: camera.mode(client_id) == "free", what="free")
    browser.click(recenter)  # free: back to the default view once, no following
    browser.set(mode, "follow")
    wait_for(lambda: camera.following(client_id), what="following again")
    browser.click(recenter)
    wait_for(lambda: camera.following(client_id), what="still following")


def test_disk_click_shows_leg_rank_and_safety(app, browser):
    from app.live.commands import SetPaused, SetPlanner

    app.terrains.load("stepping_stones")
    app.session.call(SetPlanner("contactnet"))
    app.session.call(SetPaused(False))
    wait_for(lambda: app.session.view.candidates is not None and app.session.view.candidates.rank is not None,
             what="ranked candidates")
    app.session.call(SetPaused(True))
    scene = app.viewer.scene
    wait_for(lambda: scene._drawn[0] is app.session.view.candidates, what="the disks drawn")
    cand = scene._drawn[0]
    (chosen,) = cand.chosen
    browser.click_node("/plan/candidates", chosen)
    legend = app.viewer.panel.legend
    leg = ("FL", "FR", "HL", "HR")[int(cand.leg[chosen])]
    wait_for(lambda: f"{leg} · rank {int(cand.rank[chosen])}" in legend.picked.content, what="the picked disk")
    assert "chosen" in legend.picked.content
    client_id = next(iter(app.viewer.server.get_clients()))
    assert scene._pick_labels[client_id].text.startswith(leg)  # the 3D label next to the disk
    unsafe = np.flatnonzero(~cand.safe)
    if len(unsafe):
        browser.click_node("/plan/candidates", int(unsafe[0]))
        wait_for(lambda: "unsafe" in legend.picked.content, what="an unsafe disk")
    app.session.call(SetPlanner("heuristic"))
    app.terrains.load("flat")


def test_compare_button_toggles_compare_mode(app, browser):
    panel = app.viewer.panel.gait_planner
    browser.set(panel.compare_with, "fixed")
    wait_for(lambda: panel.compare_button.label == "Compare with fixed", what="the button label")
    browser.click(panel.compare_button)
    wait_for(lambda: app.session.view.compare, what="compare mode on")
    assert [c.planner for c in app.session.view.compare] == ["fixed"]
    ghosts = app.viewer.scene.ghosts
    wait_for(lambda: ghosts.ghosts and ghosts.ghosts[0].visible, what="the ghost robot drawn")
    wait_for(lambda: len(ghosts.labels) > 1 and ghosts.labels[1].text.startswith("fixed"),
             what="the ghost's label")  # the scene thread adds the label after showing the ghost
    wait_for(lambda: panel.compare_button.label == "Stop comparing", what="the button to say Stop")
    browser.click(panel.compare_button)
    wait_for(lambda: app.session.view.compare is None, what="compare mode off")
    wait_for(lambda: not ghosts.ghosts[0].visible and not ghosts.labels[0].visible, what="the ghost hidden")


def test_status_panel_says_what_the_header_says(app, browser):
    from app.live.view import status_line

    status = app.viewer.panel.status
    wait_for(lambda: status.text.content.startswith(f"**{status_line(app.session.view)}**"), what="one status")
    assert 0.0 <= status.progress.value <= 100.0
    plots = app.viewer.panel.plots
    assert plots.gait_plot.axes[1]["values"] == ("FL", "FR", "HL", "HR", "stand")  # the legs, then the stand band
