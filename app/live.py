"""The live session: one Locomotion run in real time in its own thread, driven through a queue.

PyBullet is not thread-safe, so one thread (started by `LiveSession.start`) builds, steps,
rebuilds and closes the `Locomotion` (and with it the `Simulator`). Everyone else - web handlers,
viser callbacks, the scene updater - talks to it in two ways only:
- `submit(command)` puts a command on a queue and returns a Future (resolved once the thread has
  applied it; `call` waits for it);
- `view` is the latest `LiveView`, an immutable picture of the session that the thread replaces
  (one reference assignment) after every chunk of simulation. Readers never lock, and the
  simulation never waits for a reader.

Real-time pacing: the thread advances the simulation in chunks of at most `chunk_ticks` (10 ms)
toward `anchor_sim + speed * (wall - anchor_wall)` and sleeps when it is ahead, which also lets
the web threads run. If it falls more than `max_lag_s` behind (a slow machine), it drops the debt
instead of running in a burst to catch up.

`ViewTracker` turns successive `Snapshot`s into what a viewer draws (CoM path, gait-schedule
history, the candidate footholds of the current step, planner timings). It does not know about
viser either; `app/scene.py` draws a `LiveView`, `app/recordings.py` records it.
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from contactnet.gait import GaitSpec, gait_by_name
from contactnet.locomotion import Locomotion, Snapshot
from contactnet.robot import Solo12
from contactnet.sim import Push, SimConfig
from contactnet.terrain import Terrain

log = logging.getLogger("contactnet.app.live")

GAITS = ("walk", "trot")
PLANNERS = ("contactnet", "fixed", "heuristic")
NOISE_VARIANCE = 0.01  # the paper's joint-velocity noise, (rad/s)^2
VELOCITY_LIMIT = 0.3  # m/s, per axis
PUSH_FORCE_LIMIT = 20.0  # N, magnitude
PUSH_DURATION_LIMIT = 5.0  # s
SPEED_RANGE = (0.1, 2.0)
HISTORY_NODES = 125  # gait-schedule history shown: 125 nodes of 40 ms = 5 s
COM_PATH_POINTS = 4000
COM_PATH_STEP_M = 0.005
TIMING_PLANS = 120


# ---- commands ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SetVelocity:
    vx: float
    vy: float


@dataclass(frozen=True)
class NudgeVelocity:
    """Add (dvx, dvy) to the commanded velocity, clipped to the limits (keyboard shortcuts: applied in
    order by the session thread, so quick presses add up)."""

    dvx: float
    dvy: float


@dataclass(frozen=True)
class ApplyPush:
    fx: float
    fy: float
    duration_s: float


@dataclass(frozen=True)
class Reset:
    pass


@dataclass(frozen=True)
class SetPaused:
    paused: bool


@dataclass(frozen=True)
class TogglePause:
    """Pause a running session, run a paused one, restart one that fell or reached the goal."""


@dataclass(frozen=True)
class SetSpeed:
    speed: float


@dataclass(frozen=True)
class SetGait:
    gait: str


@dataclass(frozen=True)
class SetPlanner:
    planner: str


@dataclass(frozen=True)
class SetNoise:
    on: bool


@dataclass(frozen=True)
class SetTerrain:
    terrain: Terrain
    label: str


Command = (
    SetVelocity
    | NudgeVelocity
    | ApplyPush
    | Reset
    | SetPaused
    | TogglePause
    | SetSpeed
    | SetGait
    | SetPlanner
    | SetNoise
    | SetTerrain
)


def check_command(command: Command) -> None:
    """Reject values the simulation must never see (ValueError). The REST layer checks first, with
    field-level messages; this is the last line for every other caller."""

    def finite(*values: float) -> bool:
        return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)

    if isinstance(command, SetVelocity):
        if not (finite(command.vx, command.vy) and max(abs(command.vx), abs(command.vy)) <= VELOCITY_LIMIT):
            raise ValueError(f"velocity must be finite with |vx|, |vy| <= {VELOCITY_LIMIT} m/s")
    elif isinstance(command, NudgeVelocity):
        if not (
            finite(command.dvx, command.dvy) and max(abs(command.dvx), abs(command.dvy)) <= 2 * VELOCITY_LIMIT
        ):
            raise ValueError(f"velocity change must be finite with |dvx|, |dvy| <= {2 * VELOCITY_LIMIT} m/s")
    elif isinstance(command, ApplyPush):
        if not (
            finite(command.fx, command.fy, command.duration_s)
            and math.hypot(command.fx, command.fy) <= PUSH_FORCE_LIMIT + 1e-9
            and 0.0 < command.duration_s <= PUSH_DURATION_LIMIT
        ):
            raise ValueError(
                f"push needs |f| <= {PUSH_FORCE_LIMIT} N and 0 < duration <= {PUSH_DURATION_LIMIT} s"
            )
    elif isinstance(command, SetSpeed):
        if not (finite(command.speed) and SPEED_RANGE[0] <= command.speed <= SPEED_RANGE[1]):
            raise ValueError(f"speed must be in [{SPEED_RANGE[0]}, {SPEED_RANGE[1]}]")
    elif isinstance(command, SetGait):
        if command.gait not in GAITS:
            raise ValueError(f"unknown gait {command.gait!r}: choose one of {', '.join(GAITS)}")
    elif isinstance(command, SetPlanner):
        if command.planner not in PLANNERS:
            raise ValueError(f"unknown planner {command.planner!r}: choose one of {', '.join(PLANNERS)}")
    elif isinstance(command, SetTerrain):
        if not isinstance(command.terrain, Terrain):
            raise ValueError("SetTerrain needs a validated Terrain")


# ---- planners ------------------------------------------------------------------------------------
def default_planner_factory(
    name: str, gait: GaitSpec, model_dir: str | Path | None = None
) -> tuple[Any, str, str | None]:
    """(planner, name of the planner actually used, note).

    `contactnet` and `fixed` load `{model_dir}/{gait}.pt`, by default the shipped model
    (`contactnet/models/{gait}.pt`). When that file is missing or cannot be used, the session runs
    the heuristic planner instead and the note says why (shown in the status panel and the API)."""
    from contactnet.cli import make_planner
    from contactnet.network import ModelFileError, default_model_path

    if name == "heuristic":
        return make_planner("heuristic", gait), "heuristic", None
    model = default_model_path(gait.name) if model_dir is None else Path(model_dir) / f"{gait.name}.pt"
    try:
        return make_planner(name, gait, model=model), name, None
    except ModelFileError as exc:
        if model.exists():
            log.warning("the %s model cannot be used: %s", gait.name, exc)
            note = f"{name} planner unavailable, {exc}: using heuristic"
        else:
            note = (
                f"{name} planner: no trained {gait.name} model yet ({model.name} not found): using heuristic"
            )
    except Exception as exc:  # noqa: BLE001 - keep the tool usable whatever went wrong
        log.exception("could not build the %s planner", name)
        note = f"the {name} planner could not be built ({exc}): using heuristic"
    return make_planner("heuristic", gait), "heuristic", note


# ---- what viewers see ----------------------------------------------------------------------------
@dataclass(frozen=True)
class CandidateView:
    """Candidate footholds of the current step, world XY, with what is known about each.

    `rank` is the planner's ranking position (0 = best) when the planner ranks candidates, else
    None; `chosen` indexes the candidate(s) taken (one per swinging leg), when on the grid."""

    xy_world: np.ndarray  # (N, 2)
    safe: np.ndarray  # (N,) bool
    leg: np.ndarray  # (N,) int, the leg each candidate belongs to
    rank: np.ndarray | None = None  # (N,) int
    chosen: tuple[int, ...] = ()


@dataclass(frozen=True)
class SessionStatus:
    running: bool  # advancing (not paused, not done)
    paused: bool
    done: str | None  # "fell: ..." or "goal reached"
    speed: float
    real_time_factor: float  # simulated / wall time over the last ~2 s of running
    terrain: str
    gait: str
    planner: str  # as asked
    planner_active: str  # as used
    planner_note: str | None
    noise: bool
    pushes: int  # pushes applied since the last (re)start
    error: str | None = None


@dataclass(frozen=True)
class LiveView:
    """One immutable picture of the session (world frame, SI units)."""

    seq: int
    snapshot: Snapshot
    status: SessionStatus
    terrain: Terrain
    terrain_version: int
    gait: GaitSpec
    foot_pos_world: np.ndarray  # (4, 3) foot-ball centres
    candidates: CandidateView | None
    com_path: np.ndarray  # (M, 3) actual CoM positions so far (decimated)
    stance_history: np.ndarray  # (K, 4) bool planned stance per node, oldest first
    stance_history_node0: int  # node index of stance_history[0]
    planned_contact: np.ndarray  # (H, 4) bool contact plan from plan_t0_s
    plan_t0_s: float
    timing: np.ndarray  # (P, 3): sim time of each plan, planner ms, optimizer ms
    push_force_world: np.ndarray  # (3,) sum of the active pushes
    wall_time_s: float  # when the view was made (time.monotonic())


class ViewTracker:
    """Turns successive snapshots of one Locomotion into `LiveView` parts. Use from one thread
    (it runs forward kinematics on the robot model it is given)."""

    def __init__(self, robot: Solo12, terrain: Terrain, gait: GaitSpec):
        self.robot = robot
        self.terrain = terrain
        self.gait = gait
        self.reset()

    def reset(self) -> None:
        self._steps_seen = -1
        self._candidates: CandidateView | None = None
        self._com_buffer = np.zeros((256, 3))
        self._com_n = 0
        self._stance: deque[np.ndarray] = deque(maxlen=HISTORY_NODES)
        self._stance_array = np.ones((0, 4), dtype=bool)
        self._last_node = -1
        self._timing: deque[tuple[float, float, float]] = deque(maxlen=TIMING_PLANS)
        self._timing_array = np.zeros((0, 3))
        self._planned_contact = np.ones((0, 4), dtype=bool)
        self._plan_t0_s = 0.0

    def update(self, snap: Snapshot) -> dict[str, Any]:
        """The LiveView fields derived from `snap` (arrays are fresh or unchanged objects)."""
        gait = self.gait
        q = snap.q
        foot_pos = self.robot.foot_positions_world(q)
        if snap.steps != self._steps_seen:
            self._steps_seen = snap.steps
            if snap.planned_steps:
                self._candidates = self._candidate_view(snap)
                self._timing.append((snap.t_s, snap.last_planner_ms, snap.last_trajopt_ms))
                self._timing_array = np.array(self._timing)
                step_s = gait.step_duration_s
                self._plan_t0_s = math.floor(snap.t_s / step_s + 1e-6) * step_s
                self._planned_contact = gait.horizon_contact([s.legs for s in snap.planned_steps])
        node = int(snap.t_s / gait.node_dt_s + 1e-6)
        if node != self._last_node:
            first = node if self._last_node < 0 else self._last_node + 1
            for _ in range(first, node + 1):
                self._stance.append(np.asarray(snap.stance, dtype=bool).copy())
            self._last_node = node
            self._stance_array = np.array(self._stance)
        if snap.t_s > 0.0:  # before the first tick the controller has no CoM yet
            self._add_com_point(np.asarray(snap.com_pos, dtype=float))
        return {
            "foot_pos_world": foot_pos,
            "candidates": self._candidates,
            "com_path": self._com_buffer[: self._com_n],
            "stance_history": self._stance_array,
            "stance_history_node0": self._last_node - len(self._stance) + 1,
            "planned_contact": self._planned_contact,
            "plan_t0_s": self._plan_t0_s,
            "timing": self._timing_array,
        }

    def _add_com_point(self, com: np.ndarray) -> None:
        """Append to the CoM path when it moved COM_PATH_STEP_M. Points below the count are never
        overwritten in place (views handed out stay valid); a full buffer is replaced by a new one."""
        n = self._com_n
        if n and np.linalg.norm(com - self._com_buffer[n - 1]) < COM_PATH_STEP_M:
            return
        if n == len(self._com_buffer):
            keep = self._com_buffer[n // 2 : n] if n >= COM_PATH_POINTS else self._com_buffer[:n]
            self._com_buffer = np.zeros((max(2 * len(keep), 256), 3))
            self._com_buffer[: len(keep)] = keep
            n = len(keep)
        self._com_buffer[n] = com
        self._com_n = n + 1

    def _candidate_view(self, snap: Snapshot) -> CandidateView:
        """The planner's own ranking when the snapshot carries one (a future `Snapshot.candidates`
        with xy_world, safe, rank, chosen), else the candidate grid of the legs of the current step
        around their hip references, coloured by safety."""
        ranked = getattr(snap, "candidates", None)
        if ranked is not None:
            xy = np.asarray(ranked.xy_world, dtype=float)
            leg = np.asarray(getattr(ranked, "leg", np.full(len(xy), -1)), dtype=int)
            chosen = getattr(ranked, "chosen", None)
            chosen_t = () if chosen is None else tuple(np.atleast_1d(chosen).astype(int).tolist())
            return CandidateView(
                xy_world=xy,
                safe=np.asarray(ranked.safe, dtype=bool),
                leg=leg,
                rank=np.asarray(ranked.rank, dtype=int),
                chosen=chosen_t,
            )
        step = snap.planned_steps[0]
        legs = list(step.legs)
        base_xy = np.asarray(snap.q[:2], dtype=float)
        x, y, z, w = snap.q[3:7]
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        c, s = math.cos(yaw), math.sin(yaw)
        hip_ref = base_xy + self.robot.foot_nominal_base[:, :2] @ np.array([[c, s], [-s, c]])
        grid = self.gait.candidates_world(hip_ref, yaw)[legs]  # (L, C, 2)
        xy = grid.reshape(-1, 2)
        leg = np.repeat(np.asarray(legs, dtype=int), grid.shape[1])
        chosen = []
        half_spacing = 0.5 * self.gait.grid_spacing_m
        for j, foothold in enumerate(np.asarray(step.footholds_xy_world)):
            distance = np.linalg.norm(grid[j] - foothold, axis=1)
            k = int(np.argmin(distance))
            if distance[k] < half_spacing:
                chosen.append(j * grid.shape[1] + k)
        return CandidateView(xy_world=xy, safe=self.terrain.is_safe(xy), leg=leg, chosen=tuple(chosen))


def gait_chart(view: LiveView) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The gait schedule as step shapes: (t (S,), past stance (S, 4), planned stance (S, 4)) with
    two samples per node boundary, NaN-free (0/1 values; the plot maps them to bars)."""
    dt = view.gait.node_dt_s
    now_node = view.stance_history_node0 + len(view.stance_history) - 1
    plan_node0 = int(round(view.plan_t0_s / dt))
    future = view.planned_contact[max(0, now_node + 1 - plan_node0) :]
    nodes = len(view.stance_history) + len(future)
    if nodes == 0:
        return np.zeros(2), np.zeros((2, 4)), np.zeros((2, 4))
    past = np.zeros((nodes, 4))
    planned = np.zeros((nodes, 4))
    past[: len(view.stance_history)] = view.stance_history
    planned[len(view.stance_history) :] = future
    edges = (view.stance_history_node0 + np.arange(nodes + 1)) * dt
    t = np.stack([edges[:-1], edges[1:]], axis=1).ravel()
    return t, np.repeat(past, 2, axis=0), np.repeat(planned, 2, axis=0)


