"""Swing trajectories over terrain with heights: how high the apex goes and how vertically the foot leaves
and lands, from the tops along the way.

On flat ground a swing rises ``height_m`` above the higher of its ends (``SwingTrajectory``). Over tops at
several heights ``swing_over_terrain`` looks at the terrain under the straight path from lift-off to
touchdown (``Terrain.height_at`` every ``SAMPLE_SPACING_M``, each sample taking the highest top within a
foot radius of it, as the ball is that wide):

- the apex rises ``height_m`` above the highest of them (plus the foot radius: the trajectory is the
  ball's centre);
- the foot must pass ``clearance_m`` above every top it travels over that is higher than the top of the
  end it is nearer to (an edge to clear), and above the others at all, away from its own ends (within a
  radius and the safety margin of the lift-off and landing points the ball stands on its own top).
  The swing uses the smallest vertical lift-off and touchdown fractions (``VERTICAL_FRACTIONS`` each,
  their sum as small as possible) that achieve it: none (today's swing) when the foot clears anyway, more
  when an edge is close to the lift-off or landing point;
- a step up or down (tops differing by more than ``LEVEL_TOLERANCE_M``) leaves or lands near-vertically:
  a foot that steps up to a top higher than its lift-off rises first (lift-off fraction at least
  ``STEP_FRACTION``), one that steps down past a top higher than its landing comes down last (touchdown
  fraction at least ``STEP_FRACTION``). The lower leg slants up from the foot toward its knee and would
  sweep the edge next to the foot while the foot moves.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from contactnet.motion.controller import SwingTrajectory
from contactnet.terrain import Terrain

SAMPLE_SPACING_M = 0.005
VERTICAL_FRACTIONS = (0.0, 0.1, 0.2, 0.3)
END_ZONE_MARGIN_M = 0.008  # beyond the ball's radius, the zone around each end that is the end's own top
STEP_FRACTION = 0.2
LEVEL_TOLERANCE_M = 0.01
#: (lift-off, touchdown) fractions in the order they are tried.
_FRACTION_PAIRS = sorted(((a, b) for a in VERTICAL_FRACTIONS for b in VERTICAL_FRACTIONS),
                         key=lambda pair: (sum(pair), pair[1]))


def swing_over_terrain(
    terrain: Terrain,
    start_world: np.ndarray,
    end_world: np.ndarray,
    t0_s: float,
    t1_s: float,
    height_m: float,
    foot_radius_m: float,
    clearance_m: float = 0.015,
) -> SwingTrajectory:
    """The swing from ``start_world`` to ``end_world`` (foot-ball centres) that clears the terrain between them
    (see the module doc)."""
    start = np.asarray(start_world, dtype=float)
    end = np.asarray(end_world, dtype=float)
    length = float(np.hypot(*(end[:2] - start[:2])))
    n = max(2, math.ceil(length / SAMPLE_SPACING_M))
    progress = np.linspace(0.0, 1.0, n + 1)
    points = start[:2] + progress[:, None] * (end[:2] - start[:2])
    tops = terrain.height_at(points, outside=-np.inf)
    window = math.ceil(foot_radius_m / max(length / n, 1e-9)) if length > 0 else 0
    padded = np.pad(tops, window, constant_values=-np.inf)
    under_ball = np.max(np.lib.stride_tricks.sliding_window_view(padded, 2 * window + 1), axis=1)
    highest = float(under_ball.max())
    clear_z = highest + foot_radius_m if np.isfinite(highest) else None
    distance = progress * length
    travelling = ((distance >= foot_radius_m + END_ZONE_MARGIN_M)
                  & (distance <= length - foot_radius_m - END_ZONE_MARGIN_M))
    nearer_end_top = np.where(progress < 0.5, tops[0], tops[-1])
    obstacle = under_ball > nearer_end_top + LEVEL_TOLERANCE_M
    needed = (under_ball + foot_radius_m + np.where(obstacle, clearance_m, 0.0))[travelling]
    stepping_down = np.isfinite(highest) and highest > float(tops[-1]) + LEVEL_TOLERANCE_M
    stepping_up = np.isfinite(highest) and highest > float(tops[0]) + LEVEL_TOLERANCE_M
    min_liftoff = STEP_FRACTION if stepping_up else 0.0
    min_touchdown = STEP_FRACTION if stepping_down else 0.0
    swing = None
    for liftoff, touchdown in _FRACTION_PAIRS:
        if liftoff < min_liftoff or touchdown < min_touchdown:
            continue
        swing = SwingTrajectory(start_world=start.copy(), end_world=end.copy(), t0_s=t0_s, t1_s=t1_s,
                                height_m=height_m, clear_z_m=clear_z, liftoff_fraction=liftoff,
                                touchdown_fraction=touchdown)
        if not needed.size or np.all(swing.height_at_progress(progress[travelling]) >= needed):
            break
    return swing


#: ``swing_past_holes``: how far past the foot ball (foot radii) along the path a hole makes an end vertical, and
#: the spacing (foot radii) of the points asked.
HOLE_ZONE_RADII, HOLE_SAMPLE_RADII = 2.5, 0.25


def swing_past_holes(terrain: Terrain, start_world: np.ndarray, end_world: np.ndarray, t0_s: float, t1_s: float,
                     height_m: float, foot_radius_m: float, fraction: float,
                     too_short: Callable[[float, float], bool] | None) -> SwingTrajectory:
    """The swing on terrain of one level (``SwingTrajectory``, apex ``height_m`` over its ends) that lifts off (lands)
    vertically for ``fraction`` of its time when its lift-off (landing) point is on a top that is too short for the
    foot's roll (``too_short(x, y)``: ``contactnet.planning.roll.short_top_test``; None: no such top, no command) and
    a hole lies on its path within ``HOLE_ZONE_RADII`` foot radii past the ball there. Traced on ``narrow_map`` (3 cm
    bars): a hind foot's 20 cm swing onto a bar came down over the gap, 1.7 cm short of the bar's edge. Elsewhere it
    is the plain swing: made vertical on wider tops too, a front foot's 27 cm step across a 24 cm gap, its horizontal
    motion in 80 % of the time, came down short of a 6 cm bar (measured: docs/results.md)."""
    start, end = np.asarray(start_world, dtype=float), np.asarray(end_world, dtype=float)
    liftoff = touchdown = 0.0
    along = end[:2] - start[:2]
    length = float(np.hypot(*along))
    distances = foot_radius_m * np.arange(1.0, 1.0 + HOLE_ZONE_RADII + 1e-9, HOLE_SAMPLE_RADII)
    distances = distances[distances <= 0.5 * length]
    if fraction > 0.0 and distances.size and too_short is not None:
        unit = along / length
        ends = np.array([start[:2], end[:2]])
        points = np.concatenate([ends, start[:2] + distances[:, None] * unit, end[:2] - distances[:, None] * unit])
        on_top = terrain.is_safe(points, 0.0)  # the ends on a top (a foot put in a hole is not made vertical)
        next_to_hole = ~on_top[2:2 + distances.size].all(), ~on_top[2 + distances.size:].all()
        if on_top[0] and next_to_hole[0] and too_short(float(start[0]), float(start[1])):
            liftoff = fraction
        if on_top[1] and next_to_hole[1] and too_short(float(end[0]), float(end[1])):
            touchdown = fraction
    return SwingTrajectory(start_world=start, end_world=end, t0_s=t0_s, t1_s=t1_s, height_m=height_m,
                           liftoff_fraction=liftoff, touchdown_fraction=touchdown)


__all__ = ["END_ZONE_MARGIN_M", "HOLE_SAMPLE_RADII", "HOLE_ZONE_RADII", "LEVEL_TOLERANCE_M",
           "SAMPLE_SPACING_M", "STEP_FRACTION", "VERTICAL_FRACTIONS", "swing_over_terrain", "swing_past_holes"]
