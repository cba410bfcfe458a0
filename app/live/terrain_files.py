"""The terrain files the web tool offers: the shipped ones (read-only) under the user's own.

`TerrainLibrary` has the interface of `app.live.editor.TerrainStore` (``names``, ``load``, ``save``, ``path``,
``directory``) over two folders:

- the shipped terrains (`contactnet.terrain.terrains_dir()`, inside the installed package or the
  repository), only ever read;
- the user's folder (`ServeSettings.user_terrains_dir()`: ``$CONTACTNET_DATA/terrains``, by default
  ``~/.local/share/contactnet/terrains``), where every save goes.

A user file shadows the shipped file of the same name. Opening the library removes the temporary files a killed
save left in the user's folder (`contactnet.atomic.remove_stale_temporaries`). Saving under a shipped name (``flat``,
``stepping_stones``, ...) needs ``overwrite=True`` and writes the user's own copy: the shipped file never
changes, and deleting the copy brings it back. (Refusing such saves outright would also protect the
shipped files, but editing a shipped terrain and keeping it under its name is what the editor is for.)

Uploads are validated once (`validate_upload`, off the event loop in the server) and written as they
were validated: no second or third validation of the same terrain. A height map or a mesh is imported
(`import_upload`: segmented into steppable tops by ``contactnet.terrain.importing``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from app.live.editor import (
    MAX_UPLOAD_BYTES,
    EditError,
    ShippedTerrainError,
    TerrainStore,
    is_shipped,
    validate_name,
)
from contactnet.atomic import remove_stale_temporaries, storage_error
from contactnet.terrain import Terrain, TerrainError, terrains_dir, validate_terrain_bytes
from contactnet.terrain.schema import loads_terrain_json


def validate_upload(content: bytes, name: str | None = None, source: str | None = None) -> Terrain:
    """The terrain of uploaded JSON bytes, validated once (the terrain JSON limits, then the complexity budget:
    `contactnet.terrain.validate_terrain_bytes`); ``name``: the name it is saved as (its "name" field becomes
    ``name``), None keeps the file's. EditError (one line naming ``source`` and the field) when it is not a valid
    terrain. Thread-safe: the server runs it off the event loop."""
    source = source or (f"{validate_name(name)}.json" if name is not None else "upload")
    try:
        if name is None:
            return validate_terrain_bytes(content, source=source, max_bytes=MAX_UPLOAD_BYTES)
        data = loads_terrain_json(content, source, max_bytes=MAX_UPLOAD_BYTES)
        if isinstance(data, dict):
            data["name"] = validate_name(name)
        return Terrain.from_dict(data, source=source)
    except TerrainError as exc:
        raise EditError(str(exc)) from None


#: The largest height map or mesh accepted from the browser, bytes.
MAX_IMPORT_BYTES = 16_000_000


def import_upload(content: bytes, filename: str) -> tuple[Terrain, Any]:
    """The terrain segmented from an uploaded height map or mesh (``contactnet.terrain.importing``, its defaults),
    and the import's report; EditError (one line naming the file) for a file it cannot read or a size over
    `MAX_IMPORT_BYTES`. Thread-safe: the panel runs it off the event loop."""
    import tempfile

    from contactnet.terrain.importing import HEIGHT_MAP_SUFFIXES, MESH_SUFFIXES, import_terrain

    suffix = Path(filename).suffix.lower()
    if suffix not in HEIGHT_MAP_SUFFIXES + MESH_SUFFIXES:
        raise EditError(f"{filename}: a height map (.npy, .png) or a mesh (.stl, .obj, .ply) is imported, not {suffix or 'this'}")
    if len(content) > MAX_IMPORT_BYTES:
        raise EditError(f"{filename}: {len(content) / 1e6:.1f} MB; at most {MAX_IMPORT_BYTES / 1e6:.0f} MB")
    stem = Path(filename).stem
    try:
        name = validate_name(stem)
    except EditError:
        name = "imported"
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{name}{suffix}"
        path.write_bytes(content)
        try:
            return import_terrain(path, name=name)
        except TerrainError as exc:
            raise EditError(str(exc).replace(str(path), filename)) from None


class StoredTerrainError(EditError):
    """A terrain file in one of the folders is not a valid terrain (the request naming it is fine: 409)."""


class TerrainLibrary:
    """The shipped terrain files (read-only) under the user's folder (written); see the module doc."""

    def __init__(self, user_dir: Path, shipped_dir: Path | None = None):
        self.directory = Path(user_dir)  #: the user's folder, where saves go
        self.user = TerrainStore(self.directory)
        self.shipped = TerrainStore(Path(shipped_dir) if shipped_dir is not None else terrains_dir())
        remove_stale_temporaries(self.directory)  # what a killed save left

    def names(self) -> list[str]:
        return sorted(set(self.user.names()) | set(self.shipped.names()))

    def is_shipped(self, name: str) -> bool:
        """A terrain shipped with contactnet (a file of the shipped folder or a shipped generator)?"""
        return is_shipped(name) or name in self.shipped.names()

    def path(self, name: str) -> Path:
        """Where `save` writes ``name`` (in the user's folder)."""
        return self.user.path(name)

    def load(self, name: str) -> Terrain:
        """The user's file of that name, else the shipped one; FileNotFoundError if neither exists."""
        for store in (self.user, self.shipped):
            if store.path(name).is_file():
                try:
                    return Terrain.load(store.path(name))
                except TerrainError as exc:
                    raise StoredTerrainError(f"the stored file is not a valid terrain: {exc}") from None
        raise FileNotFoundError(f"no terrain named {name!r}")

    def check_writable(self, name: str, overwrite: bool) -> Path:
        """The path `write` would use; ShippedTerrainError for a shipped name without ``overwrite``."""
        path = self.path(name)
        if self.is_shipped(name) and not overwrite:
            raise ShippedTerrainError(
                f"{name!r} is a terrain shipped with contactnet: confirm (overwrite) to save your own copy "
                "under that name (the shipped file stays as it is)"
            )
        return path

    def write(self, terrain: Terrain, name: str, overwrite: bool = False) -> Path:
        """Write a validated terrain (named ``name``) to the user's folder; ShippedTerrainError for a shipped
        name without ``overwrite``, `contactnet.atomic.StorageError` (one line, naming the file) when the folder
        refuses it (read-only, full, ...: the old file, if any, is unchanged)."""
        path = self.check_writable(name, overwrite)
        if terrain.name != name:
            raise ValueError(f"the terrain is named {terrain.name!r}, not {name!r}")
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            terrain.save(path)
        except OSError as exc:
            raise storage_error(exc, f"cannot save {path.name} in your terrain folder") from None
        return path

    def save(self, data: Mapping[str, Any], name: str, overwrite: bool = False) -> Path:
        """Validate ``data`` (its "name" field becomes ``name``) and write it to the user's folder."""
        self.check_writable(validate_name(name), overwrite)
        try:
            terrain = Terrain.from_dict({**dict(data), "name": name}, source=f"{name}.json")
        except TerrainError as exc:
            raise EditError(str(exc)) from None
        return self.write(terrain, name, overwrite)