# ---- the session ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class SessionConfig:
    """How a live session starts."""

    terrain: Terrain
    terrain_label: str = "stepping_stones"
    gait: str = "walk"
    planner: str = "contactnet"
    vx: float = 0.05
    vy: float = 0.0
    noise: bool = False
    speed: float = 1.0
    paused: bool = False
    chunk_ticks: int = 10
    max_lag_s: float = 1.0
    publish_period_s: float = 1.0 / 60.0


@dataclass
class _Stats:
    running_wall_s: float = 0.0
    running_sim_s: float = 0.0
    lag_resets: int = 0
    longest_stall_s: float = 0.0  # longest wall time between two loop iterations while running
    history: deque = field(default_factory=lambda: deque(maxlen=240))  # (wall, sim running totals)


class LiveSession:
    """A Locomotion run in real time in its own thread (see the module docstring)."""

    def __init__(
        self,
        config: SessionConfig,
        planner_factory: Callable[[str, GaitSpec], tuple[Any, str, str | None]] = default_planner_factory,
        robot_cache_dir=None,
    ):
        self.config = config
        self._planner_factory = planner_factory
        self._robot_cache_dir = robot_cache_dir
        self._commands: queue.Queue[tuple[Command | None, Future]] = queue.Queue()
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._stop = False
        self._view: LiveView | None = None
        self._startup_error: BaseException | None = None
        self.stats = _Stats()

    # ---- the public side (any thread) ------------------------------------------------------------
    def start(self, timeout: float = 60.0) -> LiveSession:
        self._thread = threading.Thread(target=self._run, name="live-session", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout):
            raise TimeoutError("the live session did not start in time")
        if self._startup_error is not None:
            raise RuntimeError(
                f"the live session failed to start: {self._startup_error}"
            ) from self._startup_error
        return self

    def stop(self, timeout: float = 10.0) -> None:
        if self._thread is None:
            return
        self._stop = True
        self._commands.put((None, Future()))
        self._thread.join(timeout)
        self._thread = None

    def submit(self, command: Command) -> Future:
        """Queue a command; the Future resolves (to None) when the session thread has applied it,
        or carries the error that stopped it."""
        future: Future = Future()
        try:
            check_command(command)
        except ValueError as exc:
            future.set_exception(exc)
            return future
        if self._thread is None or not self._thread.is_alive():
            future.set_exception(RuntimeError("the live session is not running"))
            return future
        self._commands.put((command, future))
        return future

    def call(self, command: Command, timeout: float = 30.0) -> None:
        self.submit(command).result(timeout)

    @property
    def view(self) -> LiveView | None:
        return self._view

    def wait_view(self, predicate: Callable[[LiveView], bool], timeout: float = 10.0) -> LiveView:
        """Block until the latest view satisfies predicate (tests, benchmarks)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            view = self._view
            if view is not None and predicate(view):
                return view
            time.sleep(0.005)
        raise TimeoutError("condition on the live view not met in time")

    # ---- the session thread ------------------------------------------------------------------------
    def _run(self) -> None:
        try:
            self._robot = Solo12.load(self._robot_cache_dir)
            cfg = self.config
            self._terrain, self._terrain_label = cfg.terrain, cfg.terrain_label
            self._terrain_version = 0
            self._gait_name, self._planner_name, self._noise = cfg.gait, cfg.planner, cfg.noise
            self._vel = (cfg.vx, cfg.vy)
            self._speed = cfg.speed
            self._paused = cfg.paused
            self._error: str | None = None
            self._seq = 0
            self._loco: Locomotion | None = None
            self._build()
        except BaseException as exc:  # noqa: BLE001 - reported to start()
            log.exception("live session failed to start")
            self._startup_error = exc
            self._ready.set()
            return
        self._ready.set()
        try:
            self._loop()
        finally:
            if self._loco is not None:
                self._loco.close()

    def _build(self) -> None:
        """(Re)build the Locomotion (and its PyBullet world) for the current settings."""
        gait = gait_by_name(self._gait_name)
        planner, active, note = self._planner_factory(self._planner_name, gait)
        sim_config = SimConfig(joint_vel_noise_var=NOISE_VARIANCE if self._noise else 0.0)
        loco = Locomotion(self._robot, self._terrain, gait, planner, sim_config, vel_cmd_xy=self._vel)
        if self._loco is not None:
            self._loco.close()
        self._loco = loco
        self._planner_active, self._planner_note = active, note
        self._tracker = ViewTracker(self._robot, self._terrain, gait)
        self._after_restart()

    def _after_restart(self) -> None:
        self._pushes: list[Push] = []
        self._done: str | None = None
        self._tracker.reset()
        self._anchor()
        self._publish()

    def _anchor(self) -> None:
        self._anchor_wall = time.perf_counter()
        self._anchor_sim = self._loco.t_s
        self._last_tick_wall = self._anchor_wall
        self._last_publish = 0.0

    @property
    def _running(self) -> bool:
        return not self._paused and self._done is None and self._error is None

    def _loop(self) -> None:
        cfg = self.config
        dt = self._loco.sim.config.dt_s
        while not self._stop:
            self._drain(block=not self._running)
            if self._stop:
                break
            if not self._running:
                continue
            loco = self._loco
            now = time.perf_counter()
            target = self._anchor_sim + self._speed * (now - self._anchor_wall)
            behind_s = target - loco.t_s
            if behind_s > cfg.max_lag_s:  # cannot keep up: drop the debt rather than burst
                self.stats.lag_resets += 1
                self._anchor_sim, self._anchor_wall = loco.t_s, now
                behind_s = 0.0
            ticks = min(int(behind_s / dt + 1e-9), cfg.chunk_ticks)
            if ticks <= 0:
                time.sleep(min(0.005, max(0.0005, (dt - behind_s) / self._speed)))
                self._account(time.perf_counter())
                continue
            t_before = loco.t_s
            try:
                loco.advance(ticks)
            except Exception as exc:  # noqa: BLE001 - a bug in the stack must not kill the server
                log.error("simulation error:\n%s", traceback.format_exc())
                self._error = f"simulation error: {exc}"
            self.stats.running_sim_s += loco.t_s - t_before
            if loco.fall_reason is not None:
                self._done = f"fell: {loco.fall_reason}"
            elif loco.reached_goal:
                self._done = "goal reached"
            wall = time.perf_counter()
            self._account(wall)
            if self._done or self._error or wall - self._last_publish >= cfg.publish_period_s:
                self._publish()
            if loco.t_s == t_before and self._error is None and self._done is None:
                time.sleep(0.001)

    def _account(self, wall: float) -> None:
        gap = wall - self._last_tick_wall
        self.stats.running_wall_s += gap
        self.stats.longest_stall_s = max(self.stats.longest_stall_s, gap)
        self._last_tick_wall = wall

    def _drain(self, block: bool) -> None:
        """Apply every queued command (waiting up to 50 ms for one when idle)."""
        while True:
            try:
                command, future = self._commands.get(timeout=0.05) if block else self._commands.get_nowait()
            except queue.Empty:
                return
            block = False
            if command is None:
                future.set_result(None)
                return
            try:
                self._apply(command)
            except Exception as exc:  # noqa: BLE001 - handed back to the caller
                self._publish()
                future.set_exception(exc)
                continue
            self._publish()  # before resolving: whoever waited sees the effect in `view`
            future.set_result(None)

    def _apply(self, command: Command) -> None:
        loco = self._loco
        was_running = self._running
        if isinstance(command, SetVelocity):
            self._vel = (float(command.vx), float(command.vy))
            loco.set_command(*self._vel)
        elif isinstance(command, NudgeVelocity):
            self._vel = tuple(
                float(np.clip(round(v + d, 3), -VELOCITY_LIMIT, VELOCITY_LIMIT))
                for v, d in zip(self._vel, (command.dvx, command.dvy), strict=True)
            )
            loco.set_command(*self._vel)
        elif isinstance(command, ApplyPush):
            push = Push(
                t0_s=loco.t_s,
                duration_s=float(command.duration_s),
                force_world=(float(command.fx), float(command.fy), 0.0),
            )
            loco.push(push)
            self._pushes.append(push)
        elif isinstance(command, Reset):
            loco.reset()
            loco.set_command(*self._vel)
            self._paused = False
            self._error = None
            self._after_restart()
        elif isinstance(command, SetPaused):
            self._paused = bool(command.paused)
        elif isinstance(command, TogglePause):
            if self._done is not None or self._error is not None:
                self._apply(Reset())
            else:
                self._paused = not self._paused
        elif isinstance(command, SetSpeed):
            self._speed = float(command.speed)
        elif isinstance(command, SetGait):
            self._rebuild(gait=command.gait)
        elif isinstance(command, SetPlanner):
            self._rebuild(planner=command.planner)
        elif isinstance(command, SetNoise):
            self._rebuild(noise=bool(command.on))
        elif isinstance(command, SetTerrain):
            self._rebuild(terrain=(command.terrain, command.label))
        else:  # pragma: no cover - check_command lets only known commands through
            raise ValueError(f"unknown command {command!r}")
        if self._running and not was_running:
            self._anchor()

    def _rebuild(
        self,
        gait: str | None = None,
        planner: str | None = None,
        noise: bool | None = None,
        terrain: tuple[Terrain, str] | None = None,
    ) -> None:
        """New settings need a new Locomotion; on failure the old settings and world stay."""
        old = (self._gait_name, self._planner_name, self._noise, self._terrain, self._terrain_label)
        if gait is not None:
            self._gait_name = gait
        if planner is not None:
            self._planner_name = planner
        if noise is not None:
            self._noise = noise
        if terrain is not None:
            self._terrain, self._terrain_label = terrain
        try:
            self._build()
        except Exception:
            self._gait_name, self._planner_name, self._noise, self._terrain, self._terrain_label = old
            raise
        if terrain is not None:
            self._terrain_version += 1
            self._paused = True  # an edited terrain puts the robot back at the start: wait for "run"
        self._error = None

    def _publish(self) -> None:
        loco = self._loco
        snap = loco.snapshot()
        parts = self._tracker.update(snap)
        wall = time.perf_counter()
        stats = self.stats
        stats.history.append((wall, stats.running_wall_s, stats.running_sim_s))
        rtf = 0.0
        for then in stats.history:
            if wall - then[0] <= 2.0:
                d_wall = stats.running_wall_s - then[1]
                rtf = (stats.running_sim_s - then[2]) / d_wall if d_wall > 0.2 else 0.0
                break
        t = loco.t_s
        push_force = np.zeros(3)
        for push in self._pushes:
            if push.active(t):
                push_force += push.force_world
        status = SessionStatus(
            running=self._running,
            paused=self._paused,
            done=self._done,
            speed=self._speed,
            real_time_factor=rtf if self._running else 0.0,
            terrain=self._terrain_label,
            gait=self._gait_name,
            planner=self._planner_name,
            planner_active=self._planner_active,
            planner_note=self._planner_note,
            noise=self._noise,
            pushes=len(self._pushes),
            error=self._error,
        )
        self._seq += 1
        self._view = LiveView(
            seq=self._seq,
            snapshot=snap,
            status=status,
            terrain=self._terrain,
            terrain_version=self._terrain_version,
            gait=loco.gait,
            push_force_world=push_force,
            wall_time_s=time.monotonic(),
            **parts,
        )
        self._last_publish = wall
