"""The status lines at the top of the control panel."""

from __future__ import annotations

import numpy as np
import viser

from app.panels.common import ChangeTracker
from app.view import LiveView


def status_markdown(view: LiveView) -> str:
    """The status panel text (markdown)."""
    s, snap = view.status, view.snapshot
    if s.error:
        state = f"**ERROR**: {s.error}"
    elif s.done and s.done.startswith("fell"):
        state = f"**FELL** ({s.done[6:]}) - press Reset"
    elif s.done:
        state = "**GOAL REACHED** - press Reset"
    elif s.paused:
        state = "**PAUSED**"
    else:
        state = "**running**"
    rank = snap.planned_steps[0].rank if snap.planned_steps else None
    timing = view.timing
    mean_plan = f" (mean {timing[:, 1].mean():.2f})" if len(timing) else ""
    planner = (
        s.planner_active if s.planner == s.planner_active else f"{s.planner_active} (asked: {s.planner})"
    )
    lines = [
        f"{state} · t = {snap.t_s:.2f} s · RTF {s.real_time_factor:.2f} · speed {s.speed:.2g}x",
        f"terrain **{s.terrain}** · {s.gait} · planner **{planner}** · noise {'on' if s.noise else 'off'}",
        f"cmd ({snap.vel_cmd_xy[0]:+.2f}, {snap.vel_cmd_xy[1]:+.2f}) m/s · "
        f"CoM vel ({snap.com_vel[0]:+.2f}, {snap.com_vel[1]:+.2f}) · x = {snap.q[0]:.2f} m",
        f"steps {snap.steps} · rank chosen {'n/a' if rank is None else rank} · "
        f"plan {snap.last_planner_ms:.2f} ms{mean_plan} · optimizer {snap.last_trajopt_ms:.1f} ms",
    ]
    if np.any(view.push_force_world):
        f = view.push_force_world
        lines.append(f"**push active** ({f[0]:+.0f}, {f[1]:+.0f}) N · pushes so far {s.pushes}")
    elif s.pushes:
        lines.append(f"pushes so far {s.pushes}")
    if s.planner_note:
        lines.append(f"*{s.planner_note}*")
    return "  \n".join(lines)


class StatusPanel:
    """The status text (state, time, terrain, gait, planner, command, pushes, planner note)."""

    def __init__(self, gui: viser.GuiApi, order: float = 0.0):
        self.text = gui.add_markdown("starting ...", order=order)
        self._seen = ChangeTracker()

    def refresh(self, view: LiveView) -> None:
        text = status_markdown(view)
        if self._seen.changed("status", text):
            self.text.content = text
