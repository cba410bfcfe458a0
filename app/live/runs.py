"""The live session's runs: when the robot may walk, when a run ends, and when the next one starts.

`RunClock` is the bookkeeping of `app/live/session.py`'s session thread (one owner, no locks): it waits for the
first viewer (or an explicit start), counts down before the robot moves so the scene is drawn first, ends a
run when every robot ended (compare mode: or `COMPARE_GRACE_S` after the first), keeps the finished runs'
count and the last `RunSummary` (`run_summary` sums a robot's run up), and with the loop on counts down to
the next run.
"""

from __future__ import annotations

import time

import numpy as np

from app.live.compare import CompareResult, rank_stats
from app.live.view import RunInfo, RunSummary
from contactnet.locomotion import Locomotion
from contactnet.records import StepCounts

#: In compare mode, a run ends this many simulated seconds after its first robot finished (the others may
#: stand still forever).
COMPARE_GRACE_S = 10.0


class RunClock:
    """Where the session is between runs (session thread only). Wall times are `time.perf_counter()`."""

    def __init__(self, wait_for_viewer: bool, viewer_start_delay_s: float, loop: bool, loop_delay_s: float):
        self.waiting = wait_for_viewer  #: no robot moves before a first viewer (or an explicit start)
        self.start_at: float | None = None  #: wall time the count-down after the first viewer ends
        self.loop = loop
        self.restart_at: float | None = None  #: wall time the next run starts (loop)
        self.restart_left_s: float | None = None  #: the loop's count-down held by a pause (seconds left)
        self.runs = 0
        self.last_run: RunSummary | None = None
        self.viewer_start_delay_s = viewer_start_delay_s
        self.loop_delay_s = loop_delay_s
        self.new_run()

    def new_run(self) -> None:
        self.over = False  #: every robot ended (or the compare grace ran out)
        self.first_end_s: float | None = None
        self.restart_at = None
        self.restart_left_s = None

    @property
    def holding(self) -> bool:
        """The robot may not walk now: waiting for a viewer, counting down, or the run is over."""
        return self.waiting or self.start_at is not None or self.over

    def viewer_connected(self) -> None:
        if self.waiting:
            self.waiting = False
            self.start_at = time.perf_counter() + self.viewer_start_delay_s

    def start_now(self) -> None:
        """An explicit start (run, reset): no viewer and no count-down needed."""
        self.waiting = False
        self.start_at = None

    def set_loop(self, on: bool) -> None:
        self.loop = on
        if not on:
            self.restart_at = self.restart_left_s = None
        elif self.over and self.restart_at is None and self.restart_left_s is None:
            self.restart_at = time.perf_counter() + self.loop_delay_s

    def hold(self, paused: bool) -> None:
        """A pause holds the loop's count-down where it is (the next run does not start, and unpause the robot,
        behind the back of whoever paused it); the end of the pause lets it run on from there."""
        now = time.perf_counter()
        if paused and self.restart_at is not None:
            self.restart_left_s, self.restart_at = max(0.0, self.restart_at - now), None
        elif not paused and self.restart_left_s is not None:
            self.restart_at, self.restart_left_s = now + self.restart_left_s, None

    def should_end(self, ended: list[bool], clock_s: float) -> bool:
        """Given which robots ended (main first) at the run's simulated time ``clock_s``: is the run over?"""
        if self.over or not any(ended):
            return False
        if self.first_end_s is None:
            self.first_end_s = clock_s
        return all(ended) or clock_s - self.first_end_s >= COMPARE_GRACE_S

    def end(self, summary_of_run: RunSummary) -> None:
        """The run is over: count it (``summary_of_run.index`` should be `runs` + 1) and, looping, schedule the
        next."""
        self.runs = summary_of_run.index
        self.last_run = summary_of_run
        self.over = True
        if self.loop:
            self.restart_at = time.perf_counter() + self.loop_delay_s

    def due(self) -> str | None:
        """"start" when the first viewer's count-down ended, "restart" when the loop's did, else None."""
        now = time.perf_counter()
        if self.start_at is not None and now >= self.start_at:
            self.start_at = None
            return "start"
        if self.restart_at is not None and now >= self.restart_at:
            return "restart"
        return None

    def held_because(self, error: str | None, done: str | None) -> str:
        """Why a robot that is not running does not (for a refused command): ``error`` stopped the session,
        the run ended as ``done``, it waits for a viewer or its count-down, or it is paused."""
        if error is not None:
            return "stopped by an error (reset it)"
        if self.over:
            if self.restart_at is not None:  # the loop starts the next run by itself
                left_s = max(0.0, self.restart_at - time.perf_counter())
                return f"done ({done or 'stopped'}): the next run starts in {left_s:.0f} s"
            if self.restart_left_s is not None:  # paused on the end-of-run card: the count-down holds
                return (f"done ({done or 'stopped'}), paused: the next run starts {self.restart_left_s:.0f} s "
                        "after Run (or P)")
            return f"done ({done or 'stopped'}): reset it first (R)"
        if self.waiting:
            return "waiting for a browser to open the 3D view: open it or run the robot first"
        if self.start_at is not None:
            return "about to start: push it once it walks"
        return "paused: run it first"

    @property
    def counting_down(self) -> bool:
        return self.start_at is not None or self.restart_at is not None  # (a held one does not count)

    def info(self, x_m: float, start_x_m: float, goal_x_m: float) -> RunInfo:
        now = time.perf_counter()
        span = goal_x_m - start_x_m
        return RunInfo(
            runs=self.runs,
            last_run=self.last_run,
            waiting_for_viewer=self.waiting,
            starts_in_s=None if self.start_at is None else max(0.0, self.start_at - now),
            restart_in_s=(self.restart_left_s if self.restart_at is None
                          else max(0.0, self.restart_at - now)),
            loop=self.loop,
            progress=float(np.clip((x_m - start_x_m) / span, 0.0, 1.0)) if span > 0 else 0.0,
            start_x_m=start_x_m,
            goal_x_m=goal_x_m,
        )


def run_summary(loco: Locomotion, index: int, done: str | None, terrain: str, gait: str, planner: str,
                compare: tuple[CompareResult, ...] | None) -> RunSummary:
    """The `RunSummary` of run ``index`` of the main robot ``loco``, which ended as ``done`` ("goal reached",
    "fell: ...", or None: still walking when the compare grace ran out)."""
    mean, worst = rank_stats(loco)
    records = loco.records
    return RunSummary(
        index=index,
        t_s=loco.t_s,
        steps=loco.steps_taken,
        rank_mean=mean,
        rank_max=worst,
        success=done == "goal reached",
        reason=done or f"stopped: still walking {COMPARE_GRACE_S:g} s after the other robot ended",
        reached_x_m=float(loco.snapshot().q[0]),
        terrain=terrain,
        gait=gait,
        planner=planner,
        compare=compare,
        counts=StepCounts.of_run(records, loco.swing_retargets),
    )
