"""The terrain editor's app side: terrain files in a folder (`TerrainStore`) and uploaded files.

The edits themselves are pure functions on terrain dicts in :mod:`contactnet.terrain.edits`; they
are re-exported here so the app's modules can keep using ``editor.punch_hole`` and friends.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from contactnet.terrain import Terrain, TerrainError
from contactnet.terrain.edits import (
    HOLE_SIZE_M,
    MAX_UNDO,
    SHIPPED_NAMES,
    STONE_SHAPES,
    EditError,
    EditHistory,
    TerrainDict,
    add_stone,
    delete_region,
    fill_hole,
    is_shipped,
    move_region,
    punch_hole,
    region_at,
    region_geometry,
    region_pose,
    renamed,
    snap_square,
    to_terrain,
    validate_name,
    validated,
)

__all__ = [
    "HOLE_SIZE_M",
    "MAX_UNDO",
    "MAX_UPLOAD_BYTES",
    "SHIPPED_NAMES",
    "STONE_SHAPES",
    "EditError",
    "EditHistory",
    "ShippedTerrainError",
    "TerrainDict",
    "TerrainStore",
    "add_stone",
    "delete_region",
    "fill_hole",
    "is_shipped",
    "move_region",
    "parse_upload",
    "punch_hole",
    "region_at",
    "region_geometry",
    "region_pose",
    "renamed",
    "snap_square",
    "to_terrain",
    "validate_name",
    "validated",
]


# ---- files ---------------------------------------------------------------------------------------
MAX_UPLOAD_BYTES = 1_000_000


class ShippedTerrainError(EditError):
    """Saving would overwrite a terrain shipped with contactnet, and that was not confirmed."""


class TerrainStore:
    """Terrain files in one folder (by default `contactnet.terrain.terrains_dir()`), by name.

    Names are file stems checked by `validate_name`, so a name never leaves the folder. Saving over
    a shipped file (flat, stepping_stones, ...) needs `overwrite=True`; other files are replaced.
    """

    def __init__(self, directory: Path):
        self.directory = Path(directory)

    def names(self) -> list[str]:
        return sorted(p.stem for p in self.directory.glob("*.json")) if self.directory.is_dir() else []

    def path(self, name: str) -> Path:
        return self.directory / f"{validate_name(name)}.json"

    def load(self, name: str) -> Terrain:
        path = self.path(name)
        if not path.is_file():
            raise FileNotFoundError(f"no terrain named {name!r} in {self.directory}")
        try:
            return Terrain.load(path)
        except TerrainError as exc:
            raise EditError(str(exc)) from None

    def save(self, data: Mapping[str, Any] | Terrain, name: str, overwrite: bool = False) -> Path:
        """Validate and write `data` as `<name>.json` (its "name" field becomes `name`).

        A `Terrain` already named `name` is written as it is, without validating it again.
        """
        path = self.path(name)
        if is_shipped(name) and path.exists() and not overwrite:
            raise ShippedTerrainError(
                f"{name!r} is a terrain shipped with contactnet: confirm (overwrite) to replace it"
            )
        if isinstance(data, Terrain) and data.name == name:
            terrain = data
        else:
            plain = data.to_dict() if isinstance(data, Terrain) else data
            terrain = to_terrain(renamed(plain, name), source=path.name)
        self.directory.mkdir(parents=True, exist_ok=True)
        terrain.save(path)
        return path


def parse_upload(content: bytes, source: str = "upload", max_bytes: int = MAX_UPLOAD_BYTES) -> TerrainDict:
    """A terrain dict (normalized) from uploaded bytes (JSON), or EditError saying what is wrong with it.

    Read with the terrain JSON limits (at most ``max_bytes``; depth, values, number length, duplicate
    keys: ``contactnet.terrain.schema.loads_terrain_json``) and validated once within the terrain
    complexity budget (``Terrain.from_json``). Thread-safe: run it off an event loop.
    """
    try:
        return Terrain.from_json(content, source=source, max_bytes=max_bytes).to_dict()
    except TerrainError as exc:
        raise EditError(str(exc)) from None
