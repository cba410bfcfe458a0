"""The top of the control panel: one status line (the same sentence the front page's header shows:
`app.live.view.status_line`), the run's state (waiting for a browser, starting in N s, the end-of-run card
with the restart countdown), a progress bar from the start toward the goal, and the details
(terrain, gait, planner, command, timings, pushes, and what the planner did besides stepping: stand horizons,
useless steps, swing retargets)."""

from __future__ import annotations

import numpy as np
import viser

from app.live.view import CompareResult, LiveView, RunSummary, status_line
from app.viewer.panels.common import ChangeTracker
from contactnet.records import StepCounts


def _state_word(view: LiveView) -> str:
    s = view.status
    if s.error:
        return f"**ERROR**: {s.error}"
    if s.done and s.done.startswith("fell"):
        return f"**FELL** ({s.done[6:]})"
    if s.done:
        return "**GOAL REACHED**"
    if s.paused:
        return "**PAUSED**"
    return "**running**"


def headline(view: LiveView) -> str:
    """The first line: `status_line(view)`, the sentence the page's header shows too (one status source)."""
    return f"**{status_line(view)}**"


def step_kinds(counts: StepCounts) -> str:
    """What the planner did besides stepping, as one phrase (capture steps only once there are some)."""
    capture = f" · capture steps {counts.capture_steps}" if counts.capture_steps else ""
    return (f"stood {counts.stand_steps} · useless {counts.useless_steps} · swing retargets "
            f"{counts.swing_retargets}{capture}")


def _summary(run: RunSummary) -> str:
    """A RunSummary as two lines: time, steps, ranks, distance (the headline already says how it ended), then
    stands, useless steps and retargets."""
    rank = "" if run.rank_mean is None else f" · rank mean {run.rank_mean:.1f}, max {run.rank_max}"
    return (f"**Run {run.index}** ({run.planner}): {run.t_s:.1f} s · {run.steps} steps{rank} · "
            f"x = {run.reached_x_m:.2f} m  \n{step_kinds(run.counts)}")


def _compare_result(result: CompareResult) -> str:
    """One other robot of a finished compare run, as one line."""
    outcome = "goal reached" if result.success else ("fell" if result.fell else (result.done or "still walking"))
    rank = "" if result.rank_mean is None else f" · rank mean {result.rank_mean:.1f}"
    return f"{result.planner}: {outcome} · {result.steps} steps{rank} · x = {result.x_m:.2f} m"


def run_markdown(view: LiveView) -> str:
    """What the headline does not say about the run (`view.run`): how a waiting session starts, and the
    end-of-run card (the result, the compared robots' results, whether another run follows)."""
    run = view.run
    lines = []
    if run.waiting_for_viewer:
        lines.append("The robot starts once a browser shows the 3D view (or press Run).")
    last = run.last_run
    if last is not None and view.status.done is not None:
        lines.append(_summary(last))
        for result in last.compare or ():
            lines.append(_compare_result(result))
        if run.restart_in_s is None and not run.loop:
            lines.append("Loop off: press Run again (or Reset) for another run.")
    elif last is not None:
        result = "goal reached" if last.success else last.reason.split(":")[0]  # "fell", "stopped"
        lines.append(f"*last run: {result} after {last.t_s:.1f} s at x = {last.reached_x_m:.2f} m*")
    return "  \n".join(lines)


def details_markdown(view: LiveView) -> str:
    """Terrain, gait, planner, command, velocity, steps, rank, timings, pushes, planner note."""
    s, snap = view.status, view.snapshot
    rank = snap.planned_steps[0].rank if snap.planned_steps else None
    timing = view.timing
    mean_plan = f" (mean {timing[:, 1].mean():.2f})" if len(timing) else ""
    kinds = step_kinds(view.counts)
    planner = (
        s.planner_active if s.planner == s.planner_active else f"{s.planner_active} (asked: {s.planner})"
    )
    lines = [
        f"terrain **{s.terrain}** · {s.gait} · planner **{planner}** · noise {'on' if s.noise else 'off'}",
        f"cmd ({snap.vel_cmd_xy[0]:+.2f}, {snap.vel_cmd_xy[1]:+.2f}) m/s · "
        f"CoM vel ({snap.com_vel[0]:+.2f}, {snap.com_vel[1]:+.2f}) · x = {snap.q[0]:.2f} m",
        f"steps {snap.steps} · rank chosen {'n/a' if rank is None else rank} · "
        f"plan {snap.last_planner_ms:.2f} ms{mean_plan} · optimizer {snap.last_trajopt_ms:.1f} ms · "
        f"RTF {f'{s.real_time_factor:.2f}' if s.running else '–'} · speed {s.speed:.2g}x",  # – while it stands still
        f"{kinds} "
        f"(retargeting {'on' if s.retarget else 'off'})",
    ]
    if np.any(view.push_force_world):
        f = view.push_force_world
        lines.append(f"**push active** ({f[0]:+.0f}, {f[1]:+.0f}) N · pushes so far {s.pushes}")
    elif s.pushes:
        lines.append(f"pushes so far {s.pushes}")
    if s.planner_note:
        lines.append(f"*{s.planner_note}*")
    return "  \n".join(lines)


def status_markdown(view: LiveView) -> str:
    """The whole status text (markdown): headline, run state, details."""
    parts = [headline(view), run_markdown(view), details_markdown(view)]
    return "  \n".join(p for p in parts if p)


def progress(view: LiveView) -> float:
    """0..1: the robot's x from the start toward the goal."""
    return float(np.clip(view.run.progress, 0.0, 1.0))


class StatusPanel:
    """The status text and the progress bar toward the goal."""

    def __init__(self, gui: viser.GuiApi, order: float = 0.0):
        self.text = gui.add_markdown("starting ...", order=order)
        self.progress = gui.add_progress_bar(0.0, animated=False, color="green", order=order + 0.1)
        self._seen = ChangeTracker()

    def refresh(self, view: LiveView) -> None:
        text = status_markdown(view)
        if self._seen.changed("status", text):
            self.text.content = text
        value = round(100.0 * progress(view), 1)
        if self._seen.changed("progress", value):
            self.progress.value = value
