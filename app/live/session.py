"""The live session: one Locomotion run in real time in its own thread, driven through a queue.

PyBullet is not thread-safe, so one thread (started by `LiveSession.start`) builds, steps,
rebuilds and closes the `Locomotion` (and with it the `Simulator`). Everyone else - web handlers,
viser callbacks, the scene updater - talks to it in two ways only:
- `submit(command)` puts a command (`app/live/commands.py`) on a queue and returns a Future (resolved
  once the thread has applied it; `call` waits for it);
- `view` is the latest `LiveView` (`app/live/view.py`), an immutable picture of the session that the
  thread replaces (one reference assignment) after every chunk of simulation. Readers never lock,
  and the simulation never waits for a reader.

The session owns the current terrain: the `Terrain` it simulates, its dict form with the edit history
(undo), and its label. Loading, editing and undoing are commands, applied by the session thread, so
the terrain, its history and what viewers see always change together (`app/live/editing.py` is the
service in front of them; see docs/architecture.md). What each command does lives in
`app/live/session_commands.py` (`SessionCommands`, this class's base); this module is the thread: start-up, the
paced loop, runs, and the views it publishes.

Runs (`app/live/runs.py`): the robot waits for the first viewer, counts down so the scene is drawn before it
moves, and after the goal or a fall (summed up in a `RunSummary`) the loop starts the next run. Changes that
restart the robot say so in a `Notice` (a toast); terrain edits away from the robot need no restart.
Compare mode (`SetCompare`) runs other planners' robots beside the main one (`app/live/compare.py`). Swing
retargeting (`SetRetarget`, `contactnet.planning.retarget`) is turned on or off in every robot without a restart.

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
import uuid
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future
from pathlib import Path
from typing import Any

import numpy as np

from app.live.backend import wait_view
from app.live.commands import Command, check_command
from app.live.compare import CompareRobots, end_of
from app.live.editor import EditHistory
from app.live.pacing import Pacing, PacingStats
from app.live.planners import PlannerFactory, default_planner_factory
from app.live.runs import RunClock, run_summary
from app.live.session_commands import SessionCommands
from app.live.settings import ServeSettings
from app.live.step_events import loco_config
from app.live.view import LiveView, Notice, SessionStatus, ViewTracker
from contactnet import registry
from contactnet.locomotion import Locomotion
from contactnet.robots import load_robot
from contactnet.sim.world import Push, SimConfig
from contactnet.terrain import Terrain

log = logging.getLogger("contactnet.app.live")

NOISE_VARIANCE = 0.01  # the paper's joint-velocity noise, (rad/s)^2
NOTICES_KEPT = 10


class LiveSession(SessionCommands):
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
        self.stats = PacingStats()
        self.session_id = uuid.uuid4().hex[:12]  #: new for every session (clients reconnect when it changes)

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

    @property
    def alive(self) -> bool:
        """The session thread runs (not stopped: a reclaimed visit's session is not)."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def lost(self) -> str | None:
        """Never lost: the simulation runs in this process (`app.live.backend.SessionBackend`)."""
        return None

    def wait_view(self, predicate: Callable[[LiveView], bool], timeout: float = 10.0) -> LiveView:
        """Block until the latest view satisfies predicate (tests, benchmarks)."""
        return wait_view(self, predicate, timeout)

    # ---- the session thread ------------------------------------------------------------------------
    def _run(self) -> None:
        try:
            settings = self.settings
            self._robot = load_robot(settings.robot, self._robot_cache_dir)
            self._terrain, self._terrain_label = self._initial_terrain
            self._terrain_base_label = self._terrain_label  # "<base> (edited)" after an edit
            self._terrain_chosen = False  # a terrain loaded later (SetTerrain) is the user's choice
            self._terrain_history = EditHistory(self._terrain.to_dict())
            self._terrain_version = 0
            self._gait_name, self._planner_name = settings.gait, settings.planner
            self._noise = settings.noise
            self._sim = settings.sim
            self._retarget = settings.retarget
            self._observer = settings.observer
            self._vel = (settings.vx_m_s, settings.vy_m_s)
            self._speed = settings.sim_speed
            self._paused = settings.paused
            self._runs = RunClock(
                settings.wait_for_viewer and not settings.paused,
                settings.viewer_start_delay_s,
                settings.loop,
                settings.loop_delay_s,
            )
            self._notices: deque[Notice] = deque(maxlen=NOTICES_KEPT)
            self._notice_seq = 0
            self._compare_planners: tuple[str, ...] = ()
            self._compare: CompareRobots | None = None
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
            if self._compare is not None:
                self._compare.close()

    def _build(self, publish: bool = True) -> None:
        """(Re)build the Locomotion (and its PyBullet world) for the current settings; ``publish=False``
        leaves publishing the new view to the caller (a command publishes once it is fully applied)."""
        robot = self._robot.for_terrain(self._terrain, self._gait_name)  # its stance here (Robot.for_terrain)
        gait = registry.gait_for(self._gait_name, robot)
        planner, active, note = self._planner_factory(self._planner_name, gait, robot)
        sim_config = SimConfig(joint_vel_noise_var=NOISE_VARIANCE if self._noise else 0.0, engine=self._sim)
        config = loco_config(self._retarget, observer=self._observer)
        loco = Locomotion(robot, self._terrain, gait, planner, sim_config, config=config, vel_cmd_xy=self._vel)
        try:
            compare = (
                CompareRobots(
                    self._compare_planners[1:], robot, self._terrain, gait, self._planner_factory,
                    sim_config, self._vel, config,
                )
                if self._compare_planners
                else None
            )
        except BaseException:
            loco.close()
            raise
        if self._loco is not None:
            self._loco.close()
        if self._compare is not None:
            self._compare.close()
        self._loco, self._compare = loco, compare
        self._planner_active, self._planner_note = active, note
        self._tracker = ViewTracker(robot, self._terrain, gait)
        self._after_restart(publish)

    def _after_restart(self, publish: bool = True) -> None:
        self._pushes: list[Push] = []
        self._done: str | None = None  # how the main robot's run ended
        self._runs.new_run()
        self._clock_s = 0.0  # simulated time of this run (every robot's clock while it walks)
        self._tracker.reset()
        self._anchor()
        if publish:
            self._publish()

    def _anchor(self) -> None:
        self._anchor_wall = time.perf_counter()
        self._anchor_sim = self._clock_s
        self._last_tick_wall = self._anchor_wall
        self._last_publish = 0.0

    @property
    def _running(self) -> bool:
        return (
            not self._paused
            and not self._runs.holding
            and self._error is None
        )

    def _loop(self) -> None:
        cfg = self.pacing
        dt = self._loco.sim.config.dt_s
        while not self._stop:
            self._drain(block=not self._running)
            if self._stop:
                break
            if not self._running:
                self._count_down()
                continue
            loco = self._loco
            now = time.perf_counter()
            target = self._anchor_sim + self._speed * (now - self._anchor_wall)
            behind_s = target - self._clock_s
            if behind_s > cfg.max_lag_s:  # cannot keep up: drop the debt rather than burst
                self.stats.lag_resets += 1
                self._anchor_sim, self._anchor_wall = self._clock_s, now
                behind_s = 0.0
            self.stats.behind_s = behind_s
            ticks = min(int(behind_s / dt + 1e-9), cfg.chunk_ticks)
            if ticks <= 0:
                time.sleep(min(0.005, max(0.0005, (dt - behind_s) / self._speed)))
                self._account(time.perf_counter())
                continue
            try:
                if self._done is None:
                    loco.advance(ticks)
                if self._compare is not None:
                    self._compare.advance(ticks)
            except Exception as exc:  # noqa: BLE001 - a bug in the stack must not kill the server
                log.error("simulation error:\n%s", traceback.format_exc())
                self._error = f"simulation error: {exc}"
            self._clock_s += ticks * dt
            self.stats.running_sim_s += ticks * dt
            self._check_run_end()
            wall = time.perf_counter()
            self._account(wall)
            if self._runs.over or self._error or wall - self._last_publish >= cfg.publish_period_s:
                self._publish()

    def _check_run_end(self) -> None:
        """Note how the main robot ended; end the run when every robot ended (`RunClock.should_end`)."""
        if self._done is None:
            self._done = end_of(self._loco)
        ended = [self._done is not None] + (self._compare.ended if self._compare is not None else [])
        if not self._runs.should_end(ended, self._clock_s):
            return
        compare = self._compare.results() if self._compare is not None else None
        self._runs.end(run_summary(self._loco, self._runs.runs + 1, self._done, self._terrain_label, self._gait_name,
                                   self._planner_active, compare))

    def _count_down(self) -> None:
        """While the robot stands: start it when the first viewer's count-down ends, start the next run
        when the loop's does; publish the count-downs a few times a second."""
        due = self._runs.due()
        if due == "start":
            self._anchor()
            self._publish()
        elif due == "restart" and self._error is None:
            self._restart()
            self._paused = False
            self._publish()
        elif self._runs.counting_down and time.perf_counter() - self._last_publish >= 0.25:
            self._publish()

    def _restart(self) -> None:
        """Every robot back to the start (same settings, same terrain)."""
        self._loco.reset()
        self._loco.set_command(*self._vel)
        if self._compare is not None:
            self._compare.reset(self._vel)
        self._after_restart(publish=False)

    def _notify(self, text: str, level: str = "info") -> None:
        self._notice_seq += 1
        self._notices.append(Notice(self._notice_seq, level, text))

    def _account(self, wall: float) -> None:
        self.stats.account(wall - self._last_tick_wall)
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
        was_running = self._running
        result = self._handle(command)
        if self._running and not was_running:
            self._anchor()
        return result

    def _publish(self) -> None:
        loco = self._loco
        snap = loco.snapshot()
        parts = self._tracker.update(snap, loco)
        wall = time.perf_counter()
        rtf = self.stats.real_time_factor(wall)
        t = loco.t_s
        push_force = np.zeros(3)
        for push in self._pushes:
            if push.active(t):
                push_force += push.force_world
        status = SessionStatus(
            running=self._running,
            paused=self._paused,
            done=self._done or (self._runs.last_run.reason if self._runs.over and self._runs.last_run else None),
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
            retarget=self._retarget,
            observer=self._observer,
            sim=self._sim,
            terrain_chosen=self._terrain_chosen,
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
            terrain_can_redo=self._terrain_history.can_redo,
            run=self._runs.info(float(snap.q[0]), float(self._terrain.start_xy[0]), float(self._terrain.goal_x)),
            notices=tuple(self._notices),
            compare=self._compare.views() if self._compare is not None else None,
            session_id=self.session_id,
            **parts,
        )
        self._last_publish = wall
