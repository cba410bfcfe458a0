"""Touchdown as sensed, on terrain with heights (``contactnet.locomotion``: ``LocomotionConfig.adapt_touchdown``).

A swinging foot that touches the terrain in the last quarter of its swing near its landing point is a stance foot
from then on (a top higher than planned); one that has not touched at the planned touchdown keeps descending below
its planned landing point until it touches or has gone a set depth deeper, then it is a stance foot whatever the
sensors say."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from contactnet.motion.active_plan import ActivePlan


def adapt_to_contact(plan: ActivePlan, t_s: float, stance: np.ndarray, swing_pos: np.ndarray, swing_vel: np.ndarray,
                     landed: Callable[[object, int], bool], late_speed_m_s: float, late_depth_m: float) -> None:
    """Touchdown as sensed at ``t_s``, in place on ``stance`` (4,), ``swing_pos`` and ``swing_vel`` (4, 3), for the
    swinging legs of ``plan`` (``plan.touched`` records those that came down). ``landed(swing, leg)``: the foot
    touches the terrain near its landing point now; a late foot descends at ``late_speed_m_s`` to at most
    ``late_depth_m`` below its landing point."""
    for leg, swing in plan.swings.items():
        if plan.touched[leg]:
            stance[leg] = True
            continue
        late_s = t_s - swing.t1_s
        if late_s < -0.25 * (swing.t1_s - swing.t0_s):
            continue
        depth = late_speed_m_s * max(late_s, 0.0)
        if depth > late_depth_m or landed(swing, leg):
            plan.touched[leg] = True
            stance[leg] = True
            continue
        if late_s >= 0.0:
            stance[leg] = False
            swing_pos[leg] = swing.end_world - np.array([0.0, 0.0, depth])
            swing_vel[leg] = np.array([0.0, 0.0, -late_speed_m_s])


__all__ = ["adapt_to_contact"]
