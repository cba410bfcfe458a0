"""The "Plots" folder: the gait schedule (one bar per leg, named on the y axis: stance so far, then the
plan ahead, faded; under them a slate "stand" band where the planner chose to stand), the rank of the chosen action step by step, the commanded and measured forward
velocity, and the planner's and optimizer's time per plan.

`PlotHistory.observe(view)` runs for every new view (the viewer's scene loop) and keeps the short
histories the session does not (rank per step, velocities); `refresh` draws them a few times a second.
"""

from __future__ import annotations

import time
from collections import deque

import numpy as np
import viser
import viser.uplot as uplot

from app.live.view import LiveView, gait_chart, stand_chart
from app.viewer.panels.common import ChangeTracker
from contactnet.robots import LEG_NAMES

LEG_COLORS = ("#e8590c", "#1c7ed6", "#2f9e44", "#ae3ec9")  # FL FR HL HR
STAND_COLOR = "#495057"  # the planner's stand horizons (slate; the 3D view's stand marks have the same colour)
STAND_BAND = (-0.55, 0.4)  # the stand band's bottom and height on the gait plot's y axis (leg bars: 0..3.8)
RANK_STEPS = 80  # steps shown in the rank plot
VELOCITY_WINDOW_S = 10.0  # seconds shown in the velocity plot
VELOCITY_SAMPLE_S = 0.05
SMOOTH_S = 1.0  # the measured velocity's moving average (about a gait cycle)
SLOW_PLOTS_S = 1.0  # rank, velocity and timing plots are redrawn at most this often (the page's main thread
# also draws the 3D view; the gait plot, the one people watch move, follows every refresh)
CMD_COLOR = "#212529"
MEASURED_COLOR = "#1c7ed6"
RANK_COLOR = "#2b8a3e"


