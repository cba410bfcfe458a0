"""The recordings folder: its .viser files with their metadata sidecars (`app.recordings.meta`), listed,
saved, renamed, retitled and deleted by name.

A name is a file name of the folder, ``RECORDING_NAME`` (letters, digits, ``_``, ``-``, then ``.viser``),
so no name reaches outside the folder. A recording and its sidecars (metadata, data track: `app.recordings.track`) move and go together. Errors are
one-line exceptions that name recordings, never paths: ``ValueError`` (a bad name), ``FileNotFoundError``
(no such recording), ``FileExistsError`` (a rename onto another recording), `StorageError` (the folder refused
a write, a rename or a deletion: read-only, full, ...; its errno kept).

Opening the store tidies the folder after a crash: temporary files a killed write left
(`contactnet.atomic.remove_stale_temporaries`) go, and the journal of a recording that was in progress
(`app.recordings.journal`) becomes a recording (`recovered` names them). Names being recorded are reserved
(`reserve`), so two recorders of the same store (one per visitor) never pick the same one.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from app.recordings import journal
from app.recordings.meta import MetaRead, RecordingMeta, read_meta, retitled, sidecar_path, write_meta
from app.recordings.track import track_path, write_track
from contactnet.atomic import StorageError, atomic_write_bytes, remove_stale_temporaries, storage_error

log = logging.getLogger("contactnet.app.recordings")

__all__ = ["RECORDING_NAME", "RecordingInfo", "RecordingStore", "StorageError"]

RECORDING_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,99}\.viser$")


@dataclass(frozen=True)
class RecordingInfo:
    """One recording of the folder: its file (name, bytes, modification time, Unix s) and its metadata
    (`meta`, None without a usable sidecar; then `meta_note` says why)."""

    name: str
    size_bytes: int
    modified: float
    meta: RecordingMeta | None = None
    meta_note: str | None = None
    track: bool = False  # it has a data track (`app.recordings.track`: timeline markers and plots)


class RecordingStore:
    """The .viser files of one folder and their sidecars. Safe to use from several threads."""

    def __init__(self, directory: Path, recover: bool = True):
        self.directory = Path(directory)
        self._lock = threading.RLock()
        self._reported: dict[str, str] = {}  # name -> the sidecar problem already logged for it
        self._reserved: set[str] = set()  # names being recorded (not yet files)
        self.recovered: list[str] = []  #: recordings made from the journals a crash left (`recover`)
        if recover:
            remove_stale_temporaries(self.directory)
            self.recovered = journal.recover_journals(self)

    def path(self, name: str) -> Path:
        if not isinstance(name, str) or not RECORDING_NAME.fullmatch(name):
            raise ValueError(
                f"invalid recording name {name!r}: expected letters, digits, '_', '-' and .viser"
            )
        return self.directory / name

    def _existing(self, name: str) -> Path:
        path = self.path(name)
        if not path.is_file():
            raise FileNotFoundError(f"no recording named {name!r}")
        return path

    def info(self, name: str) -> RecordingInfo:
        """The recording `name` with its metadata (FileNotFoundError when there is none)."""
        path = self._existing(name)
        stat = path.stat()
        read = self._read_meta(path)
        return RecordingInfo(path.name, stat.st_size, stat.st_mtime, read.meta, read.note, track_path(path).is_file())

    def _read_meta(self, path: Path) -> MetaRead:
        read = read_meta(path)
        if read.meta is None and read.note and "unreadable" in read.note:
            if self._reported.get(path.name) != read.note:  # once per problem, not at every listing
                self._reported[path.name] = read.note
                log.warning("recording %s: %s; listed without metadata", path.name, read.note)
        else:
            self._reported.pop(path.name, None)
        return read

    def list(self) -> list[RecordingInfo]:
        """Every recording of the folder, newest first (a file that vanishes meanwhile is left out)."""
        if not self.directory.is_dir():
            return []
        infos = []
        for path in self.directory.glob("*.viser"):
            if RECORDING_NAME.fullmatch(path.name):
                try:
                    infos.append(self.info(path.name))
                except FileNotFoundError:
                    continue
        return sorted(infos, key=lambda r: r.modified, reverse=True)

    def new_name(self, label: str = "", taken: tuple[str | None, ...] = ()) -> str:
        """A free name from the time and `label` (``20250101-120000-label.viser``), none of `taken`, of the
        reserved names or of the journals of the folder."""
        stem = re.sub(r"[^A-Za-z0-9_-]+", "-", label).strip("-")[:40]
        return self.free_name(time.strftime("%Y%m%d-%H%M%S") + (f"-{stem}" if stem else ""), taken)

    def free_name(self, base: str, taken: tuple[str | None, ...] = ()) -> str:
        """``base.viser``, else ``base-2.viser``, ...: the first name no recording, journal or reservation has."""
        name, k = f"{base}.viser", 1
        with self._lock:
            while (
                name in taken
                or name in self._reserved
                or (self.directory / name).exists()
                or journal.journal_path(self.directory, name).exists()
            ):
                k += 1
                name = f"{base}-{k}.viser"
        return name

    def reserve(self, label: str = "") -> str:
        """A new name (`new_name`) kept from every other `new_name` of this store until `release`."""
        with self._lock:
            name = self.new_name(label)
            self._reserved.add(name)
            return name

    def release(self, name: str) -> None:
        with self._lock:
            self._reserved.discard(name)

    def save(self, data: bytes, name: str, meta: RecordingMeta | None = None, track: dict | None = None) -> Path:
        """Write the recording (atomically), then its sidecars (metadata, data track); a sidecar that cannot be
        written is logged (the recording then lists without it), never lost with the recording. `StorageError`
        when the recording cannot be written (nothing changed then)."""
        path = self.path(name)
        with self._lock:
            try:
                atomic_write_bytes(path, data)
            except OSError as exc:
                raise storage_error(exc, f"cannot save {name} in the recordings folder") from None
            if meta is not None:
                try:
                    write_meta(path, meta)
                except OSError as exc:
                    log.warning("recording %s: metadata not saved (%s)", name, exc.strerror or exc)
            if track is not None:
                try:
                    write_track(path, track)
                except OSError as exc:
                    log.warning("recording %s: data track not saved (%s)", name, exc.strerror or exc)
        return path

    def set_title(self, name: str, title: str) -> RecordingInfo:
        """Give recording `name` a title (kept in its sidecar; one is made if it had none)."""
        with self._lock:
            path = self._existing(name)
            try:
                write_meta(path, retitled(self._read_meta(path).meta, title))
            except OSError as exc:
                raise storage_error(exc, f"cannot save the title of {name}") from None
            return self.info(name)

    def rename(self, name: str, new_name: str) -> RecordingInfo:
        """Rename recording `name` (and its sidecar and data track) to `new_name`; FileExistsError if that exists."""
        with self._lock:
            source = self._existing(name)
            target = self.path(new_name)
            if new_name == name:
                return self.info(name)
            if target.exists() or new_name in self._reserved:
                raise FileExistsError(f"a recording named {new_name!r} exists already")
            doing = f"cannot rename {name} to {new_name}"
            try:
                os.replace(source, target)
            except OSError as exc:
                raise storage_error(exc, doing) from None
            moved = [(source, target)]  # put back in reverse order if a companion file cannot follow
            for companion, what in ((sidecar_path, "metadata file"), (track_path, "data track")):
                try:
                    os.replace(companion(source), companion(target))
                except FileNotFoundError:
                    try:
                        companion(target).unlink(missing_ok=True)  # a stale one must not describe it
                    except OSError as exc:
                        log.warning("recording %s: a stale %s is left (%s)", new_name, what, exc.strerror or exc)
                except OSError as exc:  # it cannot follow: put the recording (and what followed it) back, as it was
                    for moved_from, moved_to in reversed(moved):
                        with contextlib.suppress(OSError):
                            os.replace(moved_to, moved_from)
                    raise storage_error(exc, doing) from None
                else:
                    moved.append((companion(source), companion(target)))
            self._reported.pop(name, None)
            return self.info(new_name)

    def delete(self, name: str) -> None:
        """Delete recording `name` and its sidecar."""
        with self._lock:
            path = self._existing(name)
            try:
                path.unlink()
            except FileNotFoundError:
                pass  # gone meanwhile: deleted all the same
            except OSError as exc:
                raise storage_error(exc, f"cannot delete {name}") from None
            try:
                sidecar_path(path).unlink(missing_ok=True)
            except OSError as exc:  # the recording is gone; a sidecar alone never lists
                log.warning("recording %s: its metadata file is left (%s)", name, exc.strerror or exc)
            try:
                track_path(path).unlink(missing_ok=True)
            except OSError as exc:
                log.warning("recording %s: its data track is left (%s)", name, exc.strerror or exc)
            self._reported.pop(name, None)
