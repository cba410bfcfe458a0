"""The "Plots" folder: the gait schedule (past stance and the plan ahead, per leg) and the planner's and
optimizer's time per plan."""

from __future__ import annotations

import numpy as np
import viser
import viser.uplot as uplot

from app.panels.common import ChangeTracker
from app.view import LiveView, gait_chart
from contactnet.robots import LEG_NAMES

LEG_COLORS = ("#e8590c", "#1c7ed6", "#2f9e44", "#ae3ec9")  # FL FR HL HR


def _hex_rgba(color: str, alpha: float) -> str:
    r, g, b = (int(color[i : i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha})"


def _leg_bars(suffix: str, alpha: float) -> tuple[uplot.Series, ...]:
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
        for i, (leg, color) in enumerate(zip(LEG_NAMES, LEG_COLORS, strict=True))
    )


class PlotsPanel:
    """Two uPlot charts, rewritten from every refreshed view."""

    def __init__(self, gui: viser.GuiApi, order: float = 30.0):
        self._seen = ChangeTracker()
        with gui.add_folder("Plots", order=order):
            self.gait_plot = gui.add_uplot(
                data=(np.zeros(2),) + (np.zeros(2),) * 8,
                series=(uplot.Series(label="t [s]"), *_leg_bars("", 0.85), *_leg_bars(" plan", 0.3)),
                title=f"Gait schedule: {' '.join(LEG_NAMES)} top to bottom; bar = stance",
                scales={"x": uplot.Scale(time=False), "y": uplot.Scale(range=(-0.1, 4.0), auto=False)},
                legend=uplot.Legend(show=False),
                aspect=1.6,
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
                aspect=1.6,
            )

    def refresh(self, view: LiveView) -> None:
        t, past, planned = gait_chart(view)
        base = 3.0 - np.arange(4)
        self.gait_plot.data = (t, *(base + 0.8 * past).T, *(base + 0.8 * planned).T)
        timing = view.timing
        if len(timing) and self._seen.changed("timing", (len(timing), float(timing[-1, 0]))):
            self.timing_plot.data = (timing[:, 0].copy(), timing[:, 1].copy(), timing[:, 2].copy())
