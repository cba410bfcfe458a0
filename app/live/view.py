"""What viewers see of a session: `LiveView`, one immutable picture (world frame, SI units), and
`ViewTracker`, which turns successive `Snapshot`s of one Locomotion into the parts of a LiveView that
need history (CoM path, gait-schedule history with the planner's stand horizons, the candidate footholds of
the current step, planner timings, the step counts and swing retargets of `app/live/step_events.py`). Nothing here
knows about viser: `app/scene/live_scene.py` draws a `LiveView`, `app/recordings/recorder.py` records it, `app/live/session.py` publishes
one after every chunk of simulation.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from app.live.step_events import LiveCounts, RetargetFlash, StepEvents
from contactnet.locomotion import Locomotion
from contactnet.motion.gait import GaitSpec
from contactnet.records import Snapshot, StepCounts
from contactnet.robots import Robot
from contactnet.terrain import Terrain

HISTORY_NODES = 125  # gait-schedule history shown: 125 nodes of 40 ms = 5 s
COM_PATH_POINTS = 4000
COM_PATH_STEP_M = 0.005
TIMING_PLANS = 120
#: The status line's state while the planner stands (a choice, unlike a pause).
STANDING = "standing (planner's choice)"
#: A command below this speed (m/s) asks the robot to stay: the status may say it stands.
COMMAND_AT_REST_M_S = 1e-3


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
    robot: str = ""  # the robot's registry name
    retarget: bool = False  # swing retargeting is on (`contactnet.planning.retarget`)
    observer: bool = False  # the disturbance observer is on (`contactnet.planning.observer`)
    sim: str = "pybullet"  # the physics engine
    #: the terrain was loaded in this session (a user's choice), not the one the session started on
    terrain_chosen: bool = False


@dataclass(frozen=True)
class Notice:
    """Something a user should be told once (a toast): the change they made restarted the robot, an edit
    applied without a restart, ... `seq` grows by one per notice of a session."""

    seq: int
    level: str  # "info" or "warning"
    text: str


@dataclass(frozen=True)
class CompareResult:
    """How one robot of a run ended (or stands when the run was summed up)."""

    planner: str
    x_m: float
    fell: bool
    success: bool
    steps: int
    rank_mean: float | None
    done: str | None  # "goal reached", "fell: ...", or None (still walking)


@dataclass(frozen=True)
class CompareRobot(CompareResult):
    """Another robot of compare mode: its result so far and its pose (drawn as a ghost)."""

    planner_active: str = ""
    snapshot: Snapshot | None = None
    foot_pos_world: np.ndarray | None = None  # (4, 3)


@dataclass(frozen=True)
class RunSummary:
    """One finished run: the main robot's result (and the compare robots', when compare mode was on)."""

    index: int  # 1, 2, ... since the session started
    t_s: float  # simulated time the run lasted
    steps: int
    rank_mean: float | None  # mean ranking position of the chosen actions (ranking planners only)
    rank_max: int | None
    success: bool
    reason: str  # "goal reached", "fell: <why>", or "stopped: <why>"
    reached_x_m: float
    terrain: str
    gait: str
    planner: str
    compare: tuple[CompareResult, ...] | None = None
    counts: StepCounts = StepCounts()


@dataclass(frozen=True)
class RunInfo:
    """Where the session is in its runs: waiting for a first browser, counting down to a start or to the
    next run (loop), and how far the robot is from the start toward the goal."""

    runs: int = 0  # finished runs since the session started
    last_run: RunSummary | None = None
    waiting_for_viewer: bool = False
    starts_in_s: float | None = None  # the robot starts moving in this many wall seconds
    restart_in_s: float | None = None  # the next run (loop) starts in this many wall seconds
    loop: bool = False
    progress: float = 0.0  # 0 at the start, 1 at the goal line (x)
    start_x_m: float = 0.0
    goal_x_m: float = 0.0


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
    #: The session's terrain as a dict (the JSON form `terrain` was built from; edits apply to it), and
    #: whether an edit can be undone. None / False for views made outside a live session (`view_of`).
    terrain_dict: dict[str, Any] | None = None
    terrain_can_undo: bool = False
    terrain_can_redo: bool = False
    run: RunInfo = RunInfo()
    notices: tuple[Notice, ...] = ()
    #: the other robots of compare mode (the main robot runs the first planner), None when it is off
    compare: tuple[CompareRobot, ...] | None = None
    session_id: str = ""
    #: per node of stance_history: the planner had chosen to stand for that step horizon
    stand_history: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    planned_stand: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))  # (H,) per node of the plan
    counts: LiveCounts = LiveCounts()
    retarget_flashes: tuple[RetargetFlash, ...] = ()  # the swings retargeted in the last FLASH_S, oldest first
    #: (3,) N: the disturbance observer's estimate of the push, while the loop uses it (None: off or below threshold)
    estimated_push_world: np.ndarray | None = None


def estimated_push(loco: Locomotion | None) -> np.ndarray | None:
    """(3,) N, world: the push the loop's disturbance observer estimates and uses now; None when off or below its
    threshold (`contactnet.planning.observer`)."""
    observer = None if loco is None else loco.observer
    force = None if observer is None else observer.active_force_xy()
    return None if force is None else np.array([force[0], force[1], 0.0])


class ViewTracker:
    """Turns successive snapshots of one Locomotion into `LiveView` parts. Use from one thread
    (it runs forward kinematics on the robot model it is given)."""

    def __init__(self, robot: Robot, terrain: Terrain, gait: GaitSpec):
        self.robot = robot
        self.terrain = terrain
        self.gait = gait
        self.reset()

    def reset(self) -> None:
        self._plans_seen = -1
        self._events = StepEvents()
        self._counts = LiveCounts()
        self._standing: deque[bool] = deque(maxlen=HISTORY_NODES)
        self._stand_array = np.zeros(0, dtype=bool)
        self._planned_stand = np.zeros(0, dtype=bool)
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

    def update(self, snap: Snapshot, loco: Locomotion | None = None) -> dict[str, Any]:
        """The LiveView fields derived from `snap` (arrays are fresh or unchanged objects) and, given the
        Locomotion it is a snapshot of, its step counts and retargets (`app.live.step_events`)."""
        gait = self.gait
        q = snap.q
        foot_pos = self.robot.foot_positions_world(q)
        flashes: tuple[RetargetFlash, ...] = ()
        if loco is not None:
            self._counts, flashes = self._events.update(loco)
        plans = self._counts.plans if loco is not None else snap.steps  # stands are plans too (not steps)
        if plans != self._plans_seen:
            self._plans_seen = plans
            if snap.planned_steps:
                self._candidates = self._candidate_view(snap)
                self._timing.append((snap.t_s, snap.last_planner_ms, snap.last_trajopt_ms))
                self._timing_array = np.array(self._timing)
                step_s = gait.step_duration_s
                self._plan_t0_s = math.floor(snap.t_s / step_s + 1e-6) * step_s
                self._planned_contact = gait.horizon_contact([s.legs for s in snap.planned_steps])
                self._planned_stand = np.repeat([not s.legs for s in snap.planned_steps], gait.nodes_per_step)
        node = int(snap.t_s / gait.node_dt_s + 1e-6)
        if node != self._last_node:
            first = node if self._last_node < 0 else self._last_node + 1
            standing = is_stand(snap)
            for _ in range(first, node + 1):
                self._stance.append(np.asarray(snap.stance, dtype=bool).copy())
                self._standing.append(standing)
            self._last_node = node
            self._stance_array = np.array(self._stance)
            self._stand_array = np.array(self._standing, dtype=bool)
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
            "stand_history": self._stand_array,
            "planned_stand": self._planned_stand,
            "counts": self._counts,
            "retarget_flashes": flashes,
            "estimated_push_world": estimated_push(loco),
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


def stand_chart(view: LiveView) -> tuple[np.ndarray, np.ndarray]:
    """The planner's stand horizons on `gait_chart`'s samples: (past (S,), planned (S,)), 1 while it stands."""
    dt = view.gait.node_dt_s
    n_past = len(view.stance_history)
    now_node = view.stance_history_node0 + n_past - 1
    skip = max(0, now_node + 1 - int(round(view.plan_t0_s / dt)))
    n_future = len(view.planned_contact[skip:])
    if n_past + n_future == 0:
        return np.zeros(2), np.zeros(2)
    past, planned = np.zeros(n_past + n_future), np.zeros(n_past + n_future)
    history = view.stand_history[len(view.stand_history) - n_past :] if n_past else view.stand_history[:0]
    past[n_past - len(history) : n_past] = history
    future = view.planned_stand[skip : skip + n_future]
    planned[n_past : n_past + len(future)] = future
    return np.repeat(past, 2), np.repeat(planned, 2)


def is_stand(snap: Snapshot) -> bool:
    """Is the current step horizon one the planner chose to stand (no leg swings)?"""
    return bool(snap.planned_steps) and not snap.planned_steps[0].legs


#: What `status_kind` answers: the state word of the status sentence, for the page's colour (one of these).
STATUS_KINDS = ("error", "waiting", "starting", "fell", "goal", "done", "paused", "standing", "walking")


def status_kind(view: LiveView) -> str:
    """The state the status sentence names (`STATUS_KINDS`). A robot told to walk is "walking" also on a step
    horizon its planner stands (the planner stands every other horizon on some terrains: the label and its colour
    would flip every 0.4-0.8 s; "stood N" in the sentence counts those horizons, once each); "standing" is a robot
    told to stay (a zero command) whose planner stands."""
    s, snap, run = view.status, view.snapshot, view.run
    if s.error:
        return "error"
    if run.waiting_for_viewer:
        return "waiting"
    if run.starts_in_s is not None:
        return "starting"
    if s.done:
        return "goal" if s.done == "goal reached" else "fell" if s.done.startswith("fell") else "done"
    if s.paused:
        return "paused"
    commanded = math.hypot(*snap.vel_cmd_xy) > COMMAND_AT_REST_M_S
    return "standing" if is_stand(snap) and not commanded else "walking"


def status_line(view: LiveView) -> str:
    """The session's state in one sentence: the header of the page (State.status_text) and the control
    panel both show this, so they never disagree."""
    s, snap, run = view.status, view.snapshot, view.run
    kind = status_kind(view)
    if kind == "error":
        state = f"ERROR: {s.error}"
    elif kind == "waiting":
        state = "waiting for a browser"
    elif kind == "starting":
        state = f"starting in {math.ceil(run.starts_in_s)} s"
    elif s.done and run.restart_in_s is not None and s.paused:
        state = f"{_done_text(s.done)}; paused, next run {math.ceil(run.restart_in_s)} s after Run"
    elif s.done and run.restart_in_s is not None:
        state = f"{_done_text(s.done)}; next run in {math.ceil(run.restart_in_s)} s"
    elif s.done:
        state = _done_text(s.done)
    else:
        state = {"paused": "paused", "standing": STANDING}.get(kind, "walking")
    rank = snap.planned_steps[0].rank if snap.planned_steps else None
    parts = [state, f"t {snap.t_s:.1f} s", f"x {snap.q[0]:.2f} m ({100 * run.progress:.0f} %)", f"steps {snap.steps}"]
    if view.counts.stand_steps:
        parts.append(f"stood {view.counts.stand_steps}")
    if rank is not None:
        parts.append(f"rank {rank}")
    if run.runs:
        parts.append(f"run {run.runs + (0 if s.done else 1)}")
    return " · ".join(parts)


def _done_text(done: str) -> str:
    if done == "goal reached":
        return "GOAL REACHED"
    if done.startswith("fell: "):
        return f"FELL ({done.removeprefix('fell: ')})"
    return done.upper()
