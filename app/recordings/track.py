"""A recording's data track: what the robot and the planner did, frame by frame and plan by plan, in simulated
time, so that a recording can be studied (a timeline with markers, plots in step with the scrubber), not only
watched. A .viser file holds only the scene; the track is kept next to it as the sidecar
``NAME.viser.track.json`` (`track_path`), like the metadata (`app.recordings.meta`).

`TrackCollector` is fed by the scene recorder (`app.recordings.recorder.SceneRecorder`): `frame(view, rec_t)` for
every recorded frame (``rec_t``: the frame's time in the recording, seconds from its start) and `observe(view)` for
every other view it is shown (the live viewer's loop shows it every view the session publishes, so pushes, plans
and run ends between two frames are not missed). It keeps, as columns (lists of equal length):

- ``frames``: ``rec_t``, ``sim_t`` (the run's simulated clock: it goes back to 0 at a restart), ``x`` (m, base),
  ``progress`` (0..1, start to goal), ``vx_cmd``/``vy_cmd`` (the command, m/s, the robot's heading frame),
  ``vx``/``vy`` (the base's measured velocity in its heading frame, m/s, averaged since the previous frame),
  ``steps``, ``stood`` (step horizons stood), ``rank`` (the ranking position of the current step's choice, null
  without a ranking planner), ``run`` (the run's number), ``state`` (an index into ``states``: the first part of
  the live status line, "walking", "FELL (...)", ...) and ``scene`` (an index into ``scenes``: "terrain · gait
  · planner");
- ``plans``: one per step horizon planned: ``rec_t``, ``sim_t``, ``planner_ms``, ``trajopt_ms``, ``rank`` and
  ``stand`` (null when the plan was replaced before a view showed it);
- ``events``: ``{"kind", "rec_t", "sim_t", "text"}`` with kind ``push``, ``stand``, ``fall``, ``goal``, ``end``
  (a run that ended otherwise) or ``restart`` (the simulated clock went back: a new run).

`chunk(since)` gives the rows added since an earlier `marks()` (what a journal appends, `app.recordings.journal`),
`TrackCollector.from_chunks` joins them again. `RecordingTrack.from_dict` checks a track read back (format,
version, equal columns, finite numbers); a recording without a track (made before tracks existed) plays without
one, and the page says so.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from app.live.view import LiveView, is_stand, status_line
from contactnet.atomic import atomic_write_text
from contactnet.strict_json import JsonInputError, JsonLimits, loads_strict

TRACK_SUFFIX = ".track.json"  # run.viser -> run.viser.track.json
TRACK_FORMAT = "contactnet-track"
TRACK_VERSION = 1
#: A 10-minute recording at 12 Hz is about 7200 frames of 15 values (~1 MB of JSON): well within these.
TRACK_LIMITS = JsonLimits(max_bytes=32_000_000, max_depth=4, max_values=4_000_000)
FRAME_KEYS = ("rec_t", "sim_t", "x", "progress", "vx_cmd", "vy_cmd", "vx", "vy", "steps", "stood", "rank", "run",
              "state", "scene")
PLAN_KEYS = ("rec_t", "sim_t", "planner_ms", "trajopt_ms", "rank", "stand")
EVENT_KINDS = ("push", "stand", "fall", "goal", "end", "restart")
INT_KEYS = {"steps", "stood", "rank", "run", "state", "scene"}
NULLABLE_KEYS = {"rank", "stand"}
TEXTS_MAX = 1000  # distinct states or scenes kept (each a short text)
TEXT_MAX_CHARS = 300
RESTART_EPS_S = 1e-6


class TrackError(ValueError):
    """A track file that cannot be used (one line: what is wrong)."""


def track_path(recording: Path) -> Path:
    """``run.viser`` -> ``run.viser.track.json`` (never matches ``*.viser``: it never lists as a recording)."""
    return recording.with_name(recording.name + TRACK_SUFFIX)


def _r(value: float, digits: int = 4) -> float:
    value = float(value)
    return round(value, digits) if math.isfinite(value) else 0.0


def _yaw(q: np.ndarray) -> float:
    x, y, z, w = (float(v) for v in q[3:7])
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


class TrackCollector:
    """Builds a recording's data track from the views it is shown (see the module doc). One thread."""

    def __init__(self) -> None:
        self.frames: dict[str, list] = {key: [] for key in FRAME_KEYS}
        self.plans: dict[str, list] = {key: [] for key in PLAN_KEYS}
        self.events: list[dict[str, Any]] = []
        self.states: list[str] = []
        self.scenes: list[str] = []
        self._index: dict[tuple[str, str], int] = {}
        self._last_t: float | None = None  # simulated time of the last view observed
        self._last_rec_t = 0.0  # and where it lies in the recording
        self._frame_t: float | None = None  # the last frame's simulated time
        self._frame_rec_t = 0.0
        self._frame_pos: np.ndarray | None = None  # the last frame's base position (for the mean velocity)
        self._plan_t = -math.inf  # simulated time of the last plan seen (this run)
        self._pushes = 0
        self._force_on = False  # a push force acted at the last view
        self._done: str | None = None
        self._rate_period_s = 1.0 / 12.0
        self._run = 1  # runs seen: 1 + restarts (a plain loop's views count no runs of their own)

    # ---- feeding ----------------------------------------------------------------------------------------------
    def observe(self, view: LiveView, rec_t: float | None = None) -> None:
        """A view the recorder was shown (recorded or not): its events and plans. ``rec_t``: its time in the
        recording (None: estimated from the last frame)."""
        t = float(view.snapshot.t_s)
        if self._last_t is None:  # the first view: what happened before the recording started is not in it
            self._pushes, self._done = view.status.pushes, view.status.done
            self._force_on = bool(np.any(np.asarray(view.push_force_world[:2]) != 0))
            timing = np.asarray(view.timing, dtype=float).reshape(-1, 3)
            self._plan_t = float(timing[-2, 0]) if len(timing) >= 2 else -math.inf
        restart = self._last_t is not None and t < self._last_t - RESTART_EPS_S
        if rec_t is None:
            if self._frame_t is None:
                rec_t = 0.0
            elif restart or t < self._frame_t:
                rec_t = self._frame_rec_t + self._rate_period_s  # where the recorder puts the next frame
            else:
                rec_t = self._frame_rec_t + (t - self._frame_t)
        rec_t = max(float(rec_t), self._last_rec_t)
        if restart:
            self._run += 1
            self._event("restart", rec_t, t, f"restart: run {max(view.run.runs + 1, self._run)}")
            # a new run: its pushes so far are scheduled ones (`simulate --push`), counted when their force comes on
            self._plan_t, self._pushes, self._done, self._force_on = -math.inf, view.status.pushes, None, False
        self._last_t, self._last_rec_t = t, rec_t
        status = view.status
        # A push is a new one in the session's count (a push from the page) or a force that comes on (a push
        # scheduled from the start, `simulate --push`), counted once.
        fx, fy = (float(v) for v in view.push_force_world[:2])
        force_on = math.hypot(fx, fy) > 1e-9
        added = status.pushes - self._pushes
        if added > 0 or (force_on and not self._force_on):
            text = f"push ({fx:+.1f}, {fy:+.1f}) N" if force_on else "push"
            for _ in range(min(max(added, 1), 10)):
                self._event("push", rec_t, t, text)
            force_on = True  # a push counted before its force shows is not counted again when it does
        self._pushes, self._force_on = status.pushes, force_on
        self._observe_plans(view, rec_t, t)
        done = status.done
        if done and done != self._done:
            kind = "goal" if done == "goal reached" else "fall" if done.startswith("fell") else "end"
            self._event(kind, rec_t, t, done)
        self._done = done

    def _observe_plans(self, view: LiveView, rec_t: float, t: float) -> None:
        timing = np.asarray(view.timing, dtype=float).reshape(-1, 3)
        new = [row for row in timing if self._plan_t < row[0] <= t + RESTART_EPS_S]
        snap = view.snapshot
        for k, (plan_t, planner_ms, trajopt_ms) in enumerate(new):
            last = k == len(new) - 1
            rank = snap.planned_steps[0].rank if last and snap.planned_steps else None
            stand = is_stand(snap) if last else None
            at = rec_t - max(0.0, t - plan_t)
            for key, value in zip(PLAN_KEYS, (_r(max(at, 0.0), 3), _r(plan_t, 3), _r(planner_ms, 3),
                                              _r(trajopt_ms, 3), None if rank is None else int(rank), stand),
                                  strict=True):
                self.plans[key].append(value)
            if stand:
                self._event("stand", max(at, 0.0), float(plan_t), "the planner stood this step")
            self._plan_t = float(plan_t)

    def frame(self, view: LiveView, rec_t: float, period_s: float | None = None) -> None:
        """A recorded frame at ``rec_t`` s of the recording (``period_s``: the recorder's frame period)."""
        if period_s is not None:
            self._rate_period_s = period_s
        self.observe(view, rec_t)
        snap, status, run = view.snapshot, view.status, view.run
        t = float(snap.t_s)
        q = np.asarray(snap.q, dtype=float)
        pos = q[:2].copy()
        if self._frame_t is not None and self._frame_pos is not None and t - self._frame_t > 1e-4:
            v_world = (pos - self._frame_pos) / (t - self._frame_t)
        else:
            v_world = np.asarray(snap.com_vel, dtype=float)[:2]
        yaw = _yaw(q)
        c, s = math.cos(yaw), math.sin(yaw)
        vx, vy = c * v_world[0] + s * v_world[1], -s * v_world[0] + c * v_world[1]
        rank = snap.planned_steps[0].rank if snap.planned_steps else None
        state = status_line(view).split(" · ", 1)[0]
        planner = status.planner_active or status.planner
        if view.compare:
            planner = " vs ".join([planner, *(c.planner for c in view.compare)])
        scene = " · ".join(v for v in (status.terrain, status.gait, planner) if v)
        values = {
            "rec_t": _r(rec_t, 3), "sim_t": _r(t, 3), "x": _r(q[0]), "progress": _r(run.progress, 3),
            "vx_cmd": _r(snap.vel_cmd_xy[0]), "vy_cmd": _r(snap.vel_cmd_xy[1]), "vx": _r(vx), "vy": _r(vy),
            "steps": int(snap.steps), "stood": int(view.counts.stand_steps),
            "rank": None if rank is None else int(rank),
            "run": max(int(run.runs + (0 if status.done else 1)), self._run),  # the live header's "run N"
            "state": self._text_index("states", state), "scene": self._text_index("scenes", scene),
        }
        for key in FRAME_KEYS:
            self.frames[key].append(values[key])
        self._frame_t, self._frame_rec_t, self._frame_pos = t, float(rec_t), pos

    def _text_index(self, kind: str, text: str) -> int:
        texts = self.states if kind == "states" else self.scenes
        key = (kind, text)
        if key not in self._index:
            if len(texts) >= TEXTS_MAX:
                return len(texts) - 1
            self._index[key] = len(texts)
            texts.append(text[:TEXT_MAX_CHARS])
        return self._index[key]

    def _event(self, kind: str, rec_t: float, sim_t: float, text: str) -> None:
        self.events.append({"kind": kind, "rec_t": _r(rec_t, 3), "sim_t": _r(sim_t, 3),
                            "text": text[:TEXT_MAX_CHARS]})

    # ---- out -------------------------------------------------------------------------------------------------
    def to_dict(self, duration_s: float) -> dict[str, Any]:
        """The track as saved (``duration_s``: the recording's length, s)."""
        return {
            "format": TRACK_FORMAT, "version": TRACK_VERSION, "duration_s": _r(duration_s, 3),
            "states": list(self.states), "scenes": list(self.scenes),
            "frames": {key: list(values) for key, values in self.frames.items()},
            "plans": {key: list(values) for key, values in self.plans.items()},
            "events": [dict(e) for e in self.events],
        }

    def marks(self) -> tuple[int, int, int, int, int]:
        """Where the track is now (frames, plans, events, states, scenes): for `chunk`."""
        return (len(self.frames["rec_t"]), len(self.plans["rec_t"]), len(self.events), len(self.states),
                len(self.scenes))

    def chunk(self, since: tuple[int, int, int, int, int]) -> dict[str, Any]:
        """The rows added since `marks()` returned ``since`` (what a journal record carries)."""
        f, p, e, s, c = since
        return {
            "frames": {key: values[f:] for key, values in self.frames.items()},
            "plans": {key: values[p:] for key, values in self.plans.items()},
            "events": self.events[e:], "states": self.states[s:], "scenes": self.scenes[c:],
        }

    @classmethod
    def from_chunks(cls, chunks: Iterable[dict[str, Any]]) -> TrackCollector:
        """The rows of journal records (`chunk`) joined again (a chunk that does not fit is skipped whole)."""
        track = cls()
        for chunk in chunks:
            try:
                frames = {key: list(chunk["frames"][key]) for key in FRAME_KEYS}
                plans = {key: list(chunk["plans"][key]) for key in PLAN_KEYS}
                events, states, scenes = list(chunk["events"]), list(chunk["states"]), list(chunk["scenes"])
            except (KeyError, TypeError):
                continue
            for key in FRAME_KEYS:
                track.frames[key].extend(frames[key])
            for key in PLAN_KEYS:
                track.plans[key].extend(plans[key])
            track.events.extend(events)
            track.states.extend(states)
            track.scenes.extend(scenes)
        return track


