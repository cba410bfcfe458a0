"""The "Terrain editor" folder and the 3D interaction that edits the session's terrain.

A click tool (punch or fill a hole, add a stone, select one, raise or lower a grid cell by the "Cell step"),
undo, redo, delete, save and upload (a height map or mesh is previewed first: `terrain_import.py`). viser 1.1's `scene.on_click` gives a ray; the server finds where it
meets the terrain's tops (`app/scene/terrain_pick.py`: on a terrain with heights, the raised stone the user
sees, not the plane z = surface_z behind it). Selected stones get transform controls (move in x, y and
turn about z; releasing them moves the stone) and the "Stone height (cm)" slider and typed field (the
top relative to surface_z; the two stay in sync, each change is one edit). Every change goes through the
`TerrainService` (and from there to the live session).

Every click says what it did (the info line), and a click that changes nothing says why in a toast
("no stone here: click on a stone or a grid cell"). Saving over an existing terrain (the user's own
file, or a shipped name) asks first: the save button turns into "Overwrite NAME?" with a Cancel, and
only that second press writes. The "Save as" field follows the session's terrain name (after a save,
a load or an upload).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from typing import Any

import viser

from app.live import editor
from app.live.editing import TerrainService
from app.live.editor import EditError
from app.live.terrain_files import validate_upload
from app.live.view import LiveView
from app.scene.terrain_pick import ray_hit_xy, ray_to_plane
from app.viewer.panels.common import tell
from app.viewer.panels.terrain_import import ImportPreview
from contactnet.terrain import TerrainError
from contactnet.terrain.height_edits import cell_square, raise_cell, region_top_z, set_region_height

log = logging.getLogger("contactnet.app.panels.terrain_editor")

TOOLS = ("off", "punch hole", "fill hole", "add rect", "add circle", "add star", "select stone", "raise cell",
         "lower cell")
HEIGHT_RANGE_CM = 20.0  # the slider's range around surface_z (the typed field goes to the schema's bound)
__all__ = ["TOOLS", "EditorPanel", "ray_hit_xy", "ray_to_plane"]


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
        # One change of the selected stone at a time (height, move, delete: callbacks run in a pool), so that a
        # delete pressed while a move is applied deletes the moved stone, not nothing (the move re-selects it).
        self._selection_lock = threading.Lock()
        self._height_thread: int | None = None  # the thread applying a height change (keeps the selection)
        with gui.add_folder("Terrain editor", order=order, expand_by_default=False):
            self.tool = gui.add_dropdown(
                "Click tool", TOOLS, initial_value="off",
                hint="What a click on the terrain does (the Top-down camera helps)",
            )
            self.info = gui.add_markdown("Pick a tool, then click the terrain.")
            self.history_buttons = gui.add_button_group("Edits", ("Undo", "Redo"))
            self.cell_step = gui.add_number(
                "Cell step (cm)", initial_value=1.0, min=0.1, max=20.0, step=0.1, visible=False,
                hint="How much a click with 'raise cell' or 'lower cell' moves a grid cell's top",
            )
            self.delete_button = gui.add_button("Delete selected stone", icon=viser.Icon.TRASH, disabled=True)
            self.height_slider = gui.add_slider(
                "Stone height (cm)", min=-HEIGHT_RANGE_CM, max=HEIGHT_RANGE_CM, step=0.5, initial_value=0.0,
                visible=False, hint="The selected stone's top, above (+) or below (-) the terrain's surface_z",
            )
            self.height_number = gui.add_number(
                "Typed height (cm)", initial_value=0.0, step=0.1, visible=False,
                hint="The selected stone's top relative to surface_z, typed (within 50 cm)",
            )
            self.name = gui.add_text("Save as", initial_value="my_terrain", hint="letters, digits, _ and -")
            self.save_button = gui.add_button("Save terrain", icon=viser.Icon.DEVICE_FLOPPY)
            self.cancel_button = gui.add_button("Cancel", icon=viser.Icon.X, visible=False)
            self.upload = gui.add_upload_button(
                "Upload terrain JSON", icon=viser.Icon.UPLOAD, mime_type="application/json"
            )
            self.imports = ImportPreview(gui, terrains, self._run, self._say)
        self.history_buttons.on_click(self._on_history)
        self.height_slider.on_update(lambda event: self._on_height(self.height_slider, event))
        self.height_number.on_update(lambda event: self._on_height(self.height_number, event))
        self.delete_button.on_click(self._on_delete)
        self.save_button.on_click(self._on_save)
        self.cancel_button.on_click(lambda event: self._end_confirm() or self._say("Not saved."))
        self.name.on_update(lambda event: self._end_confirm())
        self.upload.on_upload(self._on_upload)
        self.tool.on_update(self._on_tool)
        server.scene.on_click()(self._on_click)
        terrains.on_change(self._changed)

    # ---- helpers --------------------------------------------------------------------------------
    def _notify(self, client, title: str, body: str, error: bool = False, color: str | None = None) -> None:
        """Tell the session's users (`tell`: the page's toasts); ``client`` and ``color`` are kept for callers."""
        tell(self.terrains.session, title, body, "error" if error else "warning" if color == "orange" else "info")

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
        self.height_slider.visible = False
        self.height_number.visible = False

    def _changed(self) -> None:
        """The service changed the terrain (an edit, undo, redo, load); a height change keeps the selection."""
        if self._height_thread != threading.get_ident():
            self._clear_selection()

    def _surface_z(self) -> float:
        return float(self.terrains.current.get("surface_z", 0.0))

    def _show_height(self, value_cm: float) -> None:
        """Both height widgets to ``value_cm`` (their callbacks see no client and apply nothing)."""
        self.height_number.value = round(value_cm, 2)
        self.height_slider.value = min(HEIGHT_RANGE_CM, max(-HEIGHT_RANGE_CM, round(value_cm, 2)))

    # ---- callbacks --------------------------------------------------------------------------------
    def _on_tool(self, event) -> None:
        if self.tool.value != "select stone":
            self._clear_selection()
        hints = {
            "off": "Clicks on the terrain do nothing.",
            "punch hole": "Click on a stone or a grid cell to cut a 5 cm square out of it.",
            "fill hole": "Click in a hole to fill it (a removed grid cell comes back, else a 5 cm square is added).",
            "select stone": "Click on a stone to select it, then drag the gizmo, set its height or delete it.",
            "raise cell": "Click on a grid cell (or a 5 cm square) to raise its top by the cell step.",
            "lower cell": "Click on a grid cell (or a 5 cm square) to lower its top by the cell step.",
        }
        self.cell_step.visible = self.tool.value in ("raise cell", "lower cell")
        self._say(hints.get(self.tool.value, f"Click where the new {self.tool.value[4:]} should go."))

    def _on_click(self, event: viser.SceneClickEvent) -> None:
        tool = self.tool.value
        if tool == "off":
            return
        client = event.client
        xy = ray_hit_xy(self.terrains.terrain, event.ray_origin, event.ray_direction)
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
        elif tool in ("raise cell", "lower cell"):
            self._on_cell(client, xy, tool == "raise cell")

    def _on_cell(self, client, xy: tuple[float, float], up: bool) -> None:
        """Raise or lower the grid cell under xy by the cell step; say where it went."""
        step_cm = float(self.cell_step.value)
        delta_m = (step_cm if up else -step_cm) / 100.0
        title = "Raise cell" if up else "Lower cell"
        found = self._run(client, title, lambda: cell_square(self.terrains.current, xy))
        if found is None:
            return
        index, (x0, y0, x1, y1) = found
        z_cm = 100.0 * (region_top_z(self.terrains.current, index) + delta_m - self._surface_z())
        centre = f"({(x0 + x1) / 2:.2f}, {(y0 + y1) / 2:.2f})"
        changed = self._run(client, title, lambda: self.terrains.edit(raise_cell, xy, delta_m))
        if changed:
            self._say(f"Cell {centre} {'raised' if up else 'lowered'} to {z_cm:+.1f} cm · {self._summary()}")
        elif changed is not None:
            self._miss(client, f"Cell {centre} unchanged: the cell step is 0.")

    def _miss(self, client, text: str) -> None:
        """A click that changed nothing: say why, in the panel and in a toast."""
        self._say(text)
        self._notify(client, "Nothing changed", text, color="yellow")

    def _select(self, index: int | None) -> None:
        self._clear_selection()
        if index is None:
            return
        data = self.terrains.current
        region = data["regions"][index]
        (x, y), yaw = editor.region_pose(region)
        top_cm = 100.0 * (region_top_z(data, index) - self._surface_z())
        z = region_top_z(data, index) + 0.01
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
        self._show_height(top_cm)
        self.height_slider.visible = True
        self.height_number.visible = True
        self._say(f"Selected region {index} ({region['shape']}, top {top_cm:+.1f} cm): drag the gizmo, set its "
                  "height, or delete it.")

    def _on_height(self, source: viser.GuiInputHandle, event) -> None:
        """The slider or the typed field changed (in a browser): put the selected stone's top there."""
        if event.client is None:  # set by the server (`_show_height`): nothing to apply
            return
        with self._selection_lock:
            index = self._selected
            if index is None:
                return
            value_cm = round(float(source.value), 2)  # the newest value: a stale callback applies nothing new
            self._show_height(value_cm)
            z_m = self._surface_z() + value_cm / 100.0
            self._height_thread = threading.get_ident()
            try:
                changed = self._run(event.client, "Stone height",
                                    lambda: self.terrains.edit(set_region_height, index, z_m))
            finally:
                self._height_thread = None
            data = self.terrains.current
            if changed is None:  # refused (said so): the widgets show the stone's height again
                self._show_height(100.0 * (region_top_z(data, index) - self._surface_z()))
                return
            if self._gizmo is not None:
                self._gizmo.position = (*self._gizmo.position[:2], region_top_z(data, index) + 0.01)
            if changed:
                shape = data["regions"][index]["shape"]
                self._say(f"Region {index} ({shape}) top set to {value_cm:+.1f} cm · {self._summary()}")

    def _on_moved(self, event) -> None:
        if event.phase != "end":
            return
        with self._selection_lock:
            gizmo, index = self._gizmo, self._selected
            if gizmo is None or index is None:
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
        with self._selection_lock:
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

        def load() -> None:  # strict JSON, validated once (app/live/terrain_files.py)
            terrain = validate_upload(uploaded.content, source=name)
            self.terrains.load_terrain(terrain, label=f"{terrain.name} (uploaded)")
            # (the session's own notice says it was loaded and the robot restarted)

        self._run(event.client, "Upload terrain", load)

    def refresh(self, view: LiveView) -> None:
        """The "Save as" field follows the session's terrain name (a file or generator name, not a label
        like "random (...)"); "(edited)", "(uploaded)" and "(imported)" are dropped, so an imported map is saved
        under its file's name (saving over an existing file asks first)."""
        label = view.status.terrain
        if label == self._label:
            return
        self._label = label
        name = label.removesuffix(" (edited)").removesuffix(" (uploaded)").removesuffix(" (imported)")
        try:
            editor.validate_name(name)
        except EditError:
            return
        if self.name.value != name:
            self.name.value = name
            self._end_confirm()
