"""The per-browser camera of the 3D view, in one of three modes each browser picks for itself:

- ``follow`` (the default): the camera moves with the robot. Orbiting and zooming change the
  viewing angle and distance, and it keeps following from there; a pan snaps back to the robot.
- ``free``: the camera stays where the user puts it.
- ``top-down``: a still view from above over the whole terrain, for the terrain editor.

"Re-center" puts the camera back to its mode's default view. Every browser gets its own small
"Camera" block in the panel (a per-client GUI), so one browser's choice never moves another's camera.

How a user's orbit is told apart from our own moves: the browser reports its camera after every
change, ours included, but late (a software renderer can be a second behind), and reports are
handled in arrival order on viser's event loop. A report that matches none of the poses we set in
the last few seconds (to a few millimetres: ours come back exact) is the user's: in follow mode its
orbit and zoom become the new offset from the robot, and we stop moving that camera until the user
has been still for `hold_s` (so we never fight a drag).

What made the camera look broken before (measured in headless chromium, software WebGL, ~1 frame/s):
the follower moved the camera 10 times a second, and each move resets the browser's orbit controls,
so a drag started while the robot walked was undone before the slow renderer ever drew (and reported)
it: the camera seemed to ignore the user and Re-center to do nothing. A drag that did get through
stopped following for good, and the robot walked off behind the panel. Now a browser that reports
slowly is moved at most every `slow_move_s` (time for a drag to show), an orbit is kept, not a reason
to stop following, and Re-center sends its pose even when viser believes the browser has it (viser's
camera setters skip values equal to the last state the server knows, and late reports overwrite it).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np
import viser
from viser import _messages

from app.live.view import LiveView
from app.scene.live_scene import default_camera, follow_anchor

log = logging.getLogger("contactnet.app.camera")

MODES = ("follow", "free", "top-down")
MODE_HINT = (
    "Follow: moves with the robot (orbit and zoom keep following). Free: stays where you put it. "
    "Top-down: the whole terrain from above, for the terrain editor."
)


def place_camera(client: viser.ClientHandle, position: np.ndarray, look_at: np.ndarray, force: bool = False) -> None:
    """Set a browser's camera to ``position`` looking at ``look_at`` (z up). With ``force`` the pose is
    sent even when the server believes the browser already has it (its belief can be a stale report)."""
    position = np.asarray(position, dtype=float)
    look_at = np.asarray(look_at, dtype=float)
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(look_at))) or np.linalg.norm(position - look_at) < 1e-6:
        raise ValueError("a camera needs finite, distinct position and look-at points")
    camera = client.camera
    with client.atomic():  # applied in one go: the browser never reports a half-set pose
        camera.up_direction = (0.0, 0.0, 1.0)
        camera.look_at = look_at
        camera.position = position  # viser moves look_at along with the position ...
        camera.look_at = look_at  # ... so set it again
        if force:
            connection = client._websock_connection  # viser 1.1 (pinned): the setters' own channel
            connection.queue_message(_messages.SetCameraPositionMessage(tuple(map(float, position))))
            connection.queue_message(_messages.SetCameraLookAtMessage(tuple(map(float, look_at))))


#: Around the terrain's part a top-down view frames, in metres: the robot stands ~0.3 m above the ground, so under a
#: camera a couple of metres up it is drawn larger than its footprint (its start pad was cut off at the view's edge).
TOP_DOWN_MARGIN_M = 0.3


def top_down_pose(
    view: LiveView, fov_rad: float = math.radians(50.0), aspect: float = 1.6, panel_fraction: float = 0.0,
    panel_bottom: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """(position, look_at) above the terrain, seeing all of it in the part of the window the control panel
    leaves free: its right ``panel_fraction`` of the width (a wide window), or its lower ``panel_bottom`` of the
    height (a phone: viser's bottom sheet); +x to the right and +y up on screen. A very large terrain (flat is 20 m
    wide) is framed from its start to its goal line only. ``fov_rad`` is the vertical field of view."""
    terrain = view.terrain
    minx, miny, maxx, maxy = terrain.bounds
    start_x, start_y = (float(v) for v in terrain.start_xy)
    minx, maxx = max(minx, start_x - 0.5), min(maxx, max(terrain.goal_x, start_x) + 0.5)
    miny, maxy = max(miny, start_y - 1.0), min(maxy, start_y + 1.0)
    half_x = 0.5 * max(maxx - minx, 0.5) + TOP_DOWN_MARGIN_M
    half_y = 0.5 * max(maxy - miny, 0.5) + TOP_DOWN_MARGIN_M
    tan_half = math.tan(0.5 * min(max(fov_rad, 0.2), 2.5))
    panel_fraction = min(max(panel_fraction, 0.0), 0.8)
    panel_bottom = min(max(panel_bottom, 0.0), 0.8)
    free_aspect = max(aspect, 0.3) * (1.0 - panel_fraction)
    height = max(half_y / (tan_half * (1.0 - panel_bottom)), half_x / (tan_half * free_aspect))
    view_height_m = 2.0 * height * tan_half
    view_width_m = view_height_m * max(aspect, 0.3)
    look_at = np.array([
        (minx + maxx) / 2 + 0.5 * panel_fraction * view_width_m,
        (miny + maxy) / 2 - 0.5 * panel_bottom * view_height_m,  # the terrain in the upper, free part
        terrain.surface_z,
    ])
    position = look_at + np.array([0.0, -0.02 * height, height])  # a hair south: the view's up is +y
    return position, look_at


#: The part of a wide window's width the control panel covers, at 1400 px (app/viewer/gui.py: control_width
#: "large"); `panel_share` gives it for another width.
PANEL_FRACTION = 0.30
#: viser's floating control panel, in CSS pixels: 25 em wide plus its margin (static/app.css --panel-w).
PANEL_PX = 424
#: The part of a narrow window's height viser's bottom sheet covers (a phone).
PANEL_BOTTOM = 0.5


def panel_share(width_px: int) -> tuple[float, float]:
    """(right, bottom): the parts of a browser's 3D view its control panel covers, for a view ``width_px`` wide (as the
    browser reports it: the canvas's width)."""
    if width_px <= 0:
        return PANEL_FRACTION, 0.0
    if width_px < WIDE_PX:
        return 0.0, PANEL_BOTTOM
    # the reported width is the canvas's, in device pixels: viser lowers its resolution on a slow machine (0.75 of the
    # CSS width here), which would overstate the panel; the clamp keeps the share a wide window's
    return min(0.4, max(0.25, PANEL_PX / width_px)), 0.0


