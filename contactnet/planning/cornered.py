"""A cornered leg (terrain with heights): its rule's numbers and tests, used by ``ContactNetPlanner``.

A leg is *cornered* when its shank, knee or thigh would reach the terrain if it stood where it is for
``CORNERED_LOOKAHEAD_STEPS`` more steps of the commanded motion (``FootholdChecker.stance_clear``: a hind foot behind
a higher top, the body moving on over it). The network knows nothing of heights and may keep such a leg down until it
touches, so

- the first step's ranking puts the actions that move a cornered leg at least ``CORNERED_MIN_PROGRESS_M`` forward
  first (each part in its own order; a step in place leaves it cornered: docs/results.md, "A cornered leg steps
  forward") and the robot does not stand (``HeightsWalk`` finds both);
- when none of those is usable and the first step may swing a cornered leg (``may_step``), the first step is
  planned once more on its candidate grid moved ``CORNERED_GRID_SHIFT_CELLS`` cells along the heading (the cornered
  leg's cells one further on: a top further ahead, beyond the riser it stands behind), and that plan is taken if it
  moves a cornered leg forward (docs/results.md, "The shift only when nothing else moves the cornered leg").
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from contactnet.motion.gait import GaitSpec
from contactnet.planning.ranking import PlannedStep, urgent_first

#: A cornered leg's step (``ContactNetPlanner``) is promoted only if it lands at least this far ahead (m).
CORNERED_MIN_PROGRESS_M = 0.02
#: ... and a leg is cornered when its lower leg would reach the terrain this many steps of motion ahead.
CORNERED_LOOKAHEAD_STEPS = 3.0
#: The first step's grid moves this many cells along the heading when no action moves a cornered leg forward.
CORNERED_GRID_SHIFT_CELLS = 1


def moves_cornered_leg(step: PlannedStep, cornered: np.ndarray, feet_xy_world: np.ndarray,
                       forward_xy: tuple[float, float], min_progress_m: float) -> bool:
    """Whether ``step`` lands one of the ``cornered`` legs ((4,) bool) at least ``min_progress_m`` ahead of where
    its foot stands (``feet_xy_world`` (4, 2)) along ``forward_xy`` (the heading's cosine and sine)."""
    forward_x, forward_y = forward_xy
    for leg, point in zip(step.legs, step.footholds_xy_world, strict=True):
        progress = (point[0] - feet_xy_world[leg, 0]) * forward_x + (point[1] - feet_xy_world[leg, 1]) * forward_y
        if cornered[leg] and progress >= min_progress_m:
            return True
    return False


def may_step(cornered: np.ndarray, gait: GaitSpec, span: tuple[int, int]) -> bool:
    """Whether the first step's actions ``span`` (first, stop) of ``gait`` swing one of the ``cornered`` legs ((4,)
    bool): the fixed gait's turn may be another leg's."""
    per_group = gait.actions_per_group
    groups = gait.swing_groups[span[0] // per_group: -(-span[1] // per_group)]
    return any(cornered[leg] for group in groups for leg in group)


def grid_shift_xy(forward_xy: tuple[float, float], spacing_m: float) -> tuple[float, float]:
    """The first step's grid shift (world XY, m) for a cornered leg with no forward step: ``CORNERED_GRID_SHIFT_CELLS``
    cells of ``spacing_m`` along the heading ``forward_xy``."""
    distance_m = CORNERED_GRID_SHIFT_CELLS * spacing_m
    return forward_xy[0] * distance_m, forward_xy[1] * distance_m


def urgent_ranking(ranking: Callable[[], np.ndarray], urgent: Callable[[], np.ndarray], first: int) -> np.ndarray:
    """The first step's ranking with a cornered leg: ``ranking()`` with the ``urgent()`` actions (bool per action
    from ``first``, ``HeightsWalk.urgent``) first, each part in its own order."""
    return urgent_first(ranking(), urgent(), first)


__all__ = ["CORNERED_GRID_SHIFT_CELLS", "CORNERED_LOOKAHEAD_STEPS", "CORNERED_MIN_PROGRESS_M", "grid_shift_xy",
           "may_step", "moves_cornered_leg", "urgent_ranking"]
