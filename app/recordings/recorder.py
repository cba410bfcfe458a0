"""Recording the scene over time (.viser files), listing them, and exporting self-contained HTML.

`SceneRecorder` draws `LiveView`s with the same `LiveScene` as the browser, on its own viser
server, and serializes that server's scene messages (viser's `get_scene_serializer`). Keeping
the recording on a separate server means it has its own, lower rate (12 Hz by default: the
serializer keeps every message in memory) and no editing gizmos; the live view is untouched. A
headless server on a free loopback port is enough, so a plain loop can record too::

    with SceneRecorder() as recorder:          # its own headless viser server
        tracker = ViewTracker(loco.robot, loco.terrain, loco.gait)
        while not loco.done:
            loco.advance(10)
            recorder.add(view_of(loco, tracker))   # app.recordings.recorder.view_of
        Path("demo.viser").write_bytes(recorder.finish())

A recording holds the 3D scene only, so the recorder also draws the status line and the gait schedule
into it (`app.recordings.overlay`), and keeps what it recorded (terrain, gait, planner, duration, how the
run ended: `SceneRecorder.meta`, `app.recordings.meta`) for the metadata file saved next to the recording, and
its data track (`SceneRecorder.track_data`, `app.recordings.track`: per frame and per plan, in simulated time, with
the pushes, stands, falls, goal and restarts) for the player's timeline and plots, saved next to it too.

`RecordingStore` (`app.recordings.store`) lists, renames and deletes the files of the recordings folder
with their metadata; `LiveRecorder` (`app.recordings.live_recorder`) records the live session with a
`SceneRecorder`. The viser client plays a file with `?playbackPath=URL` (play, pause, scrub);
`viser_html(data)` wraps a recording into one HTML file that plays anywhere.

`FileRecording` is what `contactnet simulate --record FILE.viser` uses: it checks the path and
reserves a temporary file next to it before the simulation starts (a bad path fails at once, not
after a long run), records frames as the loop goes, and replaces the target atomically at the end
(with its metadata file, ``NAME.viser.json``).
`read_recording(data)` checks that bytes are a .viser recording and says what is in it.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import socket
import tempfile
import time
from pathlib import Path

import numpy as np
import viser

from app.live.settings import RECORD_RATE_RANGE_HZ
from app.live.view import LiveView, RunInfo, SessionStatus, ViewTracker
from app.recordings.meta import MetaCollector, RecordingMeta, write_meta
from app.recordings.overlay import StatusOverlay
from app.recordings.store import RECORDING_NAME, RecordingInfo, RecordingStore
from app.recordings.track import TrackCollector, write_track
from app.recordings.viser_files import RecordingContents, read_recording, viser_html
from app.scene.live_scene import LiveScene
from contactnet.atomic import atomic_write_bytes
from contactnet.robots import DEFAULT_ROBOT, Robot, load_robot

log = logging.getLogger("contactnet.app.recordings")

__all__ = [  # the store's names are imported from here too
    "RECORDING_NAME",
    "FileRecording",
    "RecordingContents",
    "RecordingInfo",
    "RecordingStore",
    "SceneRecorder",
    "read_recording",
    "view_of",
    "viser_html",
]

DEFAULT_RATE_HZ = 12.0
FRAME_SLACK_S = 5e-4
MAX_DURATION_S = 600.0  # a recording stops itself after 10 simulated minutes (memory bound)


def free_port(host: str = "127.0.0.1") -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind((host, 0))
        return sock.getsockname()[1]


def quiet_viser_server(host: str = "127.0.0.1", port: int | None = None) -> viser.ViserServer:
    """A ViserServer without its banner on stdout (viser prints it even with verbose=False)."""
    with contextlib.redirect_stdout(io.StringIO()):
        return viser.ViserServer(host=host, port=port or free_port(host), verbose=False)


def stop_quietly(server: viser.ViserServer) -> None:
    with contextlib.redirect_stdout(io.StringIO()):
        server.stop()


class SceneRecorder:
    """Records `LiveView`s into a .viser scene at `rate_hz` of simulated time.

    `server`: a viser server to draw on and serialize; by default a headless one on a free
    loopback port, owned (and stopped) by the recorder. `robot`: the robot drawn (default Solo12).
    `overlay`: draw the status line and gait strip into the scene (`app.recordings.overlay`): a recording
    has no panel. `meta(title)` is what was recorded (`app.recordings.meta`). Use from one thread."""

    def __init__(
        self,
        server: viser.ViserServer | None = None,
        *,
        robot: Robot | None = None,
        rate_hz: float = DEFAULT_RATE_HZ,
        max_duration_s: float = MAX_DURATION_S,
        overlay: bool = True,
    ):
        low, high = RECORD_RATE_RANGE_HZ
        if not low <= rate_hz <= high:
            raise ValueError(f"rate_hz must be in [{low:g}, {high:g}], got {rate_hz}")
        self._own_server = server is None
        self.server = server if server is not None else quiet_viser_server()
        robot = robot if robot is not None else load_robot(DEFAULT_ROBOT)
        self.scene = LiveScene(self.server, robot)
        self.overlay = StatusOverlay(self.server, robot.description.leg_names) if overlay else None
        self.collector = MetaCollector()
        self.track = TrackCollector()  # what a viewer studies: events, plans, velocities (app.recordings.track)
        self.rate_hz = rate_hz
        self.max_duration_s = max_duration_s
        self._serializer = None
        self._last_t: float | None = None
        self._last_view: LiveView | None = None  # the last view recorded
        self._pending: LiveView | None = None  # a later one that ended the run, not (yet) due
        self.frames = 0
        self.duration_s = 0.0
        self._data: bytes | None = None

    @property
    def full(self) -> bool:
        return self.duration_s >= self.max_duration_s

    @property
    def serializer(self):  # noqa: ANN201 - viser's StateSerializer
        """viser's scene serializer (None before the first frame and once finished): what a journal reads."""
        return self._serializer if self._data is None else None

    def add(self, view: LiveView) -> bool:
        """Record `view` if a frame is due (every 1 / rate_hz s of simulated time); True if recorded."""
        if self._data is not None:
            raise RecordingConflict("this recording is finished")
        t = float(view.snapshot.t_s)
        if self._serializer is None:
            position, look_at = overview_camera(view.terrain)
            camera = self.server.initial_camera  # recorded: where playback starts looking from
            camera.up = (0.0, 0.0, 1.0)
            camera.look_at = tuple(look_at)
            camera.position = tuple(position)
            self._draw(view)
            self._serializer = self.server.get_scene_serializer()
        else:
            if self.full:
                return False
            # Half a tick of slack: a loop stepping by whole 1 ms ticks reaches 1/12 s at 83 ms.
            if self._last_t is not None and 0.0 <= t - self._last_t < 1.0 / self.rate_hz - FRAME_SLACK_S:
                if self._last_view is not None and _outcome(view) != _outcome(self._last_view):
                    self._pending = view  # a fall or the goal between two frames: `finish` draws it if last
                self.track.observe(view)  # a push, a plan or a fall between two frames is on the track all the same
                return False
            self._sleep_until(t)
            self._draw(view)
        self._recorded(view, t)
        return True

    def _sleep_until(self, t: float) -> None:
        # After a reset the simulated clock goes back: continue one period later.
        dt = t - self._last_t if self._last_t is not None and t >= self._last_t else 1.0 / self.rate_hz
        self._serializer.insert_sleep(dt)
        self.duration_s += dt

    def _recorded(self, view: LiveView, t: float) -> None:
        self._last_t, self._last_view, self._pending = t, view, None
        self.frames += 1
        self.collector.add(view)
        self.track.frame(view, self.duration_s, 1.0 / self.rate_hz)

    def _draw(self, view: LiveView) -> None:
        self.scene.update(view)
        if self.overlay is not None:
            with self.server.atomic():
                self.overlay.update(view)

    def meta(self, title: str = "") -> RecordingMeta:
        """What this recording shows so far (terrain, gait, planner, duration, how the run ended)."""
        return self.collector.meta(self.duration_s, self.frames, title)

    def track_data(self) -> dict:
        """The data track so far (`app.recordings.track`): frames, plans and events in simulated time."""
        return self.track.to_dict(self.duration_s)

    def finish(self) -> bytes:
        """The .viser bytes (call once; stops an owned server). A run that ended (fell, reached the goal) after the
        last recorded frame gets one more frame: the recording shows how it ended."""
        if self._data is None:
            if self._serializer is None:
                raise RecordingConflict("nothing recorded")
            pending = self._pending
            if pending is not None:  # the run ended after the last frame: the recording shows how
                t = float(pending.snapshot.t_s)
                self._sleep_until(t)
                self._draw(pending)
                self._recorded(pending, t)
            self._serializer.insert_sleep(1.0 / self.rate_hz)
            self._data = self._serializer.serialize()
            self.close()
        return self._data

    def close(self) -> None:
        if self._own_server and self.server is not None:
            stop_quietly(self.server)
            self.server = None

    def __enter__(self) -> SceneRecorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _outcome(view: LiveView) -> tuple[str | None, str | None]:
    return view.status.done, view.status.error