#: Where the followed point is drawn, as fractions of the view from its middle: in a wide window the panel
#: covers about the right quarter, so a little left; in a narrow one the panel lies over the lower half, so
#: in the upper part (and the camera a little farther away, the view being narrow).
WIDE_PX = 900
WIDE_LEFT = 0.08
NARROW_UP = 0.18
NARROW_ZOOM_OUT = 1.3


def is_narrow(client: viser.ClientHandle) -> bool:
    """A narrow window (a phone): viser puts the control panel over the lower half of the view."""
    return 0 < int(client.camera._state.image_width) < WIDE_PX


def framing_shift(client: viser.ClientHandle, offset: np.ndarray) -> np.ndarray:
    """Look-at shift that draws the followed point clear of the control panel in this browser's window, for a
    camera at ``offset`` (position - look-at): see WIDE_LEFT, NARROW_UP."""
    state = client.camera._state
    width, height = int(state.image_width), int(state.image_height)
    offset = np.asarray(offset, dtype=float)
    distance = float(np.linalg.norm(offset))
    if width <= 0 or height <= 0 or distance < 1e-9:
        return np.zeros(3)
    forward = -offset / distance
    right = np.cross(forward, [0.0, 0.0, 1.0])
    if np.linalg.norm(right) < 1e-9:
        return np.zeros(3)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    fov = float(state.fov) if state.fov > 0 else math.radians(50.0)
    view_height_m = 2.0 * distance * math.tan(0.5 * fov)
    if width < WIDE_PX:
        return -up * NARROW_UP * view_height_m
    return right * WIDE_LEFT * view_height_m * width / height


