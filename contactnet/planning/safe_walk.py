"""The walk down the network's ranking to the first safe action, compiled with numba: the planner's hot loop on a
terrain with one level (``contactnet.planning.ranking.OneLevelWalk``).

``first_safe(costs, first, stop, ...)`` finds the action ``first_safe_step`` finds: in the stable ascending order
of ``costs[first:stop]`` (equal costs in index order, NaN last, as ``np.argsort(kind="stable")``), the first action
whose landing points are all covered by the safe region. It never sorts: it tries the cheapest action (usually it
is safe); an unsafe landing point rules out every action using its cell, and the cheapest action left is tried next.
Each grid cell is looked up at most once (``known``).
A landing point is ``(base + hip reference) + cell offset``, the same float64 operations in the same order as in
Python, so the same numbers; its cell of the raster of ``contactnet.terrain.locate.PointLocator`` says inside,
outside, or near an outline. Near an outline the outline's segments in that raster row decide (a ray's crossings
up to the next cell that is not near it, ``contactnet.terrain.crossings.near_outline``), unless the point lies
within ``NEAR_OUTLINE_M`` (1 nm) of one of them, where only shapely's exact predicates can answer: the walk then
stops and asks (``ASK``), the caller sets that cell's answer in ``known`` and calls again. Because of that the
compiled code needs nothing but arrays.

Why compiled: in Python each unsafe cell cost about 1.5 us of interpreter work (and the rank 2 us more), so the
planner's time grew with the number of holes (``contactnet bench planner``: the trot's plan took 1.36 times as long
with 100 holes as with none). The kernel is compiled on first use and cached next to this file (``cache=True``).
"""

from __future__ import annotations

import numba
import numpy as np

from contactnet.terrain.crossings import CELL_BOUNDARY as _BOUNDARY
from contactnet.terrain.crossings import CELL_INSIDE as _INSIDE
from contactnet.terrain.crossings import INSIDE, OUTSIDE, near_outline

#: ``known`` per grid cell (leg * cells_per_leg + cell): not looked up yet, safe, unsafe (``near_outline``'s answers).
UNKNOWN, SAFE, UNSAFE = 0, INSIDE, OUTSIDE
#: ``first_safe``'s status: an action found, none is safe, a cell near an outline must be asked of shapely.
FOUND, NONE, ASK = 0, 1, 2


@numba.njit(cache=True, nogil=True)
def _lookup(x: float, y: float, raster: np.ndarray, codes: np.ndarray, entries: np.ndarray,
            row_first: np.ndarray) -> int:
    """SAFE or UNSAFE from the raster for the point (x, y), in a cell near an outline from the outline itself
    (``near_outline``), or -1 when it lies on the outline within ``NEAR_OUTLINE_M``."""
    col = x * raster[0] - raster[1]
    row = y * raster[0] - raster[2]
    if not col > 0.0:  # also NaN
        col = 0.0
    elif col > raster[3]:
        col = raster[3]
    if not row > 0.0:
        row = 0.0
    elif row > raster[3]:
        row = raster[3]
    code = codes[int(col) + int(row) * int(raster[4])]
    if code == _BOUNDARY:
        return near_outline(x, y, int(col), int(row), raster, codes, entries, row_first)
    return SAFE if code == _INSIDE else UNSAFE


@numba.njit(cache=True, nogil=True)
def _cell_state(flat: int, leg_cell: np.ndarray, hips: np.ndarray, offsets: np.ndarray, base_x: float,
                base_y: float, raster: np.ndarray, codes: np.ndarray, entries: np.ndarray, row_first: np.ndarray,
                ahead_x: float, ahead_y: float) -> int:
    """SAFE or UNSAFE from the raster (and the outline, ``_lookup``), or -1 when the landing point (or the point
    ``ahead``) lies on the outline. ``raster``: (inv_cell, first_col, first_row, clamp_hi, side) as ``PointLocator.covers_xy`` uses them.
    With ``ahead`` not zero the point that far on must be safe too (``contactnet.planning.roll``)."""
    leg, cell = leg_cell[flat, 0], leg_cell[flat, 1]
    x = (base_x + hips[leg, 0]) + offsets[cell, 0]
    y = (base_y + hips[leg, 1]) + offsets[cell, 1]
    state = _lookup(x, y, raster, codes, entries, row_first)
    if state == UNSAFE or (ahead_x == 0.0 and ahead_y == 0.0):
        return state
    further = _lookup(x + ahead_x, y + ahead_y, raster, codes, entries, row_first)
    if further == UNSAFE:
        return UNSAFE
    return -1 if further < 0 else state


