"""The "Legend" folder, open at the top of the panel: every colour the 3D view uses (taken from
`app/scene/live_scene.py`, `app/scene/marks.py` and `app/scene/robot_display.py`, so legend and scene cannot disagree), the ranking's colour
scale, and what the last clicked candidate disk is (leg, rank, safe or not, score when known)."""

from __future__ import annotations

import html

import numpy as np
import viser

from app.live.view import LiveView
from app.scene.live_scene import (
    ACTUAL_COM_COLOR,
    CHOSEN_COLOR,
    ESTIMATED_PUSH_COLOR,
    FORCE_COLOR,
    GOAL_COLOR,
    PLANNED_COM_COLOR,
    PUSH_COLOR,
    RANK_FADE,
    STEP_COLORS,
    UNSAFE_COLOR,
    UNSAFE_STEP_COLOR,
    LiveScene,
    PickedCandidate,
    shown_color,
    shown_rank_color,
)
from app.scene.marks import RETARGET_COLOR, STAND_COLOR
from app.scene.robot_display import GHOST_COLOR
from app.viewer.panels.common import ChangeTracker

PICK_HINT = "Click a disk to see its leg, rank and safety."


def _css(color) -> str:  # noqa: ANN001 - an RGB triple (0-255) or an RGBA one (0-1)
    c = np.asarray(color, dtype=float)
    if c.max() <= 1.0:  # 0-1 floats (viser's mesh colours)
        c = c * 255.0
    rgb = ",".join(str(int(round(v))) for v in c[:3])
    return f"rgba({rgb},{c[3] / 255.0:.2f})" if len(c) == 4 else f"rgb({rgb})"


def _swatch(kind: str, color, label: str) -> str:  # noqa: ANN001
    """One legend entry: a small disk, ball or line in ``color``, then ``label``."""
    shape = {
        "disk": "width:13px;height:13px;border-radius:50%",
        "small": "width:8px;height:8px;border-radius:50%;margin:0 2.5px",
        "ball": "width:11px;height:11px;border-radius:50%;margin:0 1px;box-shadow:inset -2px -2px 3px rgba(0,0,0,.3)",
        "line": "width:16px;height:3px;margin:5px 0",
        "robot": "width:16px;height:10px;border-radius:3px",
        "ring": "width:7px;height:7px;border-radius:50%;margin:0 1px",
    }[kind]
    paint = f"border:3px solid {_css(color)}" if kind == "ring" else f"background:{_css(color)}"
    return (
        '<div style="display:flex;align-items:center;gap:6px;min-width:0">'
        f'<span style="flex:none;display:inline-block;{shape};{paint}"></span>'
        f'<span style="overflow:hidden;text-overflow:ellipsis">{html.escape(label)}</span></div>'
    )


def rank_scale_html() -> str:
    """The ranking's colour scale: the best safe candidate (0) to RANK_FADE and more places down."""
    stops = ", ".join(_css(c) for c in shown_rank_color(np.arange(RANK_FADE + 1)))
    ticks = "".join(
        f'<span style="flex:1;text-align:{"left" if k == 0 else "right" if k == RANK_FADE else "center"}">'
        f'{k if k < RANK_FADE else f"{RANK_FADE}+"}</span>'
        for k in range(0, RANK_FADE + 1, 2)
    )
    return (
        '<div style="margin:2px 0 6px 0">'
        '<div style="font-size:0.92em;margin-bottom:2px">Safe candidate footholds, by ranking</div>'
        f'<div style="height:12px;border-radius:6px;background:linear-gradient(to right, {stops})"></div>'
        f'<div style="display:flex;font-size:0.8em;opacity:.8">{ticks}</div>'
        '<div style="font-size:0.8em;opacity:.8;margin-top:-2px">places below the best safe one '
        "(green = the planner's first safe choice). A planner that does not rank (heuristic, fixed): "
        "every safe one green.</div></div>"
    )


def legend_html() -> str:
    """The whole legend (HTML, inline styles only)."""
    entries = (
        _swatch("disk", shown_color(CHOSEN_COLOR), "chosen foothold"),
        _swatch("small", shown_color(UNSAFE_COLOR), "unsafe candidate"),
        _swatch("ball", STEP_COLORS[0], "planned steps (3)"),
        _swatch("ball", UNSAFE_STEP_COLOR, "planned step, unsafe"),
        _swatch("line", PLANNED_COM_COLOR, "planned CoM"),
        _swatch("line", ACTUAL_COM_COLOR, "actual CoM path"),
        _swatch("line", FORCE_COLOR, "foot forces"),
        _swatch("line", PUSH_COLOR, "push"),
        _swatch("line", ESTIMATED_PUSH_COLOR, "push, as estimated"),
        _swatch("line", GOAL_COLOR, "goal line"),
        _swatch("robot", GHOST_COLOR, "compared robot"),
        _swatch("line", STAND_COLOR, "standing by choice (feet)"),
        _swatch("ring", RETARGET_COLOR, "swing retargeted (flash)"),
    )
    grid = (
        '<div style="display:grid;grid-template-columns:repeat(auto-fill,minmax(150px,1fr));'
        f'gap:3px 10px;font-size:0.92em">{"".join(entries)}</div>'
    )
    return f'<div style="padding:0 2px">{rank_scale_html()}{grid}</div>'


class LegendPanel:
    """The legend (static HTML) and the last picked disk (updated on a click)."""

    def __init__(self, gui: viser.GuiApi, scene: LiveScene, order: float = 1.0):
        self._seen = ChangeTracker()
        self._picked: PickedCandidate | None = None
        self._stale = False
        with gui.add_folder("Legend", order=order, expand_by_default=True):
            self.legend = gui.add_html(legend_html())
            self.picked = gui.add_markdown(PICK_HINT)
        scene.pick_listeners.append(self._on_pick)

    def _on_pick(self, client: viser.ClientHandle | None, picked: PickedCandidate | None) -> None:
        if picked is None:
            self._stale = self._picked is not None
        else:
            self._picked, self._stale = picked, False
        self._show()

    def _show(self) -> None:
        picked = self._picked
        if picked is None:
            text = PICK_HINT
        else:
            text = f"Disk: **{picked.text()}** at ({picked.xy_world[0]:.2f}, {picked.xy_world[1]:.2f}) m"
            if self._stale:
                text += "  \n*(that step is over: click a disk of the current one)*"
        if self._seen.changed("picked", text):
            self.picked.content = text

    def refresh(self, view: LiveView) -> None:
        """Nothing to do per view: picks arrive through the scene."""
