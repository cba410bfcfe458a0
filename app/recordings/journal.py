"""The journal of a live recording: what it has recorded so far, on disk as it goes, so that a crash of the
tool (a kill, running out of memory, a power cut after the system wrote it) loses the last seconds of a
recording, not all of it.

A recording in progress is a viser scene serializer in memory (`app.recordings.recorder.SceneRecorder`). Every
`JOURNAL_PERIOD_S` the recorder appends what the serializer gained since the last time to the hidden file
``.NAME.viser.journal`` of the recordings folder (`RecordingJournal.append`); saving the recording removes its
journal. A journal left behind is a recording that was in progress when the tool stopped: opening the store
(`app.recordings.store.RecordingStore`, at the next start) makes it a recording again (`recover_journals`):
``NAME.viser`` with its metadata, whose result says it was recovered.

Format: the 8 bytes ``JOURNAL_MAGIC``, then records, each ``[4 bytes length][4 bytes CRC-32][payload]`` (little
endian), the payload zstd-compressed msgpack ``{"t": the recording's clock (s), "messages": [[t, message],
...], "buffers": [bytes, ...], "meta": RecordingMeta.to_dict(), "track": TrackCollector.chunk()}``: the serializer's
messages and binary buffers added since the previous record (a message's binary placeholders index the buffers of
the whole recording, so the records simply concatenate), the metadata so far, and the rows of the data track
(`app.recordings.track`) added since the previous record (a journal without them recovers without a track). Reading stops at the first record that is cut short
or does not match its CRC: where the crash was. An open journal is locked (``flock``), so a second tool on the
same folder never recovers a journal that is being written.

The serializer is viser's `StateSerializer` (viser 1.1.1); its messages, buffers and clock are private
attributes, read here only (`_serializer_state`). If a viser release changes them the journal turns itself off
with one warning, and recordings are made (in memory) as before.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import struct
import time
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import IO, Any

import msgspec
import zstandard

from app.recordings.meta import MetaError, RecordingMeta, read_meta
from app.recordings.track import TrackCollector
from app.recordings.viser_files import viser_bytes

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no locks, a journal is recovered whenever found
    fcntl = None  # type: ignore[assignment]

log = logging.getLogger("contactnet.app.recordings")

JOURNAL_MAGIC = b"CNJRNL01"
JOURNAL_SUFFIX = ".journal"
JOURNAL_NAME = re.compile(r"\A\.([A-Za-z0-9][A-Za-z0-9_-]{0,99}\.viser)\.journal\Z")
JOURNAL_PERIOD_S = 2.0  #: wall-clock seconds between two appends: a crash loses at most about this much
RETRY_S = 30.0  #: after a failed append, the next try
MAX_RECORD_BYTES = 1 << 31
RECOVERED = "stopped: recovered after the tool stopped while recording"
_HEADER = struct.Struct("<II")


def journal_path(directory: Path, name: str) -> Path:
    """The journal of recording ``name`` (``NAME.viser``) in the recordings folder ``directory``."""
    return Path(directory) / f".{name}{JOURNAL_SUFFIX}"


def _serializer_state(serializer: Any) -> tuple[list, list, float]:
    """(messages, binary buffers, clock) of a viser `StateSerializer` (private attributes of viser 1.1.1)."""
    return serializer._messages, serializer._binary_buffers, float(serializer._time)


def _lock(handle: IO[bytes]) -> bool:
    """Lock an open journal for this process (False when another one holds it)."""
    if fcntl is None:
        return True
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    return True


class RecordingJournal:
    """The journal of one recording in progress (see the module doc). `append` adds what the serializer gained;
    a write that fails is undone (the journal keeps its earlier records), logged once, and retried after
    `RETRY_S`; `error` then says why. `discard` removes the journal (the recording is saved), `close` keeps it
    (to be recovered). Not thread-safe: the live recorder calls it under its lock."""

    def __init__(self, directory: Path, name: str):
        self.path = journal_path(directory, name)
        self.name = name
        self.error: str | None = None  #: why the last append failed (None: the journal is up to date)
        self.records = 0
        self._file: IO[bytes] | None = None
        self._size = 0  # bytes of whole records written
        self._messages = 0  # the serializer's messages and buffers already in the journal
        self._buffers = 0
        self._track_marks = (0, 0, 0, 0, 0)  # the data track's rows already in the journal
        self._retry_at = 0.0
        self._disabled = False

    def create(self) -> None:
        """Create the journal file (it must not exist: the name is then taken by another tool); OSError if
        it cannot be (the recording then goes on without a journal)."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        handle = open(self.path, "xb")  # noqa: SIM115 - kept open until discard/close
        try:
            if not _lock(handle):
                raise FileExistsError(f"{self.path.name} is in use")
            handle.write(JOURNAL_MAGIC)
            handle.flush()
        except BaseException:
            handle.close()
            with contextlib.suppress(OSError):
                self.path.unlink()
            raise
        self._file, self._size, self._messages, self._buffers, self.records = handle, len(JOURNAL_MAGIC), 0, 0, 0
        self._track_marks = (0, 0, 0, 0, 0)

    def append(self, serializer: Any, meta: RecordingMeta, force: bool = False,
               track: TrackCollector | None = None) -> bool:
        """Append the serializer's new messages and buffers (and the metadata so far, and the data track's new
        rows); True if the journal is now up to date. After a failure nothing is tried before `RETRY_S`, unless
        ``force``."""
        if self._disabled or (not force and time.monotonic() < self._retry_at):
            return False
        try:
            messages, buffers, clock = _serializer_state(serializer)
            new_messages, new_buffers = messages[self._messages :], buffers[self._buffers :]
        except AttributeError:
            return self._disable("this viser has no scene serializer state to read")
        if not new_messages and not new_buffers and self.records:
            return True
        record_dict = {"t": clock, "messages": new_messages, "buffers": new_buffers, "meta": meta.to_dict()}
        track_marks = self._track_marks
        if track is not None:
            if self._file is None or not self.records:
                track_marks = (0, 0, 0, 0, 0)  # a journal started over holds the whole track again
            record_dict["track"] = track.chunk(track_marks)
            track_marks = track.marks()
        try:
            payload = msgspec.msgpack.encode(record_dict)
        except (TypeError, msgspec.EncodeError) as exc:
            return self._disable(f"a scene message could not be encoded ({exc})")
        record = zstandard.ZstdCompressor(level=3).compress(payload)
        try:
            if self._file is None:
                self.create()
            assert self._file is not None
            self._file.write(_HEADER.pack(len(record), zlib.crc32(record)) + record)
            self._file.flush()
        except OSError as exc:
            self._undo()
            reason = exc.strerror or type(exc).__name__
            if self.error != reason:
                log.warning(
                    "recording %s: its journal cannot be written (%s): a crash of the tool now would lose it; "
                    "retried every %.0f s",
                    self.name,
                    reason,
                    RETRY_S,
                )
            self.error, self._retry_at = reason, time.monotonic() + RETRY_S
            return False
        self._size += _HEADER.size + len(record)
        self._messages += len(new_messages)
        self._buffers += len(new_buffers)
        self._track_marks = track_marks
        self.records += 1
        if self.error is not None:
            log.info("recording %s: its journal is written again", self.name)
        self.error = None
        return True

    def _undo(self) -> None:
        """After a failed write: cut the journal back to its whole records, or start it over next time."""
        if self._file is None:
            return
        try:
            self._file.truncate(self._size)
            self._file.seek(self._size)
        except (OSError, ValueError):
            self._drop(remove=True)

    def _disable(self, why: str) -> bool:
        log.warning("recording %s: no journal (%s): a crash of the tool would lose it", self.name, why)
        self.error, self._disabled = why, True
        self._drop(remove=True)
        return False

    def _drop(self, remove: bool) -> None:
        handle, self._file = self._file, None
        self._messages = self._buffers = self.records = 0
        if handle is not None:
            with contextlib.suppress(OSError, ValueError):
                handle.close()
            if remove:
                try:
                    self.path.unlink(missing_ok=True)
                except OSError as exc:
                    log.warning("recording %s: journal left (%s)", self.name, exc.strerror or exc)

    def discard(self) -> None:
        """The recording is saved: remove its journal."""
        self._drop(remove=True)

    def close(self) -> None:
        """Close the journal and keep it: the next start recovers the recording from it."""
        self._drop(remove=False)