def _hex_rgba(color: str, alpha: float) -> str:
    r, g, b = (int(color[i : i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha})"


def _leg_bars(leg_names: tuple[str, ...], suffix: str, alpha: float) -> tuple[uplot.Series, ...]:
    """One filled band per leg, the first leg on top (stance = bar)."""
    return tuple(
        uplot.Series(
            label=f"{leg}{suffix}",
            stroke=color,
            width=0,
            fill=_hex_rgba(color, alpha),
            fillTo=3 - i,
            points={"show": False},
        )
        for i, (leg, color) in enumerate(zip(leg_names, LEG_COLORS, strict=True))
    )


def steps_shape(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A step-shaped polyline through (t, y): each value holds until the next time (uPlot draws lines)."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    if len(t) < 2:
        return (np.zeros(2), np.zeros(2)) if len(t) == 0 else (np.array([t[0], t[0]]), np.array([y[0], y[0]]))
    tt = np.repeat(t, 2)[1:]
    yy = np.repeat(y, 2)[:-1]
    return tt, yy


def _stand_bars() -> tuple[uplot.Series, ...]:
    """The stand band, done and planned (faded)."""
    return tuple(
        uplot.Series(label=label, stroke=STAND_COLOR, width=0, fill=_hex_rgba(STAND_COLOR, alpha),
                     fillTo=STAND_BAND[0], points={"show": False})
        for label, alpha in (("stand", 0.85), ("stand plan", 0.3))
    )


class PlotHistory:
    """Rank per step and forward velocities, kept from the views the viewer draws (see the module doc)."""

    def __init__(self) -> None:
        self.ranks: deque[tuple[float, int]] = deque(maxlen=RANK_STEPS)
        self.velocity: deque[tuple[float, float, float]] = deque(maxlen=int(VELOCITY_WINDOW_S / VELOCITY_SAMPLE_S) + 1)
        self._steps: tuple[int, int] | None = None
        self._t = -1.0
        self.version = 0  # bumps when something was added

    def observe(self, view: LiveView) -> None:
        snap = view.snapshot
        t = float(snap.t_s)
        if t < self._t - 1e-9:  # a reset: start over
            self.ranks.clear()
            self.velocity.clear()
            self._steps, self._t = None, -1.0
        plans = (snap.steps, view.counts.plans)  # stand horizons are plans too (with a rank), not steps
        if plans != self._steps and snap.planned_steps:
            self._steps = plans
            rank = snap.planned_steps[0].rank
            if rank is not None:
                self.ranks.append((t, int(rank)))
                self.version += 1
        if t >= self._t + VELOCITY_SAMPLE_S - 1e-9 or self._t < 0:
            self._t = t
            self.velocity.append((t, float(snap.vel_cmd_xy[0]), float(snap.com_vel[0])))
            self.version += 1

    def rank_series(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.ranks:
            return np.zeros(2), np.zeros(2)
        t, rank = np.array(self.ranks, dtype=float).T
        return steps_shape(t, rank)

    def velocity_series(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(t, commanded vx, measured vx, measured vx averaged over SMOOTH_S)."""
        if len(self.velocity) < 2:
            return np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2)
        t, cmd, measured = np.array(self.velocity, dtype=float).T
        width = max(1, int(round(SMOOTH_S / VELOCITY_SAMPLE_S)))
        cumulative = np.concatenate([[0.0], np.cumsum(measured)])
        counts = np.minimum(np.arange(1, len(measured) + 1), width)
        smooth = (cumulative[1:] - cumulative[np.arange(1, len(measured) + 1) - counts]) / counts
        return t, cmd, measured, smooth


class PlotsPanel:
    """Four uPlot charts: gait schedule, rank per step, forward velocity, planning times."""

    def __init__(self, gui: viser.GuiApi, order: float = 30.0, leg_names: tuple[str, ...] = LEG_NAMES):
        self._seen = ChangeTracker()
        self.history = PlotHistory()
        self._drawn_version = -1
        self._next_slow = 0.0
        bar_mid = (*(3.4 - i for i in range(4)), STAND_BAND[0] + 0.5 * STAND_BAND[1])
        with gui.add_folder("Plots", order=order):
            self.gait_plot = gui.add_uplot(
                data=(np.zeros(2),) + (np.zeros(2),) * 10,
                series=(uplot.Series(label="t [s]"), *_leg_bars(leg_names, "", 0.85),
                        *_leg_bars(leg_names, " plan", 0.3), *_stand_bars()),
                title="Gait schedule: stance per leg over t [s] (faded: planned; stand: the planner chose not to step)",
                scales={"x": uplot.Scale(time=False),
                        "y": uplot.Scale(range=(STAND_BAND[0] - 0.1, 4.0), auto=False)},
                axes=(
                    uplot.Axis(),
                    uplot.Axis(splits=bar_mid, values=(*leg_names, "stand"), size=42, grid={"show": False},
                               ticks={"show": False}),
                ),
                legend=uplot.Legend(show=False),
                aspect=2.0,
            )
            self.rank_plot = gui.add_uplot(
                data=(np.zeros(2), np.zeros(2)),
                series=(
                    uplot.Series(label="t [s]"),
                    uplot.Series(label="rank chosen", stroke=RANK_COLOR, width=2, fill=_hex_rgba(RANK_COLOR, 0.15),
                                 points={"show": False}),
                ),
                title="Rank of the chosen step over t [s] (0 = first choice)",
                scales={"x": uplot.Scale(time=False), "y": uplot.Scale(range=(0.0, 8.0), auto=False)},
                axes=(uplot.Axis(), uplot.Axis(size=34)),
                legend=uplot.Legend(show=False),
                aspect=2.4,
            )
            self.velocity_plot = gui.add_uplot(
                data=(np.zeros(2),) * 4,
                series=(
                    uplot.Series(label="t [s]"),
                    uplot.Series(label="measured", stroke=_hex_rgba(MEASURED_COLOR, 0.35), width=1),
                    uplot.Series(label="measured, 1 s mean", stroke=MEASURED_COLOR, width=2.5),
                    uplot.Series(label="commanded", stroke=CMD_COLOR, width=2, dash=(6.0, 4.0)),  # drawn on top
                ),
                title="Forward velocity vx [m/s] over t [s]",
                scales={"x": uplot.Scale(time=False), "y": uplot.Scale(auto=True)},
                axes=(uplot.Axis(), uplot.Axis(size=44)),
                aspect=2.0,
            )
            self.timing_plot = gui.add_uplot(
                data=(np.zeros(1), np.zeros(1), np.zeros(1)),
                series=(
                    uplot.Series(label="t [s]"),
                    uplot.Series(label="planner ms", stroke="#e8590c", width=2),
                    uplot.Series(label="optimizer ms", stroke="#1c7ed6", width=2),
                ),
                title="Planner and optimizer time per plan [ms]",
                scales={"x": uplot.Scale(time=False), "y": uplot.Scale(auto=True)},
                aspect=2.0,
            )

    def observe(self, view: LiveView) -> None:
        self.history.observe(view)

    def refresh(self, view: LiveView) -> None:
        gait_key = (view.stance_history_node0, len(view.stance_history), view.plan_t0_s, id(view.planned_contact))
        if self._seen.changed("gait", gait_key):  # nothing to send while paused
            t, past, planned = gait_chart(view)
            stood, to_stand = stand_chart(view)
            base = 3.0 - np.arange(4)
            bottom, height = STAND_BAND
            self.gait_plot.data = (t, *(base + 0.8 * past).T, *(base + 0.8 * planned).T, bottom + height * stood,
                                   bottom + height * to_stand)
        now = time.monotonic()
        if now < self._next_slow:
            return
        self._next_slow = now + SLOW_PLOTS_S
        history = self.history
        if history.version != self._drawn_version:
            self._drawn_version = history.version
            t_rank, rank = history.rank_series()
            top = max(8.0, float(np.max(rank)) + 1.0) if len(rank) else 8.0
            if self._seen.changed("rank_top", top):
                self.rank_plot.scales = {"x": uplot.Scale(time=False), "y": uplot.Scale(range=(0.0, top), auto=False)}
            self.rank_plot.data = (t_rank, rank)
            t_v, cmd, measured, smooth = history.velocity_series()
            self.velocity_plot.data = (t_v, measured, smooth, cmd)
        timing = view.timing
        if len(timing) and self._seen.changed("timing", (len(timing), float(timing[-1, 0]))):
            self.timing_plot.data = (timing[:, 0].copy(), timing[:, 1].copy(), timing[:, 2].copy())