@numba.njit(cache=True, nogil=True)
def _all_safe(action: int, action_flat: np.ndarray, known: np.ndarray, leg_cell: np.ndarray, hips: np.ndarray,
              offsets: np.ndarray, base_x: float, base_y: float, raster: np.ndarray, codes: np.ndarray,
              entries: np.ndarray, row_first: np.ndarray, ahead_x: float, ahead_y: float) -> int:
    """SAFE if every landing point of ``action`` is safe, UNSAFE if one is not, ``-1 - flat`` to ask about cell
    ``flat`` first."""
    for k in range(action_flat.shape[1]):
        flat = action_flat[action, k]
        state = known[flat]
        if state == UNKNOWN:
            state = _cell_state(flat, leg_cell, hips, offsets, base_x, base_y, raster, codes, entries, row_first,
                                ahead_x, ahead_y)
            if state < 0:
                return -1 - flat
            known[flat] = state
        if state == UNSAFE:
            return UNSAFE
    return SAFE


@numba.njit(cache=True, nogil=True)
def _ruled_out(action: int, action_flat: np.ndarray, known: np.ndarray) -> bool:
    """Whether a landing point of ``action`` is known to be unsafe."""
    for k in range(action_flat.shape[1]):
        if known[action_flat[action, k]] == UNSAFE:
            return True
    return False


@numba.njit(cache=True, nogil=True)
def rank_of(costs: np.ndarray, first: int, stop: int, action: int) -> int:
    """The position of ``action`` in the stable ascending order of ``costs[first:stop]`` (NaN last)."""
    cost, rank = costs[action], 0
    if cost != cost:  # NaN: after every number, and after the NaNs before it
        for a in range(first, stop):
            if costs[a] == costs[a] or a < action:
                rank += 1
        return rank
    for a in range(first, stop):
        if costs[a] < cost or (costs[a] == cost and a < action):
            rank += 1
    return rank


#: How many of the cheapest actions not ruled out one pass over the span keeps (``first_safe``), tried in turn before
#: the next pass: on a field with holes a step rules out several cells, and each pass costs the whole span.
_CHEAPEST = 8


