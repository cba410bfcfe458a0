"""The live session: one Locomotion run in real time in its own thread, driven through a queue.

PyBullet is not thread-safe, so one thread (started by `LiveSession.start`) builds, steps,
rebuilds and closes the `Locomotion` (and with it the `Simulator`). Everyone else - web handlers,
viser callbacks, the scene updater - talks to it in two ways only:
- `submit(command)` puts a command (`app/commands.py`) on a queue and returns a Future (resolved
  once the thread has applied it; `call` waits for it);
- `view` is the latest `LiveView` (`app/view.py`), an immutable picture of the session that the
  thread replaces (one reference assignment) after every chunk of simulation. Readers never lock,
  and the simulation never waits for a reader.

The session owns the current terrain: the `Terrain` it simulates, its dict form with the edit history
(undo), and its label. Loading, editing and undoing are commands, applied by the session thread, so
the terrain, its history and what viewers see always change together (`app/editing.py` is the
service in front of them; see docs/architecture.md).

Real-time pacing: the thread advances the simulation in chunks of at most `chunk_ticks` (10 ms)
toward `anchor_sim + speed * (wall - anchor_wall)` and sleeps when it is ahead, which also lets
the web threads run. If it falls more than `max_lag_s` behind (a slow machine), it drops the debt
instead of running in a burst to catch up.
"""

from __future__ import annotations

import logging
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

from app.commands import (
    ApplyPush,
    Command,
    CommandConflict,
    EditTerrain,
    NudgeVelocity,
    RenameTerrain,
    Reset,
    SetGait,
    SetNoise,
    SetPaused,
    SetPlanner,
    SetSpeed,
    SetTerrain,
    SetVelocity,
    TogglePause,
    UndoTerrainEdit,
    check_command,
)
from app.editor import EditHistory, to_terrain
from app.planners import PlannerFactory, default_planner_factory
from app.settings import VELOCITY_LIMIT_M_S, ServeSettings
from app.view import LiveView, SessionStatus, ViewTracker
from contactnet import registry
from contactnet.locomotion import Locomotion
from contactnet.robots import load_robot
from contactnet.sim import Push, SimConfig
from contactnet.terrain import Terrain

log = logging.getLogger("contactnet.app.live")

NOISE_VARIANCE = 0.01  # the paper's joint-velocity noise, (rad/s)^2


@dataclass(frozen=True)
class Pacing:
    """How the session thread keeps real time."""

    chunk_ticks: int = 10  #: control ticks (1 ms) simulated between two looks at the queue
    max_lag_s: float = 1.0  #: further behind than this: drop the debt instead of catching up
    publish_period_s: float = 1.0 / 60.0  #: a new LiveView at most this often while running


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
        settings: ServeSettings,
        terrain: Terrain,
        terrain_label: str | None = None,
        *,
        planner_factory: PlannerFactory = default_planner_factory,
        robot_cache_dir: Path | None = None,
        pacing: Pacing = Pacing(),
    ):
        """A session of ``settings.robot`` with the settings' gait, planner, velocity, noise, speed and
        pause, on ``terrain`` (shown as ``terrain_label``, default its name). Nothing runs before `start`."""
        self.settings = settings
        self.pacing = pacing
        self._initial_terrain = (terrain, terrain_label or terrain.name)
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

    def call(self, command: Command, timeout: float = 30.0) -> Any:
        """Submit and wait; the command's result (None for most; EditTerrain: whether it changed anything)."""
        return self.submit(command).result(timeout)

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
            settings = self.settings
            self._robot = load_robot(settings.robot, self._robot_cache_dir)
            self._terrain, self._terrain_label = self._initial_terrain
            self._terrain_base_label = self._terrain_label  # "<base> (edited)" after an edit
            self._terrain_history = EditHistory(self._terrain.to_dict())
            self._terrain_version = 0
            self._gait_name, self._planner_name = settings.gait, settings.planner
            self._noise = settings.noise
            self._vel = (settings.vx_m_s, settings.vy_m_s)
            self._speed = settings.sim_speed
            self._paused = settings.paused
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

    def _build(self, publish: bool = True) -> None:
        """(Re)build the Locomotion (and its PyBullet world) for the current settings; ``publish=False``
        leaves publishing the new view to the caller (a command publishes once it is fully applied)."""
        gait = registry.gait_by_name(self._gait_name)
        planner, active, note = self._planner_factory(self._planner_name, gait, self._robot)
        sim_config = SimConfig(joint_vel_noise_var=NOISE_VARIANCE if self._noise else 0.0)
        loco = Locomotion(self._robot, self._terrain, gait, planner, sim_config, vel_cmd_xy=self._vel)
        if self._loco is not None:
            self._loco.close()
        self._loco = loco
        self._planner_active, self._planner_note = active, note
        self._tracker = ViewTracker(self._robot, self._terrain, gait)
        self._after_restart(publish)

    def _after_restart(self, publish: bool = True) -> None:
        self._pushes: list[Push] = []
        self._done: str | None = None
        self._tracker.reset()
        self._anchor()
        if publish:
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
        cfg = self.pacing
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
                result = self._apply(command)
            except Exception as exc:  # noqa: BLE001 - handed back to the caller
                self._publish()
                future.set_exception(exc)
                continue
            self._publish()  # before resolving: whoever waited sees the effect in `view`
            future.set_result(result)

    def _apply(self, command: Command) -> Any:
        """Apply one command (session thread); returns the command's result (see `call`)."""
        loco = self._loco
        was_running = self._running
        result = None
        if isinstance(command, SetVelocity):
            self._vel = (float(command.vx), float(command.vy))
            loco.set_command(*self._vel)
        elif isinstance(command, NudgeVelocity):
            self._vel = tuple(
                float(np.clip(round(v + d, 3), -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S))
                for v, d in zip(self._vel, (command.dvx, command.dvy), strict=True)
            )
            loco.set_command(*self._vel)
        elif isinstance(command, ApplyPush):
            if not self._running:  # the clock stands still: the push would act later, or never
                raise CommandConflict(f"cannot push now: the robot is {self._not_running_reason()}")
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
            history = EditHistory(command.terrain.to_dict())  # a new terrain forgets the undo steps
            self._rebuild(terrain=(command.terrain, command.label))
            self._terrain_history, self._terrain_base_label = history, command.label
        elif isinstance(command, EditTerrain):
            history = self._terrain_history
            new = command.edit(history.current, *command.args)
            if new == history.current:
                return False
            self._rebuild(terrain=(to_terrain(new), self._edited_label()))
            history.apply(new)
            result = True
        elif isinstance(command, UndoTerrainEdit):
            previous = self._terrain_history.previous  # EditError when there is nothing to undo
            self._rebuild(terrain=(to_terrain(previous), self._edited_label()))
            self._terrain_history.undo()
        elif isinstance(command, RenameTerrain):
            self._terrain_label = self._terrain_base_label = command.label
        else:  # pragma: no cover - check_command lets only known commands through
            raise ValueError(f"unknown command {command!r}")
        if self._running and not was_running:
            self._anchor()
        return result

    def _not_running_reason(self) -> str:
        if self._error is not None:
            return "stopped by an error (reset it)"
        if self._done is not None:
            return f"done ({self._done}): reset it first"
        return "paused: run it first"

    def _edited_label(self) -> str:
        return f"{self._terrain_base_label} (edited)"

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
            self._build(publish=False)  # the terrain's history changes after this: publish both at once
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
            robot=self._robot.name,
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
            terrain_dict=self._terrain_history.current,
            terrain_can_undo=self._terrain_history.can_undo,
            **parts,
        )
        self._last_publish = wall
