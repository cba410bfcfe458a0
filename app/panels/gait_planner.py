"""The "Robot and planner" folder: which robot runs, its gait, the contact planner, joint-velocity noise,
and the legend of the 3D view's markers."""

from __future__ import annotations

import viser

from app.commands import SetGait, SetNoise, SetPlanner
from app.live import LiveSession
from app.panels.common import ChangeTracker, submit
from app.view import LiveView
from contactnet import registry

LEGEND = (
    "Disks: candidate footholds, **green** = best-ranked safe, fading to grey down the "
    "ranking; **red** = unsafe; **gold** = chosen. Orange balls: the next 3 steps. "
    "Lines: planned CoM (blue), actual CoM (purple), foot forces (dark blue), push (red)."
)


class GaitPlannerPanel:
    """Gait and planner dropdowns (the registry's names) and the noise switch; each restarts the robot."""

    def __init__(self, gui: viser.GuiApi, session: LiveSession, order: float = 40.0):
        self.session = session
        self._seen = ChangeTracker()
        settings = session.settings
        spec = registry.robot_spec(settings.robot)
        with gui.add_folder("Robot and planner", order=order):
            self.robot = gui.add_markdown(
                f"Robot **{spec.name}**" + (f" ({spec.description})" if spec.description else "")
            )
            self.gait = gui.add_dropdown("Gait", registry.gait_names(), initial_value=settings.gait)
            self.planner = gui.add_dropdown("Planner", registry.planner_names(), initial_value=settings.planner)
            self.noise = gui.add_checkbox(
                "Joint-velocity noise", settings.noise, hint="Gaussian, variance 0.01 (rad/s)^2"
            )
            self.legend = gui.add_markdown(LEGEND)

        @self.gait.on_update
        def _(event) -> None:
            if event.client is not None:
                submit(self.session, SetGait(self.gait.value), event.client, "Gait change failed")

        @self.planner.on_update
        def _(event) -> None:
            if event.client is not None:
                submit(self.session, SetPlanner(self.planner.value), event.client, "Planner change failed")

        @self.noise.on_update
        def _(event) -> None:
            if event.client is not None:
                submit(self.session, SetNoise(bool(self.noise.value)), event.client)

    def refresh(self, view: LiveView) -> None:
        s = view.status
        for key, handle, value in (("gait", self.gait, s.gait), ("planner", self.planner, s.planner),
                                   ("noise", self.noise, s.noise)):
            if self._seen.changed(key, value):
                handle.value = value
