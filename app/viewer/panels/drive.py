"""The "Drive" folder: commanded velocity, stop, pause/run, reset, looping runs, simulation speed and
shadows, and the keyboard shortcuts that drive the robot. (The camera has its own per-browser block:
`app/scene/camera.py`.)"""

from __future__ import annotations

import numpy as np
import viser

from app.live.commands import NudgeVelocity, Reset, SetLoop, SetSpeed, SetVelocity, TogglePause
from app.live.session import LiveSession
from app.live.settings import SIM_SPEED_RANGE, VELOCITY_LIMIT_M_S
from app.live.view import LiveView
from app.viewer.panels.common import ChangeTracker, SessionControls, submit

#: Velocity change of one key press (I/K, J/L), in m/s.
VELOCITY_STEP_M_S = 0.05


class DrivePanel:
    """Driving the robot: sliders, buttons and hotkeys (`shortcuts`, by key)."""

    def __init__(self, server: viser.ViserServer, session: LiveSession, order: float = 10.0):
        self.server = server
        self.session = session
        self._seen = ChangeTracker()
        self.controls = SessionControls(session, server.get_event_loop())
        gui = server.gui
        with gui.add_folder("Drive", order=order):
            self.vx = gui.add_slider("vx [m/s]", -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S, 0.01, 0.0)
            self.vy = gui.add_slider("vy [m/s]", -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S, 0.01, 0.0)
            self.stop_button = gui.add_button(
                "Stop (x)",
                icon=viser.Icon.HAND_STOP,
                hint="vx = vy = 0. Keys: I/K vx +-0.05, J/L vy +-0.05, X stop, P pause / run, R restart "
                "(W/A/S/D/Q/E and arrows move the camera; on the front page ? lists every key)",
            )
            self.run_button = gui.add_button("Pause", icon=viser.Icon.PLAYER_PAUSE)
            self.reset_button = gui.add_button("Reset", icon=viser.Icon.REFRESH, color="red")
            self.speed = gui.add_slider(
                "Sim speed",
                SIM_SPEED_RANGE[0],
                SIM_SPEED_RANGE[1],
                0.1,
                1.0,
                hint="simulated seconds per wall-clock second",
            )
            self.loop = gui.add_checkbox(
                "Loop runs", session.settings.loop,
                hint="After the goal or a fall, start another run a few seconds later",
            )
            self.shadows = gui.add_checkbox("Shadows", True, hint="Turn off for faster drawing without a GPU")
        self._wire()
        self.shortcuts = self._add_shortcuts()

    def _wire(self) -> None:
        controls = self.controls
        for key in ("vx", "vy", "speed", "loop"):
            controls.add(key, getattr(self, key))
        controls.on_change(("vx", "vy"), lambda: SetVelocity(self.vx.value, self.vy.value))
        controls.on_change(("speed",), lambda: SetSpeed(float(self.speed.value)))
        controls.on_change(("loop",), lambda: SetLoop(bool(self.loop.value)))
        self.stop_button.on_click(lambda e: self.set_velocity(0.0, 0.0, e.client))
        self.run_button.on_click(lambda e: self.run_or_pause(e.client))
        self.reset_button.on_click(lambda e: submit(self.session, Reset(), e.client))

        @self.shadows.on_update
        def _(event) -> None:
            self.server.scene.configure_default_lights(True, cast_shadow=bool(self.shadows.value))

    def _add_shortcuts(self) -> dict[str, viser.CommandHandle]:
        step = VELOCITY_STEP_M_S
        shortcuts = (
            ("Faster forward", "I", lambda c: self.nudge(step, 0.0, c)),
            ("Slower / backward", "K", lambda c: self.nudge(-step, 0.0, c)),
            ("More to the left", "J", lambda c: self.nudge(0.0, step, c)),
            ("More to the right", "L", lambda c: self.nudge(0.0, -step, c)),
            ("Stop", "X", lambda c: self.set_velocity(0.0, 0.0, c)),
            ("Pause / run", "P", lambda c: self.toggle_pause(c)),
            ("Restart the run", "R", lambda c: submit(self.session, Reset(), c)),
        )
        handles: dict[str, viser.CommandHandle] = {}
        for label, key, action in shortcuts:
            command = self.server.gui.add_command(label, hotkey=key, description=f"key {key}")
            command.on_trigger(lambda event, action=action: action(event.client))
            handles[key] = command
        return handles

    def set_velocity(self, vx: float, vy: float, client=None) -> None:  # noqa: ANN001
        vx = float(np.clip(round(vx, 3), -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S))
        vy = float(np.clip(round(vy, 3), -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S))
        submit(self.session, SetVelocity(vx, vy), client)

    def nudge(self, dvx: float, dvy: float, client=None) -> None:  # noqa: ANN001
        submit(self.session, NudgeVelocity(dvx, dvy), client)  # relative: quick presses add up in the session

    def toggle_pause(self, client=None) -> None:  # noqa: ANN001
        """The P key: decided by the session thread (quick presses alternate); at the end of a run it holds the
        loop's count-down, never starts the next run."""
        submit(self.session, TogglePause(), client)

    def run_or_pause(self, client=None) -> None:  # noqa: ANN001
        """The Pause / Run / Run again button: "Run again" (a finished run, nothing counting down) restarts."""
        view = self.session.view
        if view is not None and view.status.done is not None and view.run.restart_in_s is None and not view.status.paused:
            submit(self.session, Reset(), client)
        else:
            self.toggle_pause(client)

    def refresh(self, view: LiveView) -> None:
        s, snap = view.status, view.snapshot
        vx, vy = snap.vel_cmd_xy
        for key, value in (("vx", round(vx, 2)), ("vy", round(vy, 2)), ("speed", s.speed), ("loop", view.run.loop)):
            self.controls.show(key, value, view.seq)
        again = s.done is not None and view.run.restart_in_s is None and not s.paused  # nothing counts down
        paused = s.paused or again
        if self._seen.changed("paused", (paused, again)):
            self.run_button.label = ("Run again" if again else "Run") if paused else "Pause"
            self.run_button.icon = viser.Icon.PLAYER_PLAY if paused else viser.Icon.PLAYER_PAUSE