def overview_camera(terrain) -> tuple[np.ndarray, np.ndarray]:  # noqa: ANN001 - a Terrain
    """(position, look_at) of a camera that sees the whole terrain from behind and to the right."""
    minx, miny, maxx, maxy = terrain.bounds
    look_at = np.array([(minx + maxx) / 2, (miny + maxy) / 2, terrain.surface_z])
    extent = max(maxx - minx, maxy - miny, 0.5)
    return look_at + extent * np.array([-0.35, -0.75, 0.55]), look_at


def view_of(loco, tracker: ViewTracker, label: str = "") -> LiveView:
    """A LiveView of a Locomotion driven by a plain loop (no live session): for SceneRecorder."""
    snap = loco.snapshot()
    t = loco.t_s
    push_force = np.zeros(3)
    for push in loco.sim.pushes:
        if push.active(t):
            push_force += push.force_world
    done = (
        f"fell: {loco.fall_reason}" if loco.fall_reason else ("goal reached" if loco.reached_goal else None)
    )
    planner = getattr(loco.planner, "name", type(loco.planner).__name__)
    status = SessionStatus(
        running=not done,
        paused=False,
        done=done,
        speed=1.0,
        real_time_factor=0.0,
        terrain=label or loco.terrain.name,
        gait=loco.gait.name,
        planner=planner,
        planner_active=planner,
        planner_note=None,
        noise=loco.sim.config.joint_vel_noise_var > 0,
        pushes=len(loco.sim.pushes),
        robot=loco.robot.name,
        retarget=loco.config.retarget is not None,
    )
    start_x, goal_x = float(loco.terrain.start_xy[0]), float(loco.terrain.goal_x)
    span = goal_x - start_x
    run = RunInfo(
        progress=float(np.clip((snap.q[0] - start_x) / span, 0.0, 1.0)) if span > 0 else 0.0,
        start_x_m=start_x,
        goal_x_m=goal_x,
    )
    return LiveView(
        seq=loco.tick,
        snapshot=snap,
        status=status,
        terrain=loco.terrain,
        terrain_version=0,
        gait=loco.gait,
        push_force_world=push_force,
        wall_time_s=time.monotonic(),
        run=run,
        **tracker.update(snap, loco),
    )


