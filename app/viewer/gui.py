"""The viser control panel: the panels of `app/viewer/panels/`, top to bottom: status (one status line, the
run's state, progress toward the goal), legend, the per-browser camera block (`app/scene/camera.py`), driving,
pushes, plots, gait/planner/compare, terrain picker, terrain editor, recording; and the toasts of the
session's notices.

Every control only submits a command to the live session (never waits for it); `refresh(view)`
(called by the viewer's update loop a few times a second) writes the session's state back into
every panel, so changes made through REST or by another browser show up too. Values are written
back only when the session's value changed since the last refresh, so a slider being dragged
is not pulled back by a stale state.
"""

from __future__ import annotations

from typing import Protocol

import viser

from app.live.editing import TerrainService
from app.live.session import LiveSession
from app.live.view import LiveView
from app.recordings.live_recorder import LiveRecorder
from app.scene.camera import CameraControl
from app.scene.live_scene import LiveScene
from app.viewer.panels.drive import DrivePanel
from app.viewer.panels.gait_planner import GaitPlannerPanel
from app.viewer.panels.legend import LegendPanel
from app.viewer.panels.notices import NoticeToasts
from app.viewer.panels.plots import PlotsPanel
from app.viewer.panels.push import PushPanel
from app.viewer.panels.recording import RecordingPanel
from app.viewer.panels.status import StatusPanel
from app.viewer.panels.terrain import TerrainPanel
from app.viewer.panels.terrain_editor import EditorPanel


class Panel(Protocol):
    def refresh(self, view: LiveView) -> None: ...


class ControlPanel:
    """The control panel of the viser GUI (shared by all browsers, but for the camera block), top to
    bottom by `order`."""

    def __init__(
        self,
        server: viser.ViserServer,
        session: LiveSession,
        terrains: TerrainService,
        recorder: LiveRecorder,
        scene: LiveScene,
    ):
        self.server = server
        gui = server.gui
        gui.configure_theme(
            control_width="large",
            dark_mode=False,
            show_logo=False,
            show_share_button=False,  # no public relay link (app/security/guards.py)
            brand_color=(40, 90, 200),
        )
        self.status = StatusPanel(gui, order=0)
        self.legend = LegendPanel(gui, scene, order=1)
        self.camera = CameraControl(server, order=5)
        self.drive = DrivePanel(server, session, order=10)
        self.push = PushPanel(gui, session, order=20)
        self.plots = PlotsPanel(gui, order=30, leg_names=scene.leg_names)
        self.gait_planner = GaitPlannerPanel(gui, session, server.get_event_loop(), order=40)

        @self.gait_planner.side_by_side.on_update
        def _(event) -> None:
            scene.side_by_side = bool(self.gait_planner.side_by_side.value)

        self.terrain = TerrainPanel(gui, terrains, order=45)
        self.editor = EditorPanel(server, terrains, order=50)
        self.recording = RecordingPanel(gui, recorder, order=60, session=session)
        self.toasts = NoticeToasts(server)
        self.panels: tuple[Panel, ...] = (
            self.status,
            self.legend,
            self.drive,
            self.push,
            self.plots,
            self.gait_planner,
            self.terrain,
            self.editor,
            self.recording,
            self.toasts,
        )

    def observe(self, view: LiveView) -> None:
        """Every new view (the scene's rate): the plots' histories."""
        self.plots.observe(view)

    def refresh(self, view: LiveView) -> None:
        for panel in self.panels:
            panel.refresh(view)
