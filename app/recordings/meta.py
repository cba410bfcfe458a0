"""What a recording is about: `RecordingMeta` (its title, robot, terrain, gait, planner, simulated duration,
frames, how the run ended, when it was made), kept in a small JSON file next to the .viser file: the
*sidecar* ``NAME.viser.json`` of ``NAME.viser``.

A .viser file holds only the 3D scene; the sidecar is what the recordings list shows. It is optional: a
recording without one (made before sidecars existed, or copied without it) lists with "no metadata", and
one whose sidecar cannot be read (not JSON, wrong fields, too big) lists the same way with the reason,
logged once; neither ever fails a listing. Sidecars are written atomically (`contactnet.atomic`) and read
with `contactnet.strict_json` limits.

`MetaCollector` builds the metadata from the `LiveView`s a recorder is fed (the status of each recorded
frame), so the live recorder and the command line's ``simulate --record`` write the same thing.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from app.live.view import LiveView
from contactnet.atomic import atomic_write_text
from contactnet.strict_json import JsonInputError, JsonLimits, loads_strict

SIDECAR_SUFFIX = ".json"  # run.viser -> run.viser.json
META_FORMAT = "contactnet-recording"
META_VERSION = 1
META_LIMITS = JsonLimits(max_bytes=64_000, max_depth=4, max_values=2_000)
TITLE_MAX_CHARS = 100
TEXT_MAX_CHARS = 300  # any other text field (a fall reason, several gaits joined)
RUNS_MAX = 100  # run results kept (a looping session over 10 simulated minutes ends ~20 runs)
CHANGED = " → "  # a setting changed while recording: "walk → trot"


class MetaError(ValueError):
    """A sidecar that cannot be used (one line: what is wrong)."""


@dataclass(frozen=True)
class RecordingMeta:
    """What one recording shows. Every field but `title` may be unknown (None): a sidecar written by an
    older tool, or only a title given to a recording that had no sidecar."""

    title: str = ""  # the user's title ("" = none yet: lists show the file name)
    robot: str | None = None  # registry name
    terrain: str | None = None  # terrain label; "a → b" when it changed while recording
    gait: str | None = None
    planner: str | None = None  # the planner that ran; "contactnet vs fixed" in compare mode
    duration_s: float | None = None  # simulated seconds recorded
    frames: int | None = None
    result: str | None = None  # "goal reached", "fell: <why>", "error: <what>" or "stopped" (still running)
    runs: tuple[str, ...] = ()  # the result of every run that ended while recording, in order
    created: float | None = None  # Unix time (s) the recording started

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["runs"] = list(self.runs)
        return {"format": META_FORMAT, "version": META_VERSION, **data}

    @classmethod
    def from_dict(cls, data: Any) -> RecordingMeta:
        """The metadata of a sidecar's JSON value; `MetaError` naming the first field that is wrong."""
        if not isinstance(data, dict):
            raise MetaError("not a JSON object")
        if data.get("format") != META_FORMAT:
            raise MetaError(f"format is {_short(data.get('format'))}, expected {META_FORMAT!r}")
        version = data.get("version")
        if not isinstance(version, int) or isinstance(version, bool) or version < 1:
            raise MetaError(f"version is {_short(version)}, expected a positive integer")
        if version > META_VERSION:
            raise MetaError(f"version {version} is newer than this tool's ({META_VERSION})")
        values: dict[str, Any] = {"title": _text(data, "title", TITLE_MAX_CHARS, default="")}
        for key in ("robot", "terrain", "gait", "planner", "result"):
            values[key] = _text(data, key, TEXT_MAX_CHARS)
        values["duration_s"] = _number(data, "duration_s")
        values["created"] = _number(data, "created")
        frames = data.get("frames")
        if frames is not None and (not isinstance(frames, int) or isinstance(frames, bool) or frames < 0):
            raise MetaError(f"frames is {_short(frames)}, expected a count")
        values["frames"] = frames
        runs = data.get("runs", [])
        if not isinstance(runs, list) or len(runs) > RUNS_MAX:
            raise MetaError(f"runs: expected a list of at most {RUNS_MAX} results")
        if not all(isinstance(r, str) and len(r) <= TEXT_MAX_CHARS for r in runs):
            raise MetaError("runs: expected short texts")
        values["runs"] = tuple(runs)
        return cls(**values)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _text(data: dict, key: str, limit: int, default: str | None = None) -> str | None:
    value = data.get(key, default)
    if value is None:
        return default
    if not isinstance(value, str) or len(value) > limit:
        raise MetaError(f"{key} is {_short(value)}, expected a text of at most {limit} characters")
    return value


def _number(data: dict, key: str) -> float | None:
    value = data.get(key)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value < 0:
        raise MetaError(f"{key} is {_short(value)}, expected a number >= 0")
    return float(value)