def write_track(recording: Path, track: dict[str, Any]) -> Path:
    """Write the track sidecar of the recording at path `recording` atomically."""
    return atomic_write_text(track_path(recording), json.dumps(track, separators=(",", ":"), allow_nan=False))


def check_track(data: Any) -> dict[str, Any]:
    """The track of a sidecar's JSON value, checked; `TrackError` naming the first thing that is wrong."""
    if not isinstance(data, dict):
        raise TrackError("not a JSON object")
    if data.get("format") != TRACK_FORMAT:
        raise TrackError(f"format is not {TRACK_FORMAT!r}")
    version = data.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= TRACK_VERSION:
        raise TrackError(f"version {version!r} is not one this tool reads (1..{TRACK_VERSION})")
    duration = data.get("duration_s")
    if isinstance(duration, bool) or not isinstance(duration, int | float) or not math.isfinite(duration):
        raise TrackError("duration_s is not a number")
    for key in ("states", "scenes"):
        texts = data.get(key)
        if not isinstance(texts, list) or not all(isinstance(t, str) and len(t) <= TEXT_MAX_CHARS for t in texts):
            raise TrackError(f"{key}: expected a list of short texts")
    for table, keys in (("frames", FRAME_KEYS), ("plans", PLAN_KEYS)):
        columns = data.get(table)
        if not isinstance(columns, dict) or set(columns) != set(keys):
            raise TrackError(f"{table}: expected the columns {', '.join(keys)}")
        lengths = {len(v) if isinstance(v, list) else -1 for v in columns.values()}
        if len(lengths) != 1 or -1 in lengths:
            raise TrackError(f"{table}: the columns are not lists of one length")
        for key, values in columns.items():
            if not all(_fits(key, v) for v in values):
                raise TrackError(f"{table}.{key}: a value is not {'an integer' if key in INT_KEYS else 'a number'}")
    events = data.get("events")
    if not isinstance(events, list):
        raise TrackError("events: expected a list")
    for event in events:
        if (not isinstance(event, dict) or event.get("kind") not in EVENT_KINDS
                or not _fits("rec_t", event.get("rec_t")) or not _fits("sim_t", event.get("sim_t"))
                or not isinstance(event.get("text"), str)):
            raise TrackError("events: expected {kind, rec_t, sim_t, text} with a known kind")
    return data


