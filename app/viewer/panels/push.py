"""The "Push" folder: push the base along +-x or +-y, or along any direction, with a force for a duration or with
an impulse."""

from __future__ import annotations

import math

import viser

from app.live.commands import ApplyPush
from app.live.session import LiveSession
from app.live.settings import PUSH_DURATION_LIMIT_S, PUSH_FORCE_LIMIT_N
from app.live.view import LiveView
from app.viewer.panels.common import submit
from contactnet.sim.world import IMPULSE_DURATION_S, Push

#: Push button -> unit direction in the world's xy plane.
DIRECTIONS = {"+x": (1, 0), "-x": (-1, 0), "+y": (0, 1), "-y": (0, -1)}
#: The "Along the direction" buttons: a force for the chosen duration, or an impulse over IMPULSE_DURATION_S.
ALONG = ("Force", "Impulse")
IMPULSE_LIMIT_NS = PUSH_FORCE_LIMIT_N * IMPULSE_DURATION_S


class PushPanel:
    """Force and duration sliders and one button per axis direction; a direction slider, an impulse slider and
    two buttons that push along that direction (the force for the duration, or the impulse)."""

    def __init__(self, gui: viser.GuiApi, session: LiveSession, order: float = 20.0):
        self.session = session
        with gui.add_folder("Push", order=order):
            self.push_force = gui.add_slider("Force [N]", 0.5, PUSH_FORCE_LIMIT_N, 0.5, 5.0)
            self.push_duration = gui.add_slider("Duration [s]", 0.1, PUSH_DURATION_LIMIT_S, 0.1, 1.0)
            self.push_buttons = gui.add_button_group("Push", tuple(DIRECTIONS))
            self.push_angle = gui.add_slider("Direction [deg]", -180.0, 180.0, 5.0, 90.0,
                                             hint="world frame: 0 = +x (forward at the start), 90 = +y (left)")
            self.push_impulse = gui.add_slider("Impulse [N s]", 0.05, IMPULSE_LIMIT_NS, 0.05, 1.0,
                                               hint=f"given as its force over {IMPULSE_DURATION_S:g} s; the velocity "
                                                    "change of the free body is impulse / mass")
            self.along_buttons = gui.add_button_group("Along it", ALONG)

        @self.push_buttons.on_click
        def _(event) -> None:
            direction = DIRECTIONS[self.push_buttons.value]
            f = float(self.push_force.value)
            self._submit(ApplyPush(f * direction[0], f * direction[1], float(self.push_duration.value)), event)

        @self.along_buttons.on_click
        def _(event) -> None:
            angle_rad = math.radians(float(self.push_angle.value))
            if self.along_buttons.value == "Impulse":
                push = Push.impulse(0.0, angle_rad, float(self.push_impulse.value))
            else:
                push = Push.at_angle(0.0, angle_rad, float(self.push_force.value), float(self.push_duration.value))
            self._submit(ApplyPush(push.force_world[0], push.force_world[1], push.duration_s), event)

    def _submit(self, command: ApplyPush, event) -> None:  # noqa: ANN001 - viser's click event
        submit(self.session, command, event.client, "Push failed")

    def refresh(self, view: LiveView) -> None:
        """Nothing to write back: pushes show in the status text."""
