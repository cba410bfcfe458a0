"""The "Terrain editor" folder and the 3D interaction that edits the session's terrain.

A click tool (punch or fill a hole, add a stone, select one), undo, delete, save and upload. viser
1.1's `scene.on_click` gives a ray; we intersect it with the plane z = surface_z on the server.
Selected stones get transform controls (move in x, y and turn about z); releasing them moves the
stone. Every change goes through the `TerrainService` (and from there to the live session).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from app import editor
from app.editing import TerrainService
from app.editor import EditError
from app.terrain_files import validate_upload
from app.view import LiveView
from contactnet.terrain import TerrainError

log = logging.getLogger("contactnet.app.panels.terrain_editor")

TOOLS = ("off", "punch hole", "fill hole", "add rect", "add circle", "add star", "select stone")


def ray_to_plane(origin, direction, z: float) -> tuple[float, float] | None:
    """XY where the ray origin + s * direction (s > 0) meets the plane at height z, or None."""
    origin, direction = np.asarray(origin, float), np.asarray(direction, float)
    if not (np.all(np.isfinite(origin)) and np.all(np.isfinite(direction))) or abs(direction[2]) < 1e-9:
        return None
    s = (z - origin[2]) / direction[2]
    if s <= 0:
        return None
    point = origin + s * direction
    return float(point[0]), float(point[1])



class EditorPanel:
    """The terrain editor in the viser GUI and 3D view."""

    def __init__(self, server: viser.ViserServer, terrains: TerrainService, order: float = 50.0):
        self.server = server
        self.terrains = terrains
        self._selected: int | None = None
        self._gizmo: viser.TransformControlsHandle | None = None
        gui = server.gui
        with gui.add_folder("Terrain editor", order=order, expand_by_default=False):
            self.tool = gui.add_dropdown(
                "Click tool", TOOLS, initial_value="off", hint="What a click on the terrain does"
            )
            self.info = gui.add_markdown("Pick a tool, then click the terrain.")
            self.undo_button = gui.add_button("Undo", icon=viser.Icon.ARROW_BACK_UP)
            self.delete_button = gui.add_button("Delete selected stone", icon=viser.Icon.TRASH, disabled=True)
            self.name = gui.add_text("Save as", initial_value="my_terrain", hint="letters, digits, _ and -")
            self.overwrite = gui.add_checkbox(
                "Overwrite shipped file", False, hint="Needed to replace flat, stepping_stones, ..."
            )
            self.save_button = gui.add_button("Save terrain", icon=viser.Icon.DEVICE_FLOPPY)
            self.upload = gui.add_upload_button(
                "Upload terrain JSON", icon=viser.Icon.UPLOAD, mime_type="application/json"
            )
        self.undo_button.on_click(self._on_undo)
        self.delete_button.on_click(self._on_delete)
        self.save_button.on_click(self._on_save)
        self.upload.on_upload(self._on_upload)
        self.tool.on_update(self._on_tool)
        server.scene.on_click()(self._on_click)
        terrains.on_change(self._clear_selection)

    # ---- helpers --------------------------------------------------------------------------------
    @staticmethod
    def _notify(client, title: str, body: str, error: bool = False) -> None:
        if client is not None:
            client.add_notification(title, body, color="red" if error else "green", auto_close_seconds=6.0)

    def _run(self, client, title: str, action: Callable[[], Any]) -> Any:
        try:
            return action()
        except (EditError, TerrainError, ValueError, FileNotFoundError) as exc:
            self._notify(client, title, str(exc), error=True)
        except Exception as exc:  # noqa: BLE001 - show it, keep the server alive
            log.exception("%s failed", title)
            self._notify(client, title, f"failed: {exc}", error=True)
        return None

    def _clear_selection(self) -> None:
        self._selected = None
        if self._gizmo is not None:
            self._gizmo.remove()
            self._gizmo = None
        self.delete_button.disabled = True
        n = len(self.terrains.current["regions"])
        self.info.content = f"{n} regions · undo {'available' if self.terrains.can_undo else '—'}"

    # ---- callbacks --------------------------------------------------------------------------------
    def _on_tool(self, event) -> None:
        if self.tool.value != "select stone":
            self._clear_selection()

    def _on_click(self, event: viser.SceneClickEvent) -> None:
        tool = self.tool.value
        if tool == "off":
            return
        z = float(self.terrains.current.get("surface_z", 0.0))
        xy = ray_to_plane(event.ray_origin, event.ray_direction, z)
        if xy is None:
            return
        client = event.client
        if tool == "punch hole":
            self._run(client, "Punch hole", lambda: self.terrains.edit(editor.punch_hole, xy))
        elif tool == "fill hole":
            self._run(client, "Fill hole", lambda: self.terrains.edit(editor.fill_hole, xy))
        elif tool.startswith("add "):
            self._run(client, "Add stone", lambda: self.terrains.edit(editor.add_stone, tool[4:], xy))
        elif tool == "select stone":
            self._select(editor.region_at(self.terrains.current, xy))

    def _select(self, index: int | None) -> None:
        self._clear_selection()
        if index is None:
            return
        region = self.terrains.current["regions"][index]
        (x, y), yaw = editor.region_pose(region)
        z = float(self.terrains.current.get("surface_z", 0.0)) + 0.01
        self._selected = index
        self._gizmo = self.server.scene.add_transform_controls(
            "/editor/gizmo",
            scale=0.15,
            active_axes=(True, True, False),
            disable_sliders=True,
            rotation_limits=((0.0, 0.0), (0.0, 0.0), (-1000.0, 1000.0)),
            depth_test=False,
            position=(x, y, z),
            wxyz=(math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)),
        )
        self._gizmo.on_update(self._on_moved)
        self.delete_button.disabled = False
        self.info.content = f"Selected region {index} ({region['shape']}): drag the gizmo, or delete it."

    def _on_moved(self, event) -> None:
        gizmo, index = self._gizmo, self._selected
        if event.phase != "end" or gizmo is None or index is None:
            return
        w, _, _, z = gizmo.wxyz
        yaw = 2.0 * math.atan2(z, w)
        xy = (float(gizmo.position[0]), float(gizmo.position[1]))
        if self._run(
            event.client, "Move stone", lambda: self.terrains.edit(editor.move_region, index, xy, yaw)
        ):
            self._select(index)

    def _on_delete(self, event) -> None:
        index = self._selected
        if index is not None:
            self._run(event.client, "Delete stone", lambda: self.terrains.edit(editor.delete_region, index))

    def _on_undo(self, event) -> None:
        self._run(event.client, "Undo", self.terrains.undo)

    def _on_save(self, event) -> None:
        name, overwrite = self.name.value.strip(), self.overwrite.value
        path = self._run(event.client, "Save terrain", lambda: self.terrains.save(name, overwrite))
        if path:
            self._notify(event.client, "Saved", f"terrain saved to {path}")
            self.overwrite.value = False

    def _on_upload(self, event) -> None:
        uploaded = self.upload.value
        name = uploaded.name

        def load() -> None:  # strict JSON, validated once (app/terrain_files.py)
            terrain = validate_upload(uploaded.content, source=name)
            self.terrains.load_terrain(terrain, label=f"{terrain.name} (uploaded)")
            self._notify(event.client, "Terrain loaded", f"{name}: {len(terrain.regions)} regions")

        self._run(event.client, "Upload terrain", load)

    def refresh(self, view: LiveView) -> None:
        """Nothing to write back: the panel changes with the service's listeners."""
