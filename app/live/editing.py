"""The terrain service the GUI and REST share: load, edit, undo and save the live session's terrain.

The live session owns the current terrain (the `Terrain` it simulates, its dict form, the edit history
and the label: `app/live/session.py`); this service holds none of it. It turns a name (a file of its
`TerrainStore`, a shipped generator, or 'random') or an uploaded dict into a terrain, hands loads,
edits (the pure functions of `app/live/editor.py`), undos and redos to the session as commands, writes files, and
tells its listeners (the editor panel) after each change it made. Reads (`current`, `can_undo`,
`label`) come from the session's latest view.

The edit history lives with the terrain in the session (not here) because an edit and its history
entry must change together with what the session simulates: applied by one thread, published in one
view, they can never disagree (the service used to keep its own copy, which could lag the session).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from app.live import editor
from app.live.commands import EditTerrain, RedoTerrainEdit, RenameTerrain, SetTerrain, UndoTerrainEdit
from app.live.editor import EditError
from app.live.session import LiveSession
from app.live.terrain_files import TerrainLibrary, validate_upload
from app.live.view import LiveView
from contactnet.registry import ABSOLUTE_SCENES
from contactnet.terrain import Terrain, TerrainError, by_name, random_field, scaled

log = logging.getLogger("contactnet.app.editing")


class TerrainService:
    """Loading, editing and saving the live session's terrain (the session keeps it; see the module doc)."""

    def __init__(self, session: LiveSession, store: TerrainLibrary, scale: float = 1.0):
        """``scale``: the robot's size over Solo12's (`RobotDescription.size_scale`): the shipped scenes (files and
        generators, the random field) are built at the robot's size; the user's own files load as they are."""
        self.session = session
        self.store = store
        self.scale = scale
        self._lock = threading.RLock()  # one service operation at a time (save reads, then renames)
        self._listeners: list[Callable[[], None]] = []

    def on_change(self, callback: Callable[[], None]) -> None:
        self._listeners.append(callback)

    # ---- what the session has now ---------------------------------------------------------------------
    def _view(self) -> LiveView:
        view = self.session.view
        if view is None:
            raise RuntimeError("the live session is not running")
        return view

    @property
    def current(self) -> dict[str, Any]:
        """The session's current terrain dict (do not modify it)."""
        return self._view().terrain_dict

    @property
    def terrain(self) -> Terrain:
        """The session's current Terrain (the validated form of `current`)."""
        return self._view().terrain

    @property
    def can_undo(self) -> bool:
        return self._view().terrain_can_undo

    @property
    def can_redo(self) -> bool:
        return self._view().terrain_can_redo

    @property
    def label(self) -> str:
        """What the session calls its terrain: a file or generator name, '<name> (edited)', ..."""
        return self._view().status.terrain

    def _changed(self) -> None:
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
                    terrain = scaled(random_field(removed, seed), self.scale)
                except TerrainError as exc:
                    raise EditError(str(exc)) from None
                label = f"random (removed {removed}, seed {seed})"
            elif name in self.store.user.names():  # the user's own file, as it is
                terrain, label = self.store.load(name), name
            elif name in self.store.names():  # a shipped scene, at the robot's size
                terrain, label = self._at_robot_size(name, self.store.load(name)), name
            else:  # a generator of a shipped terrain (flat, stepping_stones, ...) without its file
                editor.validate_name(name)
                try:
                    terrain = self._at_robot_size(name, by_name(name))
                except TerrainError as exc:
                    raise FileNotFoundError(f"no terrain named {name!r}") from exc
                label = name
            self.session.call(SetTerrain(terrain, label), timeout=timeout)
            self._changed()
            return terrain

    def _at_robot_size(self, name: str, terrain: Terrain) -> Terrain:
        return terrain if name in ABSOLUTE_SCENES else scaled(terrain, self.scale)

    def load_dict(self, data: dict[str, Any], label: str, timeout: float = 60.0) -> Terrain:
        """Switch the session to an uploaded terrain dict (validated; nothing changes if invalid)."""
        return self.load_terrain(editor.to_terrain(data, source=label), label, timeout)

    def load_terrain(self, terrain: Terrain, label: str, timeout: float = 60.0) -> Terrain:
        """Switch the session to a terrain already validated (`app.live.terrain_files.validate_upload`)."""
        with self._lock:
            self.session.call(SetTerrain(terrain, label), timeout=timeout)
            self._changed()
            return terrain

    # ---- editing -----------------------------------------------------------------------------------
    def edit(self, function: Callable[..., dict[str, Any]], *args: Any, timeout: float = 60.0) -> bool:
        """Apply `function(current, *args)` in the session; False when it changed nothing."""
        with self._lock:
            changed = bool(self.session.call(EditTerrain(function, args), timeout=timeout))
            if changed:
                self._changed()
            return changed

    def undo(self, timeout: float = 60.0) -> None:
        with self._lock:
            self.session.call(UndoTerrainEdit(), timeout=timeout)
            self._changed()

    def redo(self, timeout: float = 60.0) -> None:
        """Apply again the edit the last undo took back (EditError when there is none)."""
        with self._lock:
            self.session.call(RedoTerrainEdit(), timeout=timeout)
            self._changed()

    def exists(self, name: str) -> str | None:
        """Whether saving as ``name`` would replace something: "yours" (a file of the user's folder),
        "shipped" (a terrain shipped with contactnet), or None."""
        if self.store.path(name).is_file():
            return "yours"
        is_shipped = getattr(self.store, "is_shipped", editor.is_shipped)
        return "shipped" if is_shipped(name) else None

    def save_upload(self, content: bytes, name: str, overwrite: bool = False) -> Path:
        """Validate uploaded JSON bytes once and write them as `<name>.json` (the session is not touched).
        Refusals: ShippedTerrainError (before validating), EditError (the terrain's one-line message)."""
        self.store.check_writable(name, overwrite)
        terrain = validate_upload(content, name)  # outside the lock: other terrain operations go on meanwhile
        with self._lock:
            return self.store.write(terrain, name, overwrite)

    def save(self, name: str, overwrite: bool = False, timeout: float = 60.0) -> str:
        """Write the current terrain as `<name>.json` in the store; the session calls it `name` from then on."""
        with self._lock:
            path = self.store.save(self.current, name, overwrite=overwrite)
            self.session.call(RenameTerrain(name), timeout=timeout)
            return str(path)
