"""The viser side of the tool: one ViserServer with the scene, the control panel and the terrain
editor (`app/viewer/gui.py`), and the loop that keeps them up to date (scene ~30 Hz, panel and plots ~5 Hz,
following cameras ~10 Hz, recordings at their own rate). The loop only reads `session.view`; it never
waits for the simulation, and the simulation never waits for it.

When a browser connects, the session is told (`ViewerConnected`: a session waiting for its first
viewer starts after a short count-down, so the scene is drawn before the robot moves), and viser's
software-WebGL toast is given an auto-close (`app/viewer/panels/notices.py`).
"""

from __future__ import annotations

import contextlib
import io
import logging
import threading
import time
from dataclasses import dataclass, field

import viser

from app.live.commands import ViewerConnected
from app.live.editing import TerrainService
from app.live.session import LiveSession
from app.recordings.live_recorder import LiveRecorder
from app.recordings.recorder import stop_quietly
from app.scene.live_scene import LiveScene, default_camera
from app.security.guards import AccessPolicy, guard_viser, prepare_viser_guard
from app.viewer.gui import ControlPanel
from app.viewer.panels.common import submit
from app.viewer.panels.notices import close_software_webgl_toast
from app.viewer.watch import WatchView
from contactnet.robots import Robot

log = logging.getLogger("contactnet.app.viewer")


@dataclass
class UpdateStats:
    """Costs of the update loop (seconds of this thread's CPU time per scene update)."""

    scene_updates: int = 0
    scene_cpu_s: list[float] = field(default_factory=list)

    def add(self, cpu_s: float) -> None:
        self.scene_updates += 1
        self.scene_cpu_s.append(cpu_s)
        del self.scene_cpu_s[:-2000]


class Viewer:
    """The live viser server: draws the session's views of ``robot`` and runs the control panel."""

    def __init__(
        self,
        session: LiveSession,
        terrains: TerrainService,
        recorder: LiveRecorder,
        robot: Robot,
        host: str = "127.0.0.1",
        port: int = 8080,
        scene_hz: float = 30.0,
        policy: AccessPolicy | None = None,
    ):
        """``policy``: who may connect (Host, Origin, token: `app.security.guards`); None accepts everyone.
        ``port`` 0: one the OS picks (`port` says which)."""
        self.session = session
        self.recorder = recorder
        self.robot = robot
        self.host = host
        self.policy = policy
        self.server = self._new_server(port)
        self.scene = LiveScene(self.server, robot)
        self._watch_lock = threading.Lock()
        self._watch: WatchView | None = None  # the read-only view (`watch_port`), made on first use
        self.panel = ControlPanel(self.server, session, terrains, recorder, self.scene)
        self.server.on_client_connect(self._on_connect)
        self.scene_period = 1.0 / scene_hz
        self.stats = UpdateStats()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="viewer-update", daemon=True)
        self._thread.start()

    def _new_server(self, port: int) -> viser.ViserServer:
        if self.policy is not None:
            prepare_viser_guard(self.policy)
        with contextlib.redirect_stdout(io.StringIO()):  # viser prints a banner even when not verbose
            server = viser.ViserServer(host=self.host, port=port, verbose=False)
        if self.policy is not None:
            guard_viser(server, self.policy)
        view = self.session.view
        if view is not None:
            position, look_at = default_camera(view)
            server.initial_camera.position = tuple(position)
            server.initial_camera.look_at = tuple(look_at)
            server.initial_camera.up = (0.0, 0.0, 1.0)
        return server

    def clients(self) -> int:
        """Browsers with the 3D view (with its control panel) open."""
        return len(self.server.get_clients())

    def watch_port(self) -> int:
        """The port of this session's read-only view: a second viser server with the same scene and no control
        panel (made on the first call; its scene follows the session from then on)."""
        with self._watch_lock:
            if self._watch is None:
                server = self._new_server(0)
                try:
                    self._watch = WatchView(server, self.robot)
                except BaseException:
                    stop_quietly(server)
                    raise
            return self._watch.port

    def _on_connect(self, client: viser.ClientHandle) -> None:
        close_software_webgl_toast(client)
        submit(self.session, ViewerConnected(), client, "Starting the session failed")

    @property
    def port(self) -> int:
        return self.server.get_port()

    def _loop(self) -> None:
        last_seq = -1
        next_panel = next_camera = 0.0
        deadline = time.perf_counter()
        while not self._stop.is_set():
            deadline += self.scene_period
            now = time.perf_counter()
            if deadline < now - self.scene_period:  # fell behind: skip, do not burst
                deadline = now
            view = self.session.view
            try:
                if view is not None and view.seq != last_seq:
                    last_seq = view.seq
                    cpu0 = time.thread_time()
                    self.scene.update(view)
                    if self._watch is not None:
                        self._watch.update(view)
                    self.panel.observe(view)
                    self.stats.add(time.thread_time() - cpu0)
                self.recorder.feed(view)  # cheap when no frame is due (also records a paused scene once)
                if view is not None and now >= next_camera:
                    next_camera = now + 0.1
                    self.panel.camera.step(view)
                    if self._watch is not None:
                        self._watch.step_cameras(view)
                if view is not None and now >= next_panel:
                    next_panel = now + 0.2
                    self.panel.refresh(view)
            except Exception:  # noqa: BLE001 - keep drawing; log once per failure
                log.exception("viewer update failed")
            self._stop.wait(max(0.0, deadline - time.perf_counter()))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5.0)
        stop_quietly(self.server)
        if self._watch is not None:
            stop_quietly(self._watch.server)