def sidecar_path(recording: Path) -> Path:
    """``run.viser`` -> ``run.viser.json`` (never matches ``*.viser``, so it never lists as a recording)."""
    return recording.with_name(recording.name + SIDECAR_SUFFIX)


def write_meta(recording: Path, meta: RecordingMeta) -> Path:
    """Write the sidecar of the recording at path `recording` atomically (a reader sees the old or the new)."""
    return atomic_write_text(sidecar_path(recording), json.dumps(meta.to_dict(), indent=1, allow_nan=False) + "\n")


@dataclass(frozen=True)
class MetaRead:
    """A sidecar as read: `meta` (None without a usable one) and, when None, `note` saying why."""

    meta: RecordingMeta | None
    note: str | None = None


NO_SIDECAR = "no metadata (recorded without it)"


def read_meta(recording: Path) -> MetaRead:
    """The metadata of the recording at path `recording`; never raises for a missing or bad sidecar."""
    path = sidecar_path(recording)
    try:
        data = path.read_bytes() if path.stat().st_size <= META_LIMITS.max_bytes else None
    except FileNotFoundError:
        return MetaRead(None, NO_SIDECAR)
    except OSError as exc:
        return MetaRead(None, f"metadata unreadable: {exc.strerror or type(exc).__name__}")
    if data is None:
        return MetaRead(None, f"metadata unreadable: over {META_LIMITS.max_bytes} bytes")
    try:
        return MetaRead(RecordingMeta.from_dict(loads_strict(data, source=path.name, limits=META_LIMITS)))
    except JsonInputError as exc:
        return MetaRead(None, f"metadata unreadable: {exc}")
    except MetaError as exc:
        return MetaRead(None, f"metadata unreadable: {path.name}: {exc}")


class MetaCollector:
    """Builds a recording's `RecordingMeta` from the views it records (`add` per recorded frame)."""

    def __init__(self, created: float | None = None):
        self.created = time.time() if created is None else created
        self._seen: dict[str, list[str]] = {"robot": [], "terrain": [], "gait": [], "planner": []}
        self._runs: list[str] = []
        self._done: str | None = None
        self._error: str | None = None
        self._summaries_seen: int | None = None  # the session's finished-run count (LiveView.run.runs)
        self._unmatched_done = 0  # run ends seen as `status.done` but not (yet) as a run summary
        self._unmatched_summaries = 0  # and the other way round

    def add(self, view: LiveView) -> None:
        status = view.status
        compare = getattr(view, "compare", None)  # compare mode: the other robots' planners
        planner = status.planner_active or status.planner
        if compare:
            planner = " vs ".join([planner, *(getattr(c, "planner", "?") for c in compare)])
        for key, value in (
            ("robot", status.robot),
            ("terrain", status.terrain),
            ("gait", status.gait),
            ("planner", planner),
        ):
            seen = self._seen[key]
            if value and (not seen or seen[-1] != value):
                seen.append(value)
        # A run ends as `status.done` turning on (every session) and as a new run summary (the live session,
        # which also ends runs that are not done: "stopped: ..."): count each end once.
        if status.done and status.done != self._done:
            if self._unmatched_summaries:
                self._unmatched_summaries -= 1
            else:
                self._unmatched_done += 1
                self._add_run(status.done)
        run = getattr(view, "run", None)
        runs = getattr(run, "runs", 0)
        if self._summaries_seen is not None and runs > self._summaries_seen and run.last_run is not None:
            if self._unmatched_done:
                self._unmatched_done -= 1
            else:
                self._unmatched_summaries += 1
                self._add_run(run.last_run.reason)
        self._summaries_seen = runs
        self._done = status.done
        self._error = status.error

    def _add_run(self, result: str) -> None:
        if len(self._runs) < RUNS_MAX:
            self._runs.append(result[:TEXT_MAX_CHARS])

    def meta(self, duration_s: float, frames: int, title: str = "") -> RecordingMeta:
        """The metadata so far; `result` is how the last recorded frame stood."""
        if self._done:
            result = self._done
        elif self._error:
            result = f"error: {self._error}"
        else:
            result = "stopped"
        return RecordingMeta(
            title=title[:TITLE_MAX_CHARS],
            duration_s=round(float(duration_s), 3),
            frames=int(frames),
            result=result[:TEXT_MAX_CHARS],
            runs=tuple(self._runs),
            created=self.created,
            **{key: _joined(values) for key, values in self._seen.items()},
        )


def _joined(values: list[str]) -> str | None:
    if not values:
        return None
    text = CHANGED.join(values)
    return text if len(text) <= TEXT_MAX_CHARS else text[: TEXT_MAX_CHARS - 3] + "..."


def retitled(meta: RecordingMeta | None, title: str) -> RecordingMeta:
    """`meta` with a new title (a title alone when there was no metadata)."""
    return replace(meta, title=title) if meta is not None else RecordingMeta(title=title)