# ---- reading and recovering ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class JournalContents:
    """What a journal holds: the scene messages and binary buffers, the recording's clock, its metadata."""

    messages: list
    buffers: list[bytes]
    duration_s: float
    meta: RecordingMeta | None
    records: int
    torn: bool  # it ends with a record cut short or garbled (the crash)
    track: dict | None = None  # the data track's rows joined (`TrackCollector.to_dict`); None in an older journal


def _records(data: bytes) -> Iterator[bytes]:
    offset = len(JOURNAL_MAGIC)
    while offset + _HEADER.size <= len(data):
        length, crc = _HEADER.unpack_from(data, offset)
        start = offset + _HEADER.size
        record = data[start : start + length]
        if length > MAX_RECORD_BYTES or len(record) != length or zlib.crc32(record) != crc:
            return
        yield record
        offset = start + length


def read_journal(data: bytes) -> JournalContents:
    """The contents of a journal's bytes (its whole records); ValueError if they are not a journal."""
    if not data.startswith(JOURNAL_MAGIC):
        raise ValueError("not a recording journal")
    messages: list = []
    buffers: list[bytes] = []
    clock, meta, records, used = 0.0, None, 0, len(JOURNAL_MAGIC)
    chunks: list[dict] = []
    decompressor = zstandard.ZstdDecompressor()
    for record in _records(data):
        try:
            chunk = msgspec.msgpack.decode(decompressor.decompress(record, max_output_size=MAX_RECORD_BYTES))
            meta_dict = chunk["meta"]
            new_messages, new_buffers, t = chunk["messages"], chunk["buffers"], float(chunk["t"])
        except (zstandard.ZstdError, msgspec.DecodeError, KeyError, TypeError, ValueError):
            break
        messages.extend(new_messages)
        buffers.extend(bytes(b) for b in new_buffers)
        if isinstance(chunk.get("track"), dict):
            chunks.append(chunk["track"])
        clock, records = t, records + 1
        used += _HEADER.size + len(record)
        with contextlib.suppress(MetaError):
            meta = RecordingMeta.from_dict(meta_dict)
    track = TrackCollector.from_chunks(chunks).to_dict(clock) if chunks else None
    return JournalContents(messages, buffers, clock, meta, records, torn=used < len(data), track=track)