@numba.njit(cache=True, nogil=True)
def first_safe(costs: np.ndarray, first: int, stop: int, action_flat: np.ndarray, leg_cell: np.ndarray,
               hips: np.ndarray, offsets: np.ndarray, base_x: float, base_y: float, raster: np.ndarray,
               codes: np.ndarray, entries: np.ndarray, row_first: np.ndarray,
               known: np.ndarray, ahead_x: float = 0.0, ahead_y: float = 0.0) -> tuple[int, int, int]:
    """(status, rank, action or the cell to ask about) of the first safe action of ``first..stop - 1`` in the stable
    ascending order of their ``costs``. ``action_flat`` (N_a, legs per step): each action's grid cells;
    ``leg_cell`` (cells, 2): each grid cell's leg and cell of its leg's grid; ``hips`` (4, 2) and ``offsets``
    (cells_per_leg, 2): world XY of the hip references and the cell offsets; ``known`` (cells,) int8, kept between
    calls of one evaluation. ``ahead_x, ahead_y``: a landing point is safe only if the point that far on (world,
    metres) is safe too (``contactnet.planning.roll``); zero for the landing point alone.

    No sort: the cheapest action not ruled out is tried; an unsafe landing point rules out every action that uses
    its cell, and the next cheapest is tried, until one is safe. One pass over the span keeps its ``_CHEAPEST``
    cheapest actions not ruled out (below +inf, in the stable order), tried in turn (those ruled out meanwhile
    skipped) before the next pass: every action left out costs at least as much as the last kept one (and comes
    after it), so the actions are tried in the same order as one pass per try would try them. With no such action,
    the actions of cost +inf in index order, then the NaNs."""
    kept_cost = np.empty(_CHEAPEST)
    kept = np.empty(_CHEAPEST, np.int64)
    while True:
        n, first_inf, first_nan = 0, -1, -1
        for a in range(first, stop):
            cost = costs[a]
            if cost < np.inf:  # a number below +inf (not NaN)
                if n < _CHEAPEST or cost < kept_cost[_CHEAPEST - 1]:
                    if not _ruled_out(a, action_flat, known):
                        at = min(n, _CHEAPEST - 1)  # after every kept one of a cost <= this one's (stable)
                        while at > 0 and kept_cost[at - 1] > cost:
                            kept_cost[at], kept[at] = kept_cost[at - 1], kept[at - 1]
                            at -= 1
                        kept_cost[at], kept[at] = cost, a
                        n = min(n + 1, _CHEAPEST)
            elif n == 0 and (first_inf < 0 if cost == np.inf else first_nan < 0):
                if not _ruled_out(a, action_flat, known):
                    if cost == np.inf:
                        first_inf = a
                    else:
                        first_nan = a
        if n == 0:
            kept[0] = first_inf if first_inf >= 0 else first_nan
            if kept[0] < 0:
                return NONE, -1, -1
            n = 1
        for i in range(n):
            best = kept[i]
            if i > 0 and _ruled_out(best, action_flat, known):
                continue
            state = _all_safe(best, action_flat, known, leg_cell, hips, offsets, base_x, base_y, raster, codes,
                              entries, row_first, ahead_x, ahead_y)
            if state < 0:
                return ASK, 0, -1 - state
            if state == SAFE:
                return FOUND, rank_of(costs, first, stop, best), best


@numba.njit(cache=True, nogil=True)
def first_safe_with_room(costs: np.ndarray, first: int, stop: int, per_group: int, action_flat: np.ndarray,
                         leg_cell: np.ndarray, hips: np.ndarray, offsets: np.ndarray, base_x: float, base_y: float,
                         raster: np.ndarray, codes: np.ndarray, entries: np.ndarray, row_first: np.ndarray,
                         known: np.ndarray, known_room: np.ndarray, ahead_x: float,
                         ahead_y: float) -> tuple[int, int, int]:
    """``first_safe``'s action with room for the foot's roll (``contactnet.planning.roll``), in one call: the first
    safe action of ``first..stop - 1``; if a landing point of it lacks the room ``ahead`` (world, metres: the point
    that far on is not safe), the first action of its swing group (``per_group`` actions each) in the same span
    whose landing points have it (with its rank in the whole span), else the first safe action itself.
    ``known_room`` caches the cells' answers with the room as ``known`` does without it. With the status ASK the
    third value is a cell of ``known`` (0..cells - 1) or of ``known_room`` (cells..2 cells - 1, less cells)."""
    status, rank, found = first_safe(costs, first, stop, action_flat, leg_cell, hips, offsets, base_x, base_y,
                                     raster, codes, entries, row_first, known, 0.0, 0.0)
    if status != FOUND:
        return status, rank, found
    cells = known.shape[0]
    state = _all_safe(found, action_flat, known_room, leg_cell, hips, offsets, base_x, base_y, raster, codes,
                      entries, row_first, ahead_x, ahead_y)
    if state < 0:
        return ASK, 0, cells - 1 - state
    if state == SAFE:  # it has the room (most plans)
        return FOUND, rank, found
    group = found // per_group
    status, _, better = first_safe(costs, max(first, group * per_group), min(stop, (group + 1) * per_group),
                                   action_flat, leg_cell, hips, offsets, base_x, base_y, raster, codes, entries,
                                   row_first, known_room, ahead_x, ahead_y)
    if status == ASK:
        return ASK, 0, cells + better
    if status == NONE or better == found:
        return FOUND, rank, found
    return FOUND, rank_of(costs, first, stop, better), better
