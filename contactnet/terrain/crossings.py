"""The compiled point-in-region test near an outline: a ray's crossings of the outline's segments (numba).

A region's raster (``contactnet.terrain.locate.PointLocator``) answers most points by their cell; in a cell the
outline may pass through (BOUNDARY) the outline itself decides: a ray from the point towards +x, as far as the next
cell of the raster row that is not BOUNDARY (entirely inside or entirely outside the region: its code says which),
crosses the outline's segments an odd number of times when the point's answer differs from that cell's. Only the
row's segments that may reach the stretch of the ray are looked at (``OutlineRows``: each row's segments sorted by
their lowest x, with the furthest x reached so far), so the cost of a point does not grow with the number of holes
in its row. Within ``NEAR_OUTLINE_M`` (1 nm) of a segment the answer is left to shapely's exact predicates
(``ON_OUTLINE``): the crossing's x is computed with rounding (about 1e-15 m at terrain coordinates), far below that
distance, and no segment comes that close to a cell that is not BOUNDARY, so everywhere else the answer is shapely's.
Used by the planner's compiled walk down the ranking (``contactnet.planning.safe_walk``) and by
``PointLocator.covers_xy``, where it replaces a shapely question of about 20 us by about a microsecond. Compiled on
first use, cached next to this file.
"""

from __future__ import annotations

import numba
import numpy as np

#: Within this distance (m) of an outline a compiled point test defers to shapely (`OutlineRows`): far beyond the
#: rounding of a crossing's x at terrain coordinates (about 1e-15 m), so elsewhere it gives shapely's answer.
NEAR_OUTLINE_M = 1e-9
#: ``near_outline``'s answers: inside the region, outside, on its outline (shapely must answer).
INSIDE, OUTSIDE, ON_OUTLINE = 1, 2, -1
#: The codes of a `PointLocator` raster's cells: entirely outside, entirely inside, the outline may pass through.
CELL_OUTSIDE, CELL_INSIDE, CELL_BOUNDARY = 0, 1, 2
#: The columns of ``OutlineRows.entries``: a segment (x0, y0, x1, y1), its lowest x, the highest x of it and of
#: every segment before it in its row.
X0, Y0, X1, Y1, LOW_X, REACH_X = range(6)
_NEAR2 = NEAR_OUTLINE_M * NEAR_OUTLINE_M


@numba.njit(cache=True, nogil=True)
def near_outline(x: float, y: float, col: int, row: int, raster: np.ndarray, codes: np.ndarray, entries: np.ndarray,
                 row_first: np.ndarray) -> int:
    """INSIDE or OUTSIDE for a point (x, y) of the BOUNDARY cell (``col``, ``row``) of a raster (``raster``:
    `PointLocator.raster`, ``codes`` its cells) from the region's outline (``OutlineRows``): the code of the next
    cell towards +x in the row that is not BOUNDARY, flipped by each segment the ray from the point to it crosses;
    ON_OUTLINE when the point lies within ``NEAR_OUTLINE_M`` of a segment, where shapely must answer."""
    side = int(raster[4])
    end = col + 1
    while codes[end + row * side] == CELL_BOUNDARY:  # the raster's outermost cells are never BOUNDARY
        end += 1
    inside = codes[end + row * side] == CELL_INSIDE
    x_end = (end + raster[1]) / raster[0]  # the left side of that cell
    first, stop = row_first[row], row_first[row + 1]
    while first < stop:  # stop: past the last entry that starts before the cell (plus NEAR_OUTLINE_M)
        middle = (first + stop) // 2
        if entries[middle, LOW_X] <= x_end + NEAR_OUTLINE_M:
            first = middle + 1
        else:
            stop = middle
    for k in range(stop - 1, row_first[row] - 1, -1):
        if entries[k, REACH_X] < x - NEAR_OUTLINE_M:  # this one and those before it end left of the point
            break
        x0, y0, x1, y1 = entries[k, X0], entries[k, Y0], entries[k, X1], entries[k, Y1]
        dx, dy = x1 - x0, y1 - y0
        if (min(x0, x1) - NEAR_OUTLINE_M <= x <= max(x0, x1) + NEAR_OUTLINE_M
                and min(y0, y1) - NEAR_OUTLINE_M <= y <= max(y0, y1) + NEAR_OUTLINE_M):  # else further than that
            length2 = dx * dx + dy * dy
            t = 0.0 if length2 == 0.0 else min(1.0, max(0.0, ((x - x0) * dx + (y - y0) * dy) / length2))
            ex, ey = x0 + t * dx - x, y0 + t * dy - y
            if ex * ex + ey * ey <= _NEAR2:
                return ON_OUTLINE
        if (y0 > y) != (y1 > y):
            crossing_x = x0 + (y - y0) * dx / dy
            if x < crossing_x < x_end:
                inside = not inside
    return INSIDE if inside else OUTSIDE


@numba.njit(cache=True, nogil=True)
def running_reach(row_first: np.ndarray, high_x: np.ndarray) -> np.ndarray:
    """``OutlineRows``' REACH_X: per row (``row_first``), the running maximum of ``high_x`` (entries in the row's
    order)."""
    reach = np.empty_like(high_x)
    for row in range(row_first.shape[0] - 1):
        furthest = -np.inf
        for k in range(row_first[row], row_first[row + 1]):
            furthest = max(furthest, high_x[k])
            reach[k] = furthest
    return reach


__all__ = ["CELL_BOUNDARY", "CELL_INSIDE", "CELL_OUTSIDE", "INSIDE", "NEAR_OUTLINE_M", "ON_OUTLINE", "OUTSIDE",
           "near_outline", "running_reach"]
