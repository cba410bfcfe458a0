"""The viser control panel: status, driving, pushes, gait/planner/noise, terrain picker, recording,
the live gait-schedule and timing plots, keyboard shortcuts, and the per-browser camera that
follows the robot until the user moves it.

Every control only submits a command to the live session (never waits for it); `refresh(view)`
(called by the viewer's update loop a few times a second) writes the session's state back into
the panel, so changes made through REST or by another browser show up too. Values are written
back only when the session's value changed since the last refresh, so a slider being dragged
is not pulled back by a stale state.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from concurrent.futures import Future

import numpy as np
import viser
import viser.uplot as uplot

from app.editing import TerrainService
from app.live import (
    GAITS,
    PLANNERS,
    PUSH_DURATION_LIMIT,
    PUSH_FORCE_LIMIT,
    SPEED_RANGE,
    VELOCITY_LIMIT,
    ApplyPush,
    LiveSession,
    LiveView,
    NudgeVelocity,
    Reset,
    SetGait,
    SetNoise,
    SetPlanner,
    SetSpeed,
    SetVelocity,
    TogglePause,
    gait_chart,
)
from app.recordings import LiveRecorder
from app.scene import default_camera
from contactnet.robot import LEG_NAMES

log = logging.getLogger("contactnet.app.gui")

VELOCITY_STEP = 0.05
LEG_COLORS = ("#e8590c", "#1c7ed6", "#2f9e44", "#ae3ec9")  # FL FR HL HR


def _hex_rgba(color: str, alpha: float) -> str:
    r, g, b = (int(color[i : i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha})"


def status_markdown(view: LiveView) -> str:
    """The status panel text (markdown)."""
    s, snap = view.status, view.snapshot
    if s.error:
        state = f"**ERROR**: {s.error}"
    elif s.done and s.done.startswith("fell"):
        state = f"**FELL** ({s.done[6:]}) - press Reset"
    elif s.done:
        state = "**GOAL REACHED** - press Reset"
    elif s.paused:
        state = "**PAUSED**"
    else:
        state = "**running**"
    rank = snap.planned_steps[0].rank if snap.planned_steps else None
    timing = view.timing
    mean_plan = f" (mean {timing[:, 1].mean():.2f})" if len(timing) else ""
    planner = (
        s.planner_active if s.planner == s.planner_active else f"{s.planner_active} (asked: {s.planner})"
    )
    lines = [
        f"{state} · t = {snap.t_s:.2f} s · RTF {s.real_time_factor:.2f} · speed {s.speed:.2g}x",
        f"terrain **{s.terrain}** · {s.gait} · planner **{planner}** · noise {'on' if s.noise else 'off'}",
        f"cmd ({snap.vel_cmd_xy[0]:+.2f}, {snap.vel_cmd_xy[1]:+.2f}) m/s · "
        f"CoM vel ({snap.com_vel[0]:+.2f}, {snap.com_vel[1]:+.2f}) · x = {snap.q[0]:.2f} m",
        f"steps {snap.steps} · rank chosen {'n/a' if rank is None else rank} · "
        f"plan {snap.last_planner_ms:.2f} ms{mean_plan} · optimizer {snap.last_trajopt_ms:.1f} ms",
    ]
    if np.any(view.push_force_world):
        f = view.push_force_world
        lines.append(f"**push active** ({f[0]:+.0f}, {f[1]:+.0f}) N · pushes so far {s.pushes}")
    elif s.pushes:
        lines.append(f"pushes so far {s.pushes}")
    if s.planner_note:
        lines.append(f"*{s.planner_note}*")
    return "  \n".join(lines)


class _CameraFollow:
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


class ControlPanel:
    """The control panel of the viser GUI (shared by all browsers)."""

    def __init__(
        self,
        server: viser.ViserServer,
        session: LiveSession,
        terrains: TerrainService,
        recorder: LiveRecorder,
    ):
        self.server = server
        self.session = session
        self.terrains = terrains
        self.recorder = recorder
        self.camera = _CameraFollow(server)
        self._seen: dict[str, object] = {}
        self._timing_key: int | None = None
        gui = server.gui
        gui.configure_theme(
            control_width="large", dark_mode=False, show_logo=False, brand_color=(40, 90, 200)
        )
        self.status = gui.add_markdown("starting ...", order=0)

        with gui.add_folder("Drive", order=10):
            self.vx = gui.add_slider("vx [m/s]", -VELOCITY_LIMIT, VELOCITY_LIMIT, 0.01, 0.0)
            self.vy = gui.add_slider("vy [m/s]", -VELOCITY_LIMIT, VELOCITY_LIMIT, 0.01, 0.0)
            self.stop_button = gui.add_button(
                "Stop (x)",
                icon=viser.Icon.HAND_STOP,
                hint="vx = vy = 0. Keys: I/K vx +-0.05, J/L vy +-0.05, X stop, P pause "
                "(W/A/S/D/Q/E and arrows move the camera)",
            )
            self.run_button = gui.add_button("Pause", icon=viser.Icon.PLAYER_PAUSE)
            self.reset_button = gui.add_button("Reset", icon=viser.Icon.REFRESH, color="red")
            self.speed = gui.add_slider(
                "Sim speed",
                SPEED_RANGE[0],
                SPEED_RANGE[1],
                0.1,
                1.0,
                hint="simulated seconds per wall-clock second",
            )
            self.recenter = gui.add_button(
                "Re-center camera",
                icon=viser.Icon.FOCUS_CENTERED,
                hint="The camera follows the robot until you move it",
            )
            self.shadows = gui.add_checkbox("Shadows", True, hint="Turn off for faster drawing without a GPU")
        with gui.add_folder("Push", order=20):
            self.push_force = gui.add_slider("Force [N]", 0.5, PUSH_FORCE_LIMIT, 0.5, 5.0)
            self.push_duration = gui.add_slider("Duration [s]", 0.1, PUSH_DURATION_LIMIT, 0.1, 1.0)
            self.push_buttons = gui.add_button_group("Push", ("+x", "-x", "+y", "-y"))
        with gui.add_folder("Robot and planner", order=40):
            self.gait = gui.add_dropdown("Gait", GAITS, initial_value="walk")
            self.planner = gui.add_dropdown("Planner", PLANNERS, initial_value="contactnet")
            self.noise = gui.add_checkbox(
                "Joint-velocity noise", False, hint="Gaussian, variance 0.01 (rad/s)^2"
            )
            self.legend = gui.add_markdown(
                "Disks: candidate footholds, **green** = best-ranked safe, fading to grey down the "
                "ranking; **red** = unsafe; **gold** = chosen. Orange balls: the next 3 steps. "
                "Lines: planned CoM (blue), actual CoM (purple), foot forces (dark blue), push (red)."
            )
        with gui.add_folder("Terrain", order=45, expand_by_default=False):
            options = self._terrain_options()
            self.terrain_pick = gui.add_dropdown(
                "Terrain",
                options,
                initial_value=terrains.label if terrains.label in options else options[0],
                hint="Pick, then press Load terrain",
            )
            self.removed = gui.add_number("Random: removed", 80, min=0, max=300, step=1, visible=False)
            self.seed = gui.add_number("Random: seed", 0, min=0, max=2**31 - 1, step=1, visible=False)
            self.load_button = gui.add_button("Load terrain", icon=viser.Icon.UPLOAD)
        with gui.add_folder("Record", order=60, expand_by_default=False):
            self.record_button = gui.add_button("Start recording", icon=viser.Icon.PLAYER_RECORD, color="red")
            self.record_info = gui.add_markdown("Recordings are listed on the front page.")
        with gui.add_folder("Plots", order=30):
            self.gait_plot = gui.add_uplot(
                data=(np.zeros(2),) + (np.zeros(2),) * 8,
                series=(
                    uplot.Series(label="t [s]"),
                    *(
                        uplot.Series(
                            label=leg,
                            stroke=color,
                            width=0,
                            fill=_hex_rgba(color, 0.85),
                            fillTo=3 - i,
                            points={"show": False},
                        )
                        for i, (leg, color) in enumerate(zip(LEG_NAMES, LEG_COLORS, strict=True))
                    ),
                    *(
                        uplot.Series(
                            label=f"{leg} plan",
                            stroke=color,
                            width=0,
                            fill=_hex_rgba(color, 0.3),
                            fillTo=3 - i,
                            points={"show": False},
                        )
                        for i, (leg, color) in enumerate(zip(LEG_NAMES, LEG_COLORS, strict=True))
                    ),
                ),
                title="Gait schedule: FL FR HL HR top to bottom; bar = stance",
                scales={"x": uplot.Scale(time=False), "y": uplot.Scale(range=(-0.1, 4.0), auto=False)},
                legend=uplot.Legend(show=False),
                aspect=1.6,
            )
            self.timing_plot = gui.add_uplot(
                data=(np.zeros(1), np.zeros(1), np.zeros(1)),
                series=(
                    uplot.Series(label="t [s]"),
                    uplot.Series(label="planner ms", stroke="#e8590c", width=2),
                    uplot.Series(label="optimizer ms", stroke="#1c7ed6", width=2),
                ),
                title="Planner and optimizer time per plan [ms]",
                scales={"x": uplot.Scale(time=False), "y": uplot.Scale(auto=True)},
                aspect=1.6,
            )
        self._wire()

    def _terrain_options(self) -> tuple[str, ...]:
        names = self.terrains.store.names()
        return (*names, "random")

    # ---- wiring --------------------------------------------------------------------------------
    def _notify_error(self, client, title: str):
        def done(future: Future) -> None:
            exc = future.exception()
            if exc is not None and client is not None:
                client.add_notification(title, str(exc), color="red", auto_close_seconds=8.0)

        return done

    def _send(self, command, client=None, title: str = "Command failed") -> Future:
        future = self.session.submit(command)
        future.add_done_callback(self._notify_error(client, title))
        return future

    def _wire(self) -> None:
        def velocity(event) -> None:
            if event.client is not None:
                self._send(SetVelocity(self.vx.value, self.vy.value), event.client)

        self.vx.on_update(velocity)
        self.vy.on_update(velocity)
        self.stop_button.on_click(lambda e: self._set_velocity(0.0, 0.0, e.client))
        self.run_button.on_click(lambda e: self._toggle_pause(e.client))
        self.reset_button.on_click(lambda e: self._send(Reset(), e.client))
        self.recenter.on_click(lambda e: e.client is not None and self.camera.recenter(e.client))

        @self.shadows.on_update
        def _(event) -> None:
            self.server.scene.configure_default_lights(True, cast_shadow=bool(self.shadows.value))

        @self.speed.on_update
        def _(event) -> None:
            if event.client is not None:
                self._send(SetSpeed(float(self.speed.value)), event.client)

        @self.push_buttons.on_click
        def _(event) -> None:
            direction = {"+x": (1, 0), "-x": (-1, 0), "+y": (0, 1), "-y": (0, -1)}[self.push_buttons.value]
            f = float(self.push_force.value)
            self._send(
                ApplyPush(f * direction[0], f * direction[1], float(self.push_duration.value)),
                event.client,
                "Push failed",
            )

        @self.gait.on_update
        def _(event) -> None:
            if event.client is not None:
                self._send(SetGait(self.gait.value), event.client, "Gait change failed")

        @self.planner.on_update
        def _(event) -> None:
            if event.client is not None:
                self._send(SetPlanner(self.planner.value), event.client, "Planner change failed")

        @self.noise.on_update
        def _(event) -> None:
            if event.client is not None:
                self._send(SetNoise(bool(self.noise.value)), event.client)

        @self.terrain_pick.on_update
        def _(event) -> None:
            random = self.terrain_pick.value == "random"
            self.removed.visible = random
            self.seed.visible = random

        @self.load_button.on_click
        def _(event) -> None:
            name = self.terrain_pick.value
            try:
                if name == "random":
                    self.terrains.load("random", removed=int(self.removed.value), seed=int(self.seed.value))
                else:
                    self.terrains.load(name)
            except Exception as exc:  # noqa: BLE001 - shown to the user
                if event.client is not None:
                    event.client.add_notification(
                        "Terrain not loaded", str(exc), color="red", auto_close_seconds=8
                    )

        @self.record_button.on_click
        def _(event) -> None:
            try:
                if self.recorder.recording:
                    info = self.recorder.stop()
                    if event.client is not None:
                        event.client.add_notification(
                            "Recording saved",
                            f"{info.name} ({info.size_bytes / 1e6:.1f} MB): see the front page",
                            color="green",
                            auto_close_seconds=8,
                        )
                else:
                    self.recorder.start()
            except Exception as exc:  # noqa: BLE001 - shown to the user
                log.exception("recording failed")
                if event.client is not None:
                    event.client.add_notification("Recording", str(exc), color="red", auto_close_seconds=8)
            self._refresh_record_button()

        gui = self.server.gui
        shortcuts = (
            ("Faster forward", "I", lambda c: self._nudge(VELOCITY_STEP, 0.0, c)),
            ("Slower / backward", "K", lambda c: self._nudge(-VELOCITY_STEP, 0.0, c)),
            ("More to the left", "J", lambda c: self._nudge(0.0, VELOCITY_STEP, c)),
            ("More to the right", "L", lambda c: self._nudge(0.0, -VELOCITY_STEP, c)),
            ("Stop", "X", lambda c: self._set_velocity(0.0, 0.0, c)),
            ("Pause / run", "P", lambda c: self._toggle_pause(c)),
        )
        self.shortcuts: dict[str, viser.CommandHandle] = {}
        for label, key, action in shortcuts:
            command = gui.add_command(label, hotkey=key, description=f"key {key}")
            command.on_trigger(lambda event, action=action: action(event.client))
            self.shortcuts[key] = command

    def _set_velocity(self, vx: float, vy: float, client=None) -> None:
        vx = float(np.clip(round(vx, 3), -VELOCITY_LIMIT, VELOCITY_LIMIT))
        vy = float(np.clip(round(vy, 3), -VELOCITY_LIMIT, VELOCITY_LIMIT))
        self._send(SetVelocity(vx, vy), client)

    def _nudge(self, dvx: float, dvy: float, client=None) -> None:
        self._send(NudgeVelocity(dvx, dvy), client)  # relative: quick presses add up in the session

    def _toggle_pause(self, client=None) -> None:
        self._send(TogglePause(), client)  # decided by the session thread: quick presses alternate

    def _refresh_record_button(self) -> None:
        recording = self.recorder.recording
        self.record_button.label = "Stop recording" if recording else "Start recording"
        self.record_button.icon = viser.Icon.PLAYER_STOP if recording else viser.Icon.PLAYER_RECORD

    # ---- refresh from the session ------------------------------------------------------------------
    def _changed(self, key: str, value) -> bool:
        if self._seen.get(key, object()) == value:
            return False
        self._seen[key] = value
        return True

    def refresh(self, view: LiveView) -> None:
        s, snap = view.status, view.snapshot
        text = status_markdown(view)
        if self._changed("status", text):
            self.status.content = text
        vx, vy = snap.vel_cmd_xy
        if self._changed("vx", vx):
            self.vx.value = round(vx, 2)
        if self._changed("vy", vy):
            self.vy.value = round(vy, 2)
        for key, handle, value in (
            ("speed", self.speed, s.speed),
            ("gait", self.gait, s.gait),
            ("planner", self.planner, s.planner),
            ("noise", self.noise, s.noise),
        ):
            if self._changed(key, value):
                handle.value = value
        paused = s.paused or s.done is not None
        if self._changed("paused", (paused, s.done)):
            self.run_button.label = ("Run again" if s.done else "Run") if paused else "Pause"
            self.run_button.icon = viser.Icon.PLAYER_PLAY if paused else viser.Icon.PLAYER_PAUSE
        options = self._terrain_options()  # new files appear after "Save terrain" or a PUT
        if tuple(self.terrain_pick.options) != options:
            self.terrain_pick.options = options
        self._refresh_record_button()
        status = self.recorder.status()
        text = (
            f"**recording** {status['name']}: {status['duration_s']:.1f} s, {status['frames']} frames"
            if status["recording"]
            else (
                f"last saved: {status['last_saved']}"
                if status["last_saved"]
                else "Recordings are listed on the front page."
            )
        )
        if self._changed("record_info", text):
            self.record_info.content = text
        t, past, planned = gait_chart(view)
        base = 3.0 - np.arange(4)
        self.gait_plot.data = (t, *(base + 0.8 * past).T, *(base + 0.8 * planned).T)
        timing = view.timing
        if len(timing) and self._changed("timing", (len(timing), float(timing[-1, 0]))):
            self.timing_plot.data = (timing[:, 0].copy(), timing[:, 1].copy(), timing[:, 2].copy())
