"""The "Robot and planner" folder: which robot runs, its gait, the contact planner, the physics engine, joint-velocity noise,
swing retargeting and the disturbance observer (on or off without a restart), and compare mode (a second robot with another planner on the same terrain, drawn as a ghost)."""

from __future__ import annotations

import asyncio

import viser

from app.live.commands import SetCompare, SetGait, SetNoise, SetObserver, SetPlanner, SetRetarget, SetSim
from app.live.session import LiveSession
from app.live.view import LiveView
from app.viewer.panels.common import ChangeTracker, SessionControls, submit
from contactnet import registry
from contactnet.sim.world import ENGINES, engine_installed

RETARGET_HINT = (
    "During a swing, when a push throws the robot off its command, rank the swinging legs' landings again and "
    "move the swing to the new one (it flashes in the 3D view). ContactNet and fixed planners; no restart."
)
OBSERVER_HINT = (
    "Estimate a push from the body's momentum: the feet push against it and the next step leans into it "
    "(the disturbance observer; no restart)."
)
SIM_HINT = "The physics engine the robot runs in (the same robot, terrain and controller; the robot restarts)"
COMPARE_HINT = "A second robot with this planner walks the same terrain with the same command (a teal ghost)"


def compare_label(comparing: bool, other: str) -> str:
    """The compare button's label: what pressing it does."""
    return "Stop comparing" if comparing else f"Compare with {other}"


class GaitPlannerPanel:
    """Gait and planner dropdowns (the registry's names) and the noise switch, each restarting the robot; the
    retarget switch (no restart)."""

    def __init__(self, gui: viser.GuiApi, session: LiveSession, loop: asyncio.AbstractEventLoop, order: float = 40.0):
        """``loop``: the viser server's event loop (`SessionControls`)."""
        self.session = session
        self._seen = ChangeTracker()
        self.controls = SessionControls(session, loop)
        settings = session.settings
        spec = registry.robot_spec(settings.robot)
        with gui.add_folder("Robot and planner", order=order):
            self.robot = gui.add_markdown(
                f"Robot **{spec.name}**" + (f" ({spec.description})" if spec.description else "")
            )
            self.gait = gui.add_dropdown("Gait", registry.gait_names(), initial_value=settings.gait)
            self.planner = gui.add_dropdown("Planner", registry.planner_names(), initial_value=settings.planner)
            engines = tuple(e for e in ENGINES if engine_installed(e) or e == settings.sim)
            self.sim = gui.add_dropdown("Physics", engines, initial_value=settings.sim, hint=SIM_HINT)
            self.noise = gui.add_checkbox(
                "Joint-velocity noise", settings.noise, hint="Gaussian, variance 0.01 (rad/s)^2"
            )
            self.retarget = gui.add_checkbox("Retarget swings", settings.retarget, hint=RETARGET_HINT)
            self.observer = gui.add_checkbox("Resist pushes", settings.observer, hint=OBSERVER_HINT)
            others = self._others(settings.planner)
            self.compare_with = gui.add_dropdown(
                "Compare with", others, initial_value="fixed" if "fixed" in others else others[0], hint=COMPARE_HINT
            )
            self.compare_button = gui.add_button(
                compare_label(False, self.compare_with.value), icon=viser.Icon.ARROWS_SPLIT, hint=COMPARE_HINT
            )
            self.side_by_side = gui.add_checkbox(
                "Side by side", False, hint="compare mode: the other robot walks a copy of the terrain beside this one "
                "(a split view) instead of a ghost over the same terrain; the 3D view only, the runs are the same"
            )
        self._comparing = False

        controls = self.controls
        for key in ("gait", "planner", "sim", "noise", "retarget", "observer"):
            controls.add(key, getattr(self, key))
        controls.on_change(("gait",), lambda: SetGait(self.gait.value), "Gait change failed")
        controls.on_change(("planner",), lambda: SetPlanner(self.planner.value), "Planner change failed")
        controls.on_change(("sim",), lambda: SetSim(self.sim.value), "Engine change failed")
        controls.on_change(("noise",), lambda: SetNoise(bool(self.noise.value)))
        controls.on_change(("retarget",), lambda: SetRetarget(bool(self.retarget.value)))
        controls.on_change(("observer",), lambda: SetObserver(bool(self.observer.value)))

        @self.compare_with.on_update
        def _(event) -> None:
            self.compare_button.label = compare_label(self._comparing, self.compare_with.value)

        @self.compare_button.on_click
        def _(event) -> None:
            planners = () if self._comparing else (self.planner.value, self.compare_with.value)
            submit(self.session, SetCompare(planners), event.client, "Compare mode failed")

    @staticmethod
    def _others(planner: str) -> tuple[str, ...]:
        names = registry.planner_names()
        return tuple(n for n in names if n != planner) or names

    def refresh(self, view: LiveView) -> None:
        s = view.status
        for key, value in (("gait", s.gait), ("planner", s.planner), ("sim", s.sim), ("noise", s.noise),
                           ("retarget", s.retarget), ("observer", s.observer)):
            self.controls.show(key, value, view.seq)
        others = self._others(s.planner)
        if tuple(self.compare_with.options) != others:
            self.compare_with.options = others  # viser keeps the value if it is still an option
        comparing = bool(view.compare)
        label = compare_label(comparing, self.compare_with.value)
        if self._seen.changed("compare", (comparing, label)):
            self._comparing = comparing
            self.compare_button.label = label
            self.compare_button.color = "teal" if comparing else None
