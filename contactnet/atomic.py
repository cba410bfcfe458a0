"""Atomic file writes: a reader sees the old file or the new one, never half of one.

The one writer of the project: write a temporary file in the target's folder, flush and fsync it,
give it ordinary permissions (``mkstemp`` makes it private), then ``os.replace`` it over the target.
An interrupted write leaves the old file untouched. A write that fails (an exception: a full disk, a read-only
folder, Ctrl-C) removes its temporary file; a process killed in the middle of one cannot, and leaves
``.NAME.XXXXXXXX.tmp`` next to the target: `remove_stale_temporaries(folder)` removes those (older than
`STALE_TEMPORARY_S`, so never a write in progress), and the folders of user files call it when opened (the web
tool's recordings and terrains).

`StorageError` is an OSError of a user file said in one line (what could not be done to which file, and the
system's reason) with its errno kept, so that a caller can tell a full disk (``ENOSPC``) from a read-only folder.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import re
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO

log = logging.getLogger("contactnet.atomic")

#: A temporary file of `atomic_open` (or any ``mkstemp(prefix=".NAME.", suffix=".tmp")``): ``.NAME.`` then
#: mkstemp's 8 random characters, then ``.tmp``.
TEMPORARY_NAME = re.compile(r"\A\..+\.[a-z0-9_]{8}\.tmp\Z")
#: Age (s since its last change) beyond which a temporary file is one a killed process left behind.
STALE_TEMPORARY_S = 120.0
#: errno values saying the disk (or the user's quota) is full.
NO_SPACE = frozenset({errno.ENOSPC, errno.EDQUOT})


class StorageError(OSError):
    """A file could not be written, renamed or deleted: ``str()`` is one line naming the file (never its folder's
    path) and the system's reason; ``errno`` is the system's (``ENOSPC``: the disk is full)."""

    def __init__(self, code: int | None, message: str):
        super().__init__(code, message)

    def __str__(self) -> str:
        return str(self.strerror)

    @property
    def no_space(self) -> bool:
        return self.errno in NO_SPACE


def storage_error(exc: OSError, doing: str) -> StorageError:
    """``exc`` as a `StorageError` saying ``doing`` (e.g. "cannot save run.viser") and why, in one line."""
    if isinstance(exc, StorageError):
        return exc
    reason = exc.strerror or type(exc).__name__
    if isinstance(exc, FileExistsError) and exc.filename:
        reason = f"{Path(exc.filename).name} is a file, not a folder"  # a file where the folder should be
    elif exc.errno in NO_SPACE:
        reason = f"{reason} (the disk is full)"
    return StorageError(exc.errno, f"{doing}: {reason}")


def remove_stale_temporaries(folder: str | os.PathLike[str], older_than_s: float = STALE_TEMPORARY_S) -> list[str]:
    """Remove the temporary files (`TEMPORARY_NAME`) a killed write left in ``folder``, those unchanged for
    ``older_than_s``; the names removed. Never raises: a folder that cannot be read or a file that cannot be removed
    is left as it is (logged)."""
    removed: list[str] = []
    now = time.time()
    try:
        candidates = [entry for entry in os.scandir(folder) if TEMPORARY_NAME.match(entry.name)]
    except OSError:
        return removed  # no folder yet (nothing to clean), or one we cannot read
    for entry in candidates:
        try:
            if not entry.is_file(follow_symlinks=False) or now - entry.stat().st_mtime < older_than_s:
                continue
            os.unlink(entry.path)
        except FileNotFoundError:
            continue
        except OSError as exc:
            log.warning("left temporary file %s (%s)", entry.name, exc.strerror or exc)
            continue
        removed.append(entry.name)
    if removed:
        log.info("removed %d temporary file(s) left by an interrupted write: %s", len(removed), ", ".join(removed))
    return removed


def _ordinary_mode(target: Path) -> int:
    """The mode a new file gets under the umask, or the existing target's mode."""
    if target.exists():
        return target.stat().st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "wb", encoding: str | None = None) -> Iterator[IO]:
    """Open a temporary file next to ``path`` for writing; on a clean exit it replaces ``path``.

    ``mode`` is ``"wb"`` or ``"w"`` (text, ``encoding`` default utf-8). The folder is created if missing.
    On an exception the temporary file is removed and ``path`` is unchanged.
    """
    if mode not in ("wb", "w"):
        raise ValueError(f"atomic_open: mode must be 'wb' or 'w', got {mode!r}")
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        os.chmod(tmp_name, _ordinary_mode(target))
        text = {"encoding": encoding or "utf-8"} if mode == "w" else {}
        with os.fdopen(fd, mode, **text) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp_name, target)
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_open(path, "wb") as handle:
        handle.write(data)
    return Path(path)


def atomic_write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; returns the path."""
    with atomic_open(path, "w", encoding=encoding) as handle:
        handle.write(text)
    return Path(path)


def atomic_write_with(path: str | os.PathLike[str], write: Callable[[IO[bytes]], object]) -> Path:
    """Let ``write(handle)`` fill a binary file that then atomically replaces ``path`` (torch.save, np.savez)."""
    with atomic_open(path, "wb") as handle:
        write(handle)
    return Path(path)
