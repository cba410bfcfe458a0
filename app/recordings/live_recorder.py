"""Recordings of the live session: `LiveRecorder` starts and stops them (from the GUI or REST), is fed by the
viewer's update loop, journals each recording as it goes (`app.recordings.journal`: a crash keeps all but the last
seconds), keeps a recording whose save failed until a later stop saves it, and guards the recording in progress
against renames and deletions. The frames themselves are drawn by a `app.recordings.recorder.SceneRecorder`."""

from __future__ import annotations

import logging
import tempfile
import threading
import time
from pathlib import Path

from app.live.view import LiveView
from app.recordings.journal import JOURNAL_PERIOD_S, RecordingJournal
from app.recordings.recorder import DEFAULT_RATE_HZ, RecordingConflict, SceneRecorder
from app.recordings.store import RecordingInfo, RecordingStore, StorageError
from contactnet.robots import Robot

log = logging.getLogger("contactnet.app.recordings")


class RecordingBusy(RecordingConflict):
    """The recording is being made (or saved) right now: it cannot be renamed or deleted yet."""


class RecordingNotSaved(StorageError):
    """`LiveRecorder.stop` could not write the recording: it is kept (stop again to save it). One line saying
    why; the errno of the file system's error (``ENOSPC``: the disk is full)."""


