"""Terrain editing in the 3D view, and the terrain service the GUI and REST share.

`TerrainService` holds the session's terrain as a dict with an undo history, applies edits (the
pure functions of `app/editor.py`), loads and saves files through a `TerrainStore`, and hands
every new terrain to the live session (whose thread rebuilds its Simulator with it).

`EditorPanel` is the viser side: a "Terrain editor" folder (click tool, undo, delete, save,
upload) and the 3D interaction. viser 1.1's `scene.on_click` gives a ray; we intersect it with
the plane z = surface_z on the server. Selected stones get transform controls (move in x, y and
turn about z); releasing them moves the stone.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from app import editor
from app.editor import EditError, EditHistory, TerrainStore
from app.live import LiveSession, SetTerrain
from contactnet.terrain import Terrain, TerrainError, by_name, random_field

log = logging.getLogger("contactnet.app.editing")

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


class TerrainService:
    """The session's terrain: current dict, undo, files, and handing terrains to the session."""

    def __init__(self, session: LiveSession, store: TerrainStore, initial: Terrain, label: str):
        self.session = session
        self.store = store
        self._lock = threading.RLock()
        self.history = EditHistory(initial.to_dict())
        self.label = label
        self.base_label = label
        self.version = 0
        self._listeners: list[Callable[[], None]] = []

    def on_change(self, callback: Callable[[], None]) -> None:
        self._listeners.append(callback)

    @property
    def current(self) -> dict[str, Any]:
        """The current terrain dict; waits for a change in progress (the session may already show
        a new terrain while its history is being updated)."""
        with self._lock:
            return self.history.current

    def _send(self, terrain: Terrain, label: str, timeout: float, commit: Callable[[], Any]) -> None:
        """Hand ``terrain`` to the session; once it took it, ``commit`` the history, then tell listeners
        (which see the new history)."""
        self.session.call(SetTerrain(terrain, label), timeout=timeout)
        commit()
        self.label = label
        self.version += 1
        for callback in self._listeners:
            try:
                callback()
            except Exception:  # noqa: BLE001 - a listener must not break editing
                log.exception("terrain listener failed")

    # ---- loading ------------------------------------------------------------------------------------
    def load(self, name: str, removed: int | None = None, seed: int = 0, timeout: float = 60.0) -> Terrain:
        """Switch the session to a named terrain: a file in the store, a generator name, or 'random'."""
        with self._lock:
            if name == "random":
                if removed is None:
                    raise EditError("random terrain needs 'removed' (0..300)")
                try:
                    terrain = random_field(removed, seed)
                except TerrainError as exc:
                    raise EditError(str(exc)) from None
                label = f"random (removed {removed}, seed {seed})"
            elif name in self.store.names():
                terrain, label = self.store.load(name), name
            else:  # a generator of a shipped terrain (flat, stepping_stones, ...) without its file
                editor.validate_name(name)
                try:
                    terrain = by_name(name)
                except TerrainError as exc:
                    raise FileNotFoundError(f"no terrain named {name!r}") from exc
                label = name
            self._send(terrain, label, timeout, lambda: self._reset(terrain, label))
            return terrain

    def _reset(self, terrain: Terrain, label: str) -> None:
        self.history.reset(terrain.to_dict())
        self.base_label = label

    def load_dict(self, data: dict[str, Any], label: str, timeout: float = 60.0) -> Terrain:
        """Switch the session to an uploaded terrain dict (validated; nothing changes if invalid)."""
        with self._lock:
            terrain = editor.to_terrain(data, source=label)
            self._send(terrain, label, timeout, lambda: self._reset(terrain, label))
            return terrain

    # ---- editing -----------------------------------------------------------------------------------
    def edit(self, function: Callable[..., dict[str, Any]], *args: Any, timeout: float = 60.0) -> bool:
        """Apply `function(current, *args)`; False when it changed nothing."""
        with self._lock:
            new = function(self.history.current, *args)
            if new == self.history.current:
                return False
            terrain = editor.to_terrain(new)
            self._send(terrain, f"{self.base_label} (edited)", timeout, lambda: self.history.apply(new))
            return True

    def undo(self, timeout: float = 60.0) -> None:
        with self._lock:
            previous = self.history.previous
            self._send(editor.to_terrain(previous), f"{self.base_label} (edited)", timeout, self.history.undo)

    def save(self, name: str, overwrite: bool = False) -> str:
        with self._lock:
            path = self.store.save(self.history.current, name, overwrite=overwrite)
            self.base_label = name
            self.label = name
            return str(path)


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
        self.info.content = f"{n} regions · undo {'available' if self.terrains.history.can_undo else '—'}"

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

        def load() -> None:
            data = editor.parse_upload(uploaded.content, source=name)
            self.terrains.load_dict(data, label=f"{data['name']} (uploaded)")
            self._notify(event.client, "Terrain loaded", f"{name}: {len(data['regions'])} regions")

        self._run(event.client, "Upload terrain", load)