@dataclass
class _Browser:
    """One browser's camera state (guarded by CameraControl's lock)."""

    mode: str = "follow"
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))  # follow: camera position - look-at
    sent: deque = field(default_factory=lambda: deque(maxlen=80))  # (time, look_at, offset) we set
    pan: np.ndarray = field(default_factory=lambda: np.zeros(3))  # follow: look-at point - followed point
    hold_until: float = 0.0  # follow: the user moved the camera; leave it alone until then
    anchor: np.ndarray | None = None  # follow: the robot anchor the camera was last placed at
    placed: bool = False  # the first recenter happened (before it the offset means nothing)
    last_report: float = 0.0  # when the browser last reported its camera
    report_s: float = 0.0  # how often it reports (moving average): a software renderer draws ~1 frame/s
    next_move: float = 0.0  # follow: not before then (a slow browser is moved less often)


class CameraControl:
    """Per browser: the camera mode, "Re-center", and following the robot (see the module doc)."""

    # A browser reports back the pose we set to float precision (applied in one frame: `place_camera`), so a
    # small tolerance: even a short drag (a few cm at the camera) counts as the user's.
    tolerance_m = 2e-3
    tolerance_rel = 2e-3
    hold_s = 0.7
    memory_s = 6.0  # how long a pose we set can still come back in a late report
    slow_report_s = 0.3  # a browser reporting less often than this draws slowly ...
    slow_move_s = 1.5  # ... and is moved at most this often, so a drag has time to show (and be reported)
    smoothing = 0.3  # per step (10 Hz): the followed point lags the robot by ~0.3 s, so its sway does not shake the view
    min_move_m = 3e-3  # smaller moves of the followed point are not sent
    jump_m = 0.3  # a larger move (a reset, a new terrain) is followed at once

    def __init__(self, server: viser.ViserServer, order: float = 5.0):
        self.server = server
        self.order = order
        self._lock = threading.Lock()
        self._browsers: dict[int, _Browser] = {}
        self.controls: dict[int, tuple[viser.GuiDropdownHandle, viser.GuiButtonHandle]] = {}
        self.view: LiveView | None = None
        self._anchor: np.ndarray | None = None
        self._terrain_version: int | None = None
        server.on_client_connect(self._on_connect)
        server.on_client_disconnect(self._on_disconnect)

    # ---- browsers come and go ------------------------------------------------------------------------
    def _on_connect(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._browsers[client.client_id] = _Browser()
        with client.gui.add_folder("Camera", order=self.order):
            mode = client.gui.add_dropdown("Camera", MODES, initial_value="follow", hint=MODE_HINT)
            recenter = client.gui.add_button(
                "Re-center", icon=viser.Icon.FOCUS_CENTERED, hint="Back to this mode's default view"
            )
        mode.on_update(lambda event: self.set_mode(client, str(mode.value)))
        recenter.on_click(lambda event: self.recenter(client))
        self.controls[client.client_id] = (mode, recenter)
        client.camera.on_update(self._on_camera)
        self.recenter(client)

    def _on_disconnect(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._browsers.pop(client.client_id, None)
        self.controls.pop(client.client_id, None)

    # ---- what a browser asks -------------------------------------------------------------------------
    def mode(self, client_id: int) -> str | None:
        browser = self._browsers.get(client_id)
        return None if browser is None else browser.mode

    def following(self, client_id: int) -> bool:
        return self.mode(client_id) == "follow"

    def set_mode(self, client: viser.ClientHandle, mode: str) -> None:
        if mode not in MODES:
            raise ValueError(f"camera mode must be one of {', '.join(MODES)}")
        with self._lock:
            browser = self._browsers.get(client.client_id)
            if browser is None:
                return
            browser.mode = mode
        control = self.controls.get(client.client_id)
        if control is not None and control[0].value != mode:
            control[0].value = mode
        self.recenter(client)

    def recenter(self, client: viser.ClientHandle) -> None:
        """Put the browser's camera at its mode's default view (sent even if the server thinks it is there)."""
        view = self.view
        with self._lock:
            browser = self._browsers.get(client.client_id)
            if view is None or browser is None:
                return
            if browser.mode == "top-down":
                camera = client.camera
                width = camera._state.image_width
                aspect = width / max(camera._state.image_height, 1) or 1.6
                right, bottom = panel_share(int(width))
                position, look_at = top_down_pose(view, camera._state.fov or math.radians(50.0), aspect, right, bottom)
            else:
                position, look_at = default_camera(view)
                offset = (position - look_at) * (NARROW_ZOOM_OUT if is_narrow(client) else 1.0)
                pan = framing_shift(client, offset)
                look_at = look_at + pan
                position = look_at + offset
                if browser.mode == "follow":
                    browser.pan = pan
                    browser.offset = position - look_at
                    browser.anchor = None  # placed at the robot itself; the next step() re-anchors
                    browser.hold_until = 0.0
            browser.placed = True
            self._remember(browser, look_at, position - look_at)
            place_camera(client, position, look_at, force=True)  # under the lock: no step() in between

    # ---- reports from the browser ------------------------------------------------------------------
    def _remember(self, browser: _Browser, look_at: np.ndarray, offset: np.ndarray) -> None:
        browser.sent.append((time.monotonic(), np.array(look_at, dtype=float), np.array(offset, dtype=float)))

    def _ours(self, browser: _Browser, position: np.ndarray, look_at: np.ndarray) -> bool:
        """Whether a reported pose is one we set recently (a late echo), not the user's."""
        offset = position - look_at
        tolerance = max(self.tolerance_m, self.tolerance_rel * float(np.linalg.norm(offset)))
        horizon = time.monotonic() - self.memory_s
        return any(
            t >= horizon
            and np.linalg.norm(look_at - sent_look_at) <= tolerance
            and np.linalg.norm(offset - sent_offset) <= tolerance
            for t, sent_look_at, sent_offset in browser.sent
        )

    async def _on_camera(self, camera: viser.CameraHandle) -> None:
        """Runs on viser's event loop, so reports are seen in the order they arrive."""
        position, look_at = np.asarray(camera.position, dtype=float), np.asarray(camera.look_at, dtype=float)
        initial = self.server.initial_camera
        if np.allclose(position, initial.position, atol=1e-3) and np.allclose(look_at, initial.look_at, atol=1e-3):
            return  # a late report of the page's initial camera (it can arrive after we moved it)
        with self._lock:
            browser = self._browsers.get(camera.client.client_id)
            if browser is None:
                return
            now = time.monotonic()
            if browser.last_report:
                browser.report_s = 0.8 * browser.report_s + 0.2 * min(now - browser.last_report, 5.0)
            browser.last_report = now
            if browser.mode != "follow" or self._ours(browser, position, look_at):
                return
            browser.offset = position - look_at  # the user's orbit and zoom: keep following from there
            browser.pan = framing_shift(camera.client, browser.offset)
            browser.hold_until = time.monotonic() + self.hold_s
            log.debug("client %s moved the camera: offset %s", camera.client.client_id, browser.offset)

    # ---- following ---------------------------------------------------------------------------------------
    def step(self, view: LiveView) -> None:
        """Move following cameras with the robot; re-fit top-down views when the terrain changed."""
        self.view = view
        target = follow_anchor(view)
        if self._anchor is None or np.linalg.norm(target - self._anchor) > self.jump_m:
            self._anchor = target
        else:
            self._anchor = self._anchor + self.smoothing * (target - self._anchor)
        anchor = self._anchor
        terrain_changed = self._terrain_version is not None and view.terrain_version != self._terrain_version
        self._terrain_version = view.terrain_version
        now = time.monotonic()
        for client in self.server.get_clients().values():
            with self._lock:
                browser = self._browsers.get(client.client_id)
                if browser is None:
                    continue
                mode = "unplaced" if not browser.placed else browser.mode
                if mode == "follow":
                    moved = browser.anchor is None or np.linalg.norm(anchor - browser.anchor) > self.min_move_m
                    if now < max(browser.hold_until, browser.next_move) or not moved:
                        continue
                    slow = browser.report_s > self.slow_report_s
                    browser.next_move = now + (max(self.slow_move_s, 1.5 * browser.report_s) if slow else 0.0)
                    browser.anchor = anchor.copy()
                    look_at = anchor + browser.pan
                    self._remember(browser, look_at, browser.offset)
                    place_camera(client, look_at + browser.offset, look_at)
            if mode == "unplaced" or (mode == "top-down" and terrain_changed):
                self.recenter(client)