class LiveRecorder:
    """Start/stop recordings of the live session (of ``robot``, default Solo12); `feed(view)` is called by
    the viewer's update loop. Renames, titles and deletions of the folder's recordings go through it too,
    so that the recording in progress (not yet on disk) is never renamed over nor deleted (`RecordingBusy`).

    Nothing is lost when a write fails: a recording goes to its journal as it is made (`app.recordings.journal`:
    a crash keeps all but the last seconds), and a `stop` whose save fails keeps the recording, stopped, in
    memory (`RecordingNotSaved`; `status` says why): a later `stop` saves it, and at shut-down
    (`save_in_progress`) it is saved in a folder of its own if the recordings folder still refuses it."""

    def __init__(self, store: RecordingStore, robot: Robot | None = None, rate_hz: float = DEFAULT_RATE_HZ):
        self.store = store
        self.robot = robot
        self.rate_hz = rate_hz
        self._lock = threading.Lock()
        self._recorder: SceneRecorder | None = None
        self._journal: RecordingJournal | None = None
        self._next_journal = 0.0
        self._name: str | None = None
        self._title = ""
        self._stopped = False  # stopped (no more frames), not saved yet
        self._saving: str | None = None  # the name being written by `stop`
        self._save_error: str | None = None  # why the last save failed
        self.last_saved: str | None = None

    @property
    def recording(self) -> bool:
        """A recording is in progress, or stopped and not saved yet (a `stop` saves it)."""
        return self._recorder is not None

    @property
    def stopped(self) -> bool:
        """The recording is stopped but not saved (its save failed: `status` says why; a `stop` saves it)."""
        return self._recorder is not None and self._stopped

    def status(self) -> dict:
        with self._lock:
            rec = self._recorder
            journal = self._journal
            return {
                "recording": rec is not None,
                "name": self._name,
                "frames": rec.frames if rec else 0,
                "duration_s": rec.duration_s if rec else 0.0,
                "last_saved": self.last_saved,
                "save_error": self._save_error
                or (f"journal not written ({journal.error}): a crash would lose it" if journal and journal.error else None),
            }

    def start(self, label: str = "", title: str = "") -> str:
        """Start recording into a new file named from the time and `label`; `title` goes in its metadata."""
        with self._lock:
            if self._recorder is not None:
                if self._stopped:
                    raise RecordingConflict(
                        f"{self._name} is not saved yet ({self._save_error}): stop again to save it first"
                    )
                raise RecordingConflict(f"already recording {self._name}")
            self._recorder = SceneRecorder(robot=self.robot, rate_hz=self.rate_hz)
            self._name = name = self.store.reserve(label)
            self._title = title
            self._stopped, self._save_error = False, None
            self._journal = RecordingJournal(self.store.directory, name)
            self._next_journal = time.monotonic() + JOURNAL_PERIOD_S
            try:
                self._journal.create()  # now: it also keeps the name from another tool on the same folder
            except OSError as exc:  # recorded in memory all the same; `append` tries again
                self._journal.error = exc.strerror or type(exc).__name__
                log.warning("recording %s: no journal (%s): a crash of the tool would lose it", name, self._journal.error)
            return name

    def feed(self, view: LiveView | None) -> None:
        if view is None or self._recorder is None or self._stopped:
            return
        with self._lock:
            recorder = self._recorder
            if recorder is None or self._stopped or not recorder.add(view):
                return
            if self._journal is not None and time.monotonic() >= self._next_journal:
                self._next_journal = time.monotonic() + JOURNAL_PERIOD_S
                self._append_journal(recorder)

    def _append_journal(self, recorder: SceneRecorder, force: bool = False) -> None:
        if self._journal is not None and recorder.serializer is not None:
            self._journal.append(recorder.serializer, recorder.meta(self._title), force=force, track=recorder.track)

    def stop(self) -> RecordingInfo:
        """Stop and save the recording with its metadata. `RecordingNotSaved` when it cannot be written: it is
        then kept, stopped, and the next `stop` tries again."""
        with self._lock:
            recorder, name = self._recorder, self._name
            if recorder is None or name is None:
                raise RecordingConflict("not recording")
            if self._saving is not None:
                raise RecordingBusy(f"{name} is being saved")
            if not self._stopped:
                self._append_journal(recorder, force=True)  # the journal holds all of it until it is saved
                self._stopped = True
            self._saving = name
        try:
            data = recorder.finish()  # (once: a later stop reuses the bytes)
        except RecordingConflict:  # nothing recorded: nothing to keep
            self._end(name)
            raise
        try:
            self.store.save(data, name, recorder.meta(self._title), recorder.track_data())
        except Exception as exc:
            with self._lock:
                self._saving = None
                self._save_error = str(exc) if isinstance(exc, OSError) else f"{type(exc).__name__}: {exc}"
            raise RecordingNotSaved(
                getattr(exc, "errno", None),
                f"{self._save_error}; the recording is kept: stop again to save it once the folder can be written",
            ) from None
        self._end(name)
        self.last_saved = name
        return self.store.info(name)

    def _end(self, name: str) -> None:
        """The recording `name` is saved (or had nothing): forget it and its journal."""
        with self._lock:
            recorder, journal = self._recorder, self._journal
            self._recorder = self._journal = self._name = self._saving = self._save_error = None
            self._stopped = False
        self.store.release(name)
        if recorder is not None:
            recorder.close()
        if journal is not None:
            journal.discard()

    def _check_idle(self, *names: str | None) -> None:
        for name in names:
            if name is not None and name in (self._name, self._saving):
                raise RecordingBusy(f"{name} is being recorded: stop the recording first")

    def change(self, name: str, new_name: str | None = None, title: str | None = None) -> RecordingInfo:
        """Rename recording `name` to `new_name` and/or give it `title`; the recording as it is then."""
        with self._lock:
            self._check_idle(name, new_name)
            if new_name is not None:
                self.store.rename(name, new_name)
                name = new_name
            if title is not None:
                return self.store.set_title(name, title)
            return self.store.info(name)

    def delete(self, name: str) -> None:
        """Delete recording `name` and its metadata."""
        with self._lock:
            self._check_idle(name)
            self.store.delete(name)

    def save_in_progress(self, fallback: Path | None = None) -> str | None:
        """At shut-down: save the recording in progress (or stopped, not saved), if any. When the recordings
        folder refuses it, it goes to ``fallback`` (default: ``contactnet-recordings`` in the temporary folder).
        One line saying what happened (saved, with its folder; or what keeps it, or that it was dropped and
        why), None when nothing was recording."""
        name, recorder = self._name, self._recorder
        if recorder is None or name is None:
            return None
        try:
            info = self.stop()
        except RecordingNotSaved as exc:
            return self._save_elsewhere(name, recorder, fallback, self._save_error or str(exc))
        except Exception as exc:  # noqa: BLE001 - reported, never raised at shut-down
            return f"dropped the recording in progress {name}: {exc}"
        return f"saved the recording in progress: {info.name} in {self.store.directory} ({info.size_bytes} bytes)"

    def _save_elsewhere(self, name: str, recorder: SceneRecorder, fallback: Path | None, why: str) -> str:
        folder = Path(fallback) if fallback is not None else Path(tempfile.gettempdir()) / "contactnet-recordings"
        try:
            store = RecordingStore(folder, recover=False)
            name = store.free_name(name[: -len(".viser")])
            store.save(recorder.finish(), name, recorder.meta(self._title), recorder.track_data())
        except Exception as exc:  # noqa: BLE001 - reported, never raised at shut-down
            journal = self._journal
            kept = (
                f"; its journal keeps {journal.records} part(s) of it: the next start recovers them"
                if journal is not None and journal.records
                else ""
            )
            return f"could not save the recording in progress {name} ({why}), nor in {folder} ({exc}){kept}"
        self._end(self._name or name)
        return f"saved the recording in progress: {name} in {folder} (the recordings folder refused it: {why})"

    def close(self) -> None:
        """Drop the recorder; a recording not saved keeps its journal (the next start recovers it)."""
        with self._lock:
            if self._recorder is not None:
                self._recorder.close()
                self._recorder = None
            if self._journal is not None:
                self._journal.close()
                self._journal = None
