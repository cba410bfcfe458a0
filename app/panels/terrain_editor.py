"""The "Terrain editor" folder and the 3D interaction that edits the session's terrain.

A click tool (punch or fill a hole, add a stone, select one), undo, redo, delete, save and upload.
viser 1.1's `scene.on_click` gives a ray; we intersect it with the plane z = surface_z on the server.
Selected stones get transform controls (move in x, y and turn about z); releasing them moves the
stone. Every change goes through the `TerrainService` (and from there to the live session).

Every click says what it did (the info line), and a click that changes nothing says why in a toast
("no stone here: click on a stone or a grid cell"). Saving over an existing terrain (the user's own
file, or a shipped name) asks first: the save button turns into "Overwrite NAME?" with a Cancel, and
only that second press writes. The "Save as" field follows the session's terrain name (after a save,
a load or an upload).
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
        self._pending_save: str | None = None  # the name an "Overwrite NAME?" press would write
        self._label: str | None = None
        with gui.add_folder("Terrain editor", order=order, expand_by_default=False):
            self.tool = gui.add_dropdown(
                "Click tool", TOOLS, initial_value="off",
                hint="What a click on the terrain does (the Top-down camera helps)",
            )
            self.info = gui.add_markdown("Pick a tool, then click the terrain.")
            self.history_buttons = gui.add_button_group("Edits", ("Undo", "Redo"))
            self.delete_button = gui.add_button("Delete selected stone", icon=viser.Icon.TRASH, disabled=True)
            self.name = gui.add_text("Save as", initial_value="my_terrain", hint="letters, digits, _ and -")
            self.save_button = gui.add_button("Save terrain", icon=viser.Icon.DEVICE_FLOPPY)
            self.cancel_button = gui.add_button("Cancel", icon=viser.Icon.X, visible=False)
            self.upload = gui.add_upload_button(
                "Upload terrain JSON", icon=viser.Icon.UPLOAD, mime_type="application/json"
            )
        self.history_buttons.on_click(self._on_history)
        self.delete_button.on_click(self._on_delete)
        self.save_button.on_click(self._on_save)
        self.cancel_button.on_click(lambda event: self._end_confirm() or self._say("Not saved."))
        self.name.on_update(lambda event: self._end_confirm())
        self.upload.on_upload(self._on_upload)
        self.tool.on_update(self._on_tool)
        server.scene.on_click()(self._on_click)
        terrains.on_change(self._changed)

    # ---- helpers --------------------------------------------------------------------------------
    @staticmethod
    def _notify(client, title: str, body: str, error: bool = False, color: str | None = None) -> None:
        if client is not None:
            client.add_notification(
                title, body, color=color or ("red" if error else "green"), auto_close_seconds=6.0 if error else 4.0
            )

    def _run(self, client, title: str, action: Callable[[], Any]) -> Any:
        try:
            return action()
        except (EditError, TerrainError, ValueError, FileNotFoundError) as exc:
            self._say(f"**{title}**: {exc}")
            self._notify(client, title, str(exc), error=True)
        except Exception as exc:  # noqa: BLE001 - show it, keep the server alive
            log.exception("%s failed", title)
            self._notify(client, title, f"failed: {exc}", error=True)
        return None

    def _say(self, text: str) -> None:
        self.info.content = text

    def _summary(self) -> str:
        n = len(self.terrains.current["regions"])
        undo = "undo" if self.terrains.can_undo else ""
        redo = "redo" if self.terrains.can_redo else ""
        available = " and ".join(x for x in (undo, redo) if x)
        return f"{n} regions · {available + ' available' if available else 'no edits to undo'}"

    def _clear_selection(self) -> None:
        self._selected = None
        if self._gizmo is not None:
            self._gizmo.remove()
            self._gizmo = None
        self.delete_button.disabled = True

    def _changed(self) -> None:
        """The service changed the terrain (an edit, undo, redo, load)."""
        self._clear_selection()

    # ---- callbacks --------------------------------------------------------------------------------
    def _on_tool(self, event) -> None:
        if self.tool.value != "select stone":
            self._clear_selection()
        hints = {
            "off": "Clicks on the terrain do nothing.",
            "punch hole": "Click on a stone or a grid cell to cut a 5 cm square out of it.",
            "fill hole": "Click in a hole to fill it (a removed grid cell comes back, else a 5 cm square is added).",
            "select stone": "Click on a stone to select it, then drag the gizmo or delete it.",
        }
        self._say(hints.get(self.tool.value, f"Click where the new {self.tool.value[4:]} should go."))

    def _on_click(self, event: viser.SceneClickEvent) -> None:
        tool = self.tool.value
        if tool == "off":
            return
        client = event.client
        z = float(self.terrains.current.get("surface_z", 0.0))
        xy = ray_to_plane(event.ray_origin, event.ray_direction, z)
        if xy is None:
            self._miss(client, "That click does not reach the ground: click on the terrain.")
            return
        at = f"({xy[0]:.2f}, {xy[1]:.2f})"
        if tool == "punch hole":
            if self._run(client, "Punch hole", lambda: self.terrains.edit(editor.punch_hole, xy)):
                self._say(f"Hole punched at {at} · {self._summary()}")
            elif editor.region_at(self.terrains.current, xy) is None:
                self._miss(client, f"No stone here {at}: click on a stone or a grid cell.")
        elif tool == "fill hole":
            if self._run(client, "Fill hole", lambda: self.terrains.edit(editor.fill_hole, xy)):
                self._say(f"Hole filled at {at} · {self._summary()}")
            else:
                self._miss(client, f"No hole here {at}: the ground is already steppable.")
        elif tool.startswith("add "):
            if self._run(client, "Add stone", lambda: self.terrains.edit(editor.add_stone, tool[4:], xy)):
                self._say(f"Added a {tool[4:]} at {at} · {self._summary()}")
        elif tool == "select stone":
            index = editor.region_at(self.terrains.current, xy)
            if index is None:
                self._clear_selection()
                self._miss(client, f"No stone here {at}: click on a stone to select it.")
            else:
                self._select(index)

    def _miss(self, client, text: str) -> None:
        """A click that changed nothing: say why, in the panel and in a toast."""
        self._say(text)
        self._notify(client, "Nothing changed", text, color="yellow")

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
        self._say(f"Selected region {index} ({region['shape']}): drag the gizmo, or delete it.")

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
            self._say(f"Moved region {index} to ({xy[0]:.2f}, {xy[1]:.2f}) · {self._summary()}")

    def _on_delete(self, event) -> None:
        index = self._selected
        if index is not None and self._run(
            event.client, "Delete stone", lambda: self.terrains.edit(editor.delete_region, index)
        ):
            self._say(f"Deleted region {index} · {self._summary()}")

    def _on_history(self, event) -> None:
        undo = self.history_buttons.value == "Undo"
        action = self.terrains.undo if undo else self.terrains.redo
        done = self._run(event.client, "Undo" if undo else "Redo", lambda: action() or True)
        if done:
            self._say(f"{'Undone' if undo else 'Redone'} · {self._summary()}")

    # ---- saving --------------------------------------------------------------------------------
    def _on_save(self, event) -> None:
        name = self.name.value.strip()
        confirmed = self._pending_save == name
        self._end_confirm()
        if not confirmed:
            exists = self._run(event.client, "Save terrain", lambda: self.terrains.exists(name) or "")
            if exists is None:
                return  # a bad name: said so
            if exists:
                self._ask_overwrite(name, exists)
                return
        path = self._run(event.client, "Save terrain", lambda: self.terrains.save(name, overwrite=confirmed))
        if path:
            self._notify(event.client, "Saved", f"terrain saved as {name} ({path})")
            self._say(f"Saved as **{name}**.")

    def _ask_overwrite(self, name: str, exists: str) -> None:
        self._pending_save = name
        self.save_button.label = f"Overwrite {name}?"
        self.save_button.color = "red"
        self.cancel_button.visible = True
        if exists == "yours":
            text = f"**{name}** is one of your saved terrains: press *Overwrite {name}?* to replace it, or Cancel."
        else:
            text = (f"**{name}** is a shipped terrain: saving keeps the shipped file and saves your own copy under "
                    f"that name. Press *Overwrite {name}?* to go on, or Cancel.")
        self._say(text)

    def _end_confirm(self) -> None:
        if self._pending_save is None:
            return
        self._pending_save = None
        self.save_button.label = "Save terrain"
        self.save_button.color = None
        self.cancel_button.visible = False

    def _on_upload(self, event) -> None:
        uploaded = self.upload.value
        name = uploaded.name

        def load() -> None:  # strict JSON, validated once (app/terrain_files.py)
            terrain = validate_upload(uploaded.content, source=name)
            self.terrains.load_terrain(terrain, label=f"{terrain.name} (uploaded)")
            self._notify(event.client, "Terrain loaded", f"{name}: {len(terrain.regions)} regions")

        self._run(event.client, "Upload terrain", load)

    def refresh(self, view: LiveView) -> None:
        """The "Save as" field follows the session's terrain name (a file or generator name, not a label
        like "random (...)" or "x (uploaded)"); "(edited)" is dropped."""
        label = view.status.terrain
        if label == self._label:
            return
        self._label = label
        name = label.removesuffix(" (edited)")
        try:
            editor.validate_name(name)
        except EditError:
            return
        if self.name.value != name:
            self.name.value = name
            self._end_confirm()
