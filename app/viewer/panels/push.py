"""The "Push" folder: push the base along +-x or +-y with a chosen force and duration."""

from __future__ import annotations

import viser

from app.live.commands import ApplyPush
from app.live.session import LiveSession
from app.live.settings import PUSH_DURATION_LIMIT_S, PUSH_FORCE_LIMIT_N
from app.live.view import LiveView
from app.viewer.panels.common import submit

#: Push button -> unit direction in the world's xy plane.
DIRECTIONS = {"+x": (1, 0), "-x": (-1, 0), "+y": (0, 1), "-y": (0, -1)}


class PushPanel:
    """Force and duration sliders and one button per direction."""

    def __init__(self, gui: viser.GuiApi, session: LiveSession, order: float = 20.0):
        self.session = session
        with gui.add_folder("Push", order=order):
            self.push_force = gui.add_slider("Force [N]", 0.5, PUSH_FORCE_LIMIT_N, 0.5, 5.0)
            self.push_duration = gui.add_slider("Duration [s]", 0.1, PUSH_DURATION_LIMIT_S, 0.1, 1.0)
            self.push_buttons = gui.add_button_group("Push", tuple(DIRECTIONS))

        @self.push_buttons.on_click
        def _(event) -> None:
            direction = DIRECTIONS[self.push_buttons.value]
            f = float(self.push_force.value)
            submit(
                self.session,
                ApplyPush(f * direction[0], f * direction[1], float(self.push_duration.value)),
                event.client,
                "Push failed",
            )

    def refresh(self, view: LiveView) -> None:
        """Nothing to write back: pushes show in the status text."""