class RecordingPathError(ValueError):
    """A recording cannot be written where asked (one-line message)."""


def reserve_output(path: str | os.PathLike) -> tuple[Path, Path]:
    """Check that a .viser file can be written at `path` and create the temporary file (same folder,
    hidden) that `FileRecording.save` later renames onto it. Returns (path, temporary path)."""
    path = Path(path)
    if path.suffix != ".viser":
        raise RecordingPathError(f"recording file {path}: the name must end in .viser")
    if path.is_dir():
        raise RecordingPathError(f"recording file {path}: is a folder")
    folder = path.parent
    if not folder.exists():
        raise RecordingPathError(f"recording file {path}: folder {folder} does not exist")
    if not folder.is_dir():
        raise RecordingPathError(f"recording file {path}: {folder} is not a folder")
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise RecordingPathError(
            f"recording file {path}: cannot write in {folder} ({exc.strerror or type(exc).__name__})"
        ) from None
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; a recording is an ordinary file
    return path, Path(tmp)


class FileRecording:
    """Records a `Locomotion` driven by a plain loop into one .viser file.

    The constructor checks the path and reserves a temporary file (`RecordingPathError` if it
    cannot); call `add(loco)` whenever the loop has advanced (a frame is kept every 1 / rate_hz
    simulated seconds: step the loop by `period_s`), then `save()`; `close()` (or leaving the
    `with` block) removes the temporary file if nothing was saved. The robot drawn is the loop's."""

    def __init__(
        self,
        path: str | os.PathLike,
        rate_hz: float = DEFAULT_RATE_HZ,
        max_duration_s: float = MAX_DURATION_S,
    ):
        self.path, self._tmp = reserve_output(path)
        self.rate_hz = rate_hz
        self._max_duration_s = max_duration_s
        self._recorder: SceneRecorder | None = None
        self._tracker: ViewTracker | None = None
        self.size_bytes = 0

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def frames(self) -> int:
        return self._recorder.frames if self._recorder else 0

    @property
    def duration_s(self) -> float:
        return self._recorder.duration_s if self._recorder else 0.0

    @property
    def full(self) -> bool:
        """True once the recording reached max_duration_s (later frames are dropped)."""
        return self._recorder is not None and self._recorder.full

    def add(self, loco) -> bool:  # noqa: ANN001 - a contactnet.locomotion.Locomotion
        """Record the loop's current state if a frame is due; True if recorded."""
        if self._recorder is None:
            self._recorder = SceneRecorder(
                robot=loco.robot, rate_hz=self.rate_hz, max_duration_s=self._max_duration_s
            )
            self._tracker = ViewTracker(loco.robot, loco.terrain, loco.gait)
        return self._recorder.add(view_of(loco, self._tracker))

    def save(self) -> Path:
        """Write the recording (temporary file, then an atomic rename onto the path) and its metadata next to it
        (``NAME.viser.json``)."""
        if self._recorder is None:
            raise RecordingConflict("nothing recorded")
        data = self._recorder.finish()
        atomic_write_bytes(self.path, data)
        self._tmp.unlink(missing_ok=True)
        try:  # what the recordings list shows (app.recordings.meta); the recording itself is saved
            write_meta(self.path, self._recorder.meta())
            write_track(self.path, self._recorder.track_data())  # what the player plots (app.recordings.track)
        except OSError as exc:
            log.warning("recording %s: metadata not saved (%s)", self.path.name, exc.strerror or exc)
        self.size_bytes = len(data)
        return self.path

    def close(self) -> None:
        if self._recorder is not None:
            self._recorder.close()
        self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> FileRecording:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class RecordingConflict(RuntimeError):
    """Not possible in the recorder's current state (already recording, not recording, nothing recorded)."""
