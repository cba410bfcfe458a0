"""The read-only view of a live session (`Viewer.watch_port`): a viser server of its own with the session's scene
and a per-browser camera block (`app/scene/camera.py`), and nothing that acts on the session. Watchers connect
there, never to the session's own server with its control panel, so watching is read-only by construction."""

from __future__ import annotations

import viser

from app.live.view import LiveView
from app.scene.camera import CameraControl
from app.scene.live_scene import LiveScene
from app.viewer.panels.notices import close_software_webgl_toast
from contactnet.robots import Robot


class WatchView:
    """The scene of one session on ``server`` (made by the caller, guarded like the session's own), followed by each
    watcher's camera."""

    def __init__(self, server: viser.ViserServer, robot: Robot):
        self.server = server
        self.scene = LiveScene(server, robot)
        self.camera = CameraControl(server)  # a GUI per browser: viser shows no developer panel then
        server.on_client_connect(close_software_webgl_toast)

    @property
    def port(self) -> int:
        return self.server.get_port()

    def update(self, view: LiveView) -> None:
        self.scene.update(view)

    def step_cameras(self, view: LiveView) -> None:
        self.camera.step(view)