def recover_journals(store: Any) -> list[str]:  # an app.recordings.store.RecordingStore
    """Make a recording of every journal of ``store``'s folder that no running tool holds; the names saved.
    A journal whose recording was saved already (a crash between the save and the journal's removal) is only
    removed; one that cannot be saved now stays for the next start. Never raises."""
    directory = Path(store.directory)
    try:
        journals = sorted(p for p in directory.iterdir() if JOURNAL_NAME.match(p.name))
    except OSError:
        return []
    recovered = []
    for path in journals:
        try:
            name = _recover(store, path, JOURNAL_NAME.match(path.name).group(1))
        except Exception as exc:  # noqa: BLE001 - a journal that cannot be recovered never stops the tool
            log.warning("recording journal %s not recovered: %s", path.name, exc)
            continue
        if name is not None:
            recovered.append(name)
    return recovered


def _recover(store: Any, path: Path, name: str) -> str | None:
    with open(path, "rb") as handle:
        if not _lock(handle):
            return None  # being written by a running tool
        contents = read_journal(handle.read())
        if contents.records == 0:
            log.warning("recording journal %s held no frame: removed", path.name)
            _remove(path)
            return None
        saved = store.directory / name
        if saved.is_file():
            meta = read_meta(saved).meta
            journal_frames = contents.meta.frames if contents.meta else None
            if meta is not None and meta.frames is not None and (journal_frames or 0) <= meta.frames:
                _remove(path)  # the recording was saved; the tool stopped before removing its journal
                return None
            name = store.free_name(name[: -len(".viser")] + "-recovered")
        meta = contents.meta or RecordingMeta()
        meta = replace(meta, result=RECOVERED, duration_s=round(contents.duration_s, 3))
        store.save(viser_bytes(contents.messages, contents.buffers, contents.duration_s), name, meta, contents.track)
    _remove(path)
    log.warning(
        "recovered the recording %s (%.1f s, %s frames) that was in progress when the tool stopped%s",
        name,
        contents.duration_s,
        meta.frames if meta.frames is not None else "?",
        " (its last record was cut short)" if contents.torn else "",
    )
    return name


def _remove(path: Path) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass
    except OSError as exc:
        log.warning("recording journal %s left (%s)", path.name, exc.strerror or exc)
