"""The per-browser camera of the 3D view: it follows the robot until the user moves it."""

from __future__ import annotations

import logging
import threading
import time
from collections import deque

import numpy as np
import viser

from app.scene import default_camera
from app.view import LiveView

log = logging.getLogger("contactnet.app.camera")


class CameraFollow:
    """Per browser: move the camera with the robot until the user orbits, pans or zooms.

    The browser reports its camera after every change, ours included, but late (a slow renderer
    can be a second behind); reports are handled in arrival order on viser's event loop, and a
    late report of the page's initial camera is ignored. After (re)centring we wait for a report
    that matches what we set ("synced"); from then on a report off every camera state we set in
    the last few seconds by more than `tolerance` (the larger of `tolerance_m` and `tolerance_rel`
    of the viewing distance) is the user's own orbit, pan or zoom, and following stops for that
    browser until "Re-center camera".
    """

    tolerance_m = 0.05
    tolerance_rel = 0.03
    sync_timeout_s = 5.0

    def __init__(self, server: viser.ViserServer):
        self.server = server
        self._lock = threading.Lock()
        self._state: dict[int, dict] = {}
        self._base: np.ndarray | None = None
        self.view: LiveView | None = None
        server.on_client_connect(self._on_connect)
        server.on_client_disconnect(lambda client: self._state.pop(client.client_id, None))

    def _on_connect(self, client: viser.ClientHandle) -> None:
        self.recenter(client)
        client.camera.on_update(self._on_camera)

    def recenter(self, client: viser.ClientHandle) -> None:
        view = self.view
        if view is None:
            return
        position, look_at = default_camera(view)
        with self._lock:
            self._state[client.client_id] = {
                "follow": True,
                "offset": position - look_at,
                "look_ats": deque([look_at.copy()], maxlen=60),
                "synced": False,
                "since": time.monotonic(),
            }
        client.camera.look_at = look_at
        client.camera.position = position
        client.camera.look_at = look_at

    async def _on_camera(self, camera: viser.CameraHandle) -> None:
        """Runs on viser's event loop, so reports are seen in the order they arrive."""
        with self._lock:
            state = self._state.get(camera.client.client_id)
            if state is None or not state["follow"]:
                return
            position, look_at = np.asarray(camera.position), np.asarray(camera.look_at)
            initial = self.server.initial_camera
            if np.allclose(position, initial.position, atol=1e-3) and np.allclose(
                look_at, initial.look_at, atol=1e-3
            ):
                return  # a late report of the page's initial camera (it can arrive after we moved it)
            orbit_error = np.linalg.norm(position - look_at - state["offset"])
            pan_error = min(np.linalg.norm(look_at - p) for p in state["look_ats"])
            tolerance = max(self.tolerance_m, self.tolerance_rel * float(np.linalg.norm(state["offset"])))
            matches = max(orbit_error, pan_error) <= tolerance
            if not state["synced"]:
                state["synced"] = matches or time.monotonic() - state["since"] > self.sync_timeout_s
            elif not matches:
                state["follow"] = False
                log.debug(
                    "client %s moved the camera: stop following (orbit %.3f m, pan %.3f m)",
                    camera.client.client_id,
                    orbit_error,
                    pan_error,
                )

    def following(self, client_id: int) -> bool:
        state = self._state.get(client_id)
        return bool(state and state["follow"])

    def step(self, view: LiveView) -> None:
        """Shift following cameras by the base's motion since the last step."""
        self.view = view
        base = np.array([view.snapshot.q[0], view.snapshot.q[1], 0.0])
        previous, self._base = self._base, base
        if previous is None:
            return
        delta = base - previous
        if np.linalg.norm(delta) < 1e-4:
            return
        clients = self.server.get_clients().values()
        if np.linalg.norm(delta) > 0.3:  # a reset or a new terrain: back to the default view
            for client in clients:
                if self.following(client.client_id):
                    self.recenter(client)
            return
        for client in clients:
            with self._lock:
                state = self._state.get(client.client_id)
                if state is None or not state["follow"]:
                    continue
                look_at = state["look_ats"][-1] + delta
                state["look_ats"].append(look_at)
                position = look_at + state["offset"]
            client.camera.position = position  # moves the look-at point along
            client.camera.look_at = look_at