def _fits(key: str, value: Any) -> bool:
    if value is None:
        return key in NULLABLE_KEYS
    if key == "stand":
        return isinstance(value, bool)
    if isinstance(value, bool):
        return False
    if key in INT_KEYS:
        return isinstance(value, int)
    return isinstance(value, int | float) and math.isfinite(value)


NO_TRACK = "no data track (recorded before tracks were kept): it plays without the timeline's markers and plots"


def read_track(recording: Path) -> dict[str, Any]:
    """The checked track of the recording at path `recording`: FileNotFoundError (`NO_TRACK`) without one,
    `TrackError` for one that cannot be read."""
    path = track_path(recording)
    try:
        data = path.read_bytes() if path.stat().st_size <= TRACK_LIMITS.max_bytes else None
    except FileNotFoundError:
        raise FileNotFoundError(f"{recording.name}: {NO_TRACK}") from None
    except OSError as exc:
        raise TrackError(f"{path.name} unreadable: {exc.strerror or type(exc).__name__}") from None
    if data is None:
        raise TrackError(f"{path.name} unreadable: over {TRACK_LIMITS.max_bytes} bytes")
    try:
        return check_track(loads_strict(data, source=path.name, limits=TRACK_LIMITS))
    except JsonInputError as exc:
        raise TrackError(str(exc)) from None
    except TrackError as exc:
        raise TrackError(f"{path.name}: {exc}") from None


__all__ = ["NO_TRACK", "TRACK_SUFFIX", "TrackCollector", "TrackError", "check_track", "read_track", "track_path",
           "write_track"]
