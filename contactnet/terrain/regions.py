"""Region shapes as shapely geometry; grids traced straight from their cells, in time linear in the cells.

``region_geometry`` turns one normalized region (``contactnet.terrain.schema``) into a polygon: rects,
circles (an inscribed polygon within ``CIRCLE_MAX_ERROR_M``), stars and polygons from their outlines.

A grid's steppable set is the union of its present cells. Asking GEOS to unite thousands of squares
took seconds for a 500 x 500 grid; here the outline is traced from the raster instead:

- the boundary between present and removed cells is cut into *sides*: maximal straight runs with the
  present cells on their left, so shells run counter-clockwise and holes clockwise;
- each side continues at its end vertex with the one side that starts there, except where two present
  cells touch only at a corner (a *pinch*): there the side turns left (keeping the two cells apart)
  when they belong to different 4-connected components, else right (splitting off the hole between
  them). Every ring is then simple, and rings touch only at pinches, which is what GEOS itself builds;
- rings are grouped by the component on their left: its one counter-clockwise ring is the shell, the
  clockwise ones its holes. Components come from the rows' runs of present cells, joined where runs
  of neighbouring rows share a column (vectorized union-find).

Vertices lie only at corners (no collinear vertices), at the given cell edge coordinates.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from contactnet.terrain.schema import circle_segments, rect_corners_xy

_EAST, _NORTH, _WEST, _SOUTH = 0, 1, 2, 3
_MAX_HOOK_ROUNDS = 64


# ---------------------------------------------------------------------------------------------
# Outlines
# ---------------------------------------------------------------------------------------------
def circle_xy(center: Sequence[float], radius: float) -> np.ndarray:
    """Vertices (n, 2) of the circle's inscribed polygon (``circle_segments(radius)`` of them)."""
    n = circle_segments(radius)
    angles = np.arange(n) * (2.0 * math.pi / n)
    return np.asarray(center) + radius * np.column_stack([np.cos(angles), np.sin(angles)])


def star_xy(region: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """(outer tips (n, 2), inner vertices (n, 2)); inner vertex k lies between tips k and k + 1."""
    n, yaw = region["points"], region["yaw"]
    angles = yaw + np.arange(n) * (2.0 * math.pi / n)
    half = math.pi / n
    center = np.asarray(region["center"])
    tips = center + region["outer_radius"] * np.column_stack([np.cos(angles), np.sin(angles)])
    inner = center + region["inner_radius"] * np.column_stack([np.cos(angles + half), np.sin(angles + half)])
    return tips, inner


def outline_xy(region: Mapping[str, Any]) -> np.ndarray:
    """The outline (n, 2) of a region that is not a grid, counter-clockwise except for polygons (as given)."""
    shape = region["shape"]
    if shape == "rect":
        return rect_corners_xy(region["center"], region["size"], region["yaw"])
    if shape == "circle":
        return circle_xy(region["center"], region["radius"])
    if shape == "star":
        tips, inner = star_xy(region)
        return np.stack([tips, inner], axis=1).reshape(-1, 2)
    if shape == "polygon":
        return np.asarray(region["vertices"], dtype=float)
    raise ValueError(f"a {shape} region has no single outline")


def outlines_xy(regions: Sequence[Mapping[str, Any]]) -> tuple[np.ndarray, np.ndarray]:
    """The outlines of regions that are not grids, concatenated: (vertices (N, 2), vertices per region (k,)).

    Rects, the common case, are computed together; equal to ``outline_xy`` region by region.
    """
    if not regions:
        return np.zeros((0, 2)), np.zeros(0, dtype=np.int64)
    is_rect = np.array([r["shape"] == "rect" for r in regions])
    outlines: list[np.ndarray] = [np.zeros((0, 2))] * len(regions)
    if is_rect.any():
        rects = [r for r in regions if r["shape"] == "rect"]
        center = np.array([r["center"] for r in rects], dtype=float)
        half = 0.5 * np.array([r["size"] for r in rects], dtype=float)
        yaw = np.array([r["yaw"] for r in rects], dtype=float)
        local_xy = np.stack([-half, half * (1, -1), half, half * (-1, 1)], axis=1)  # (k, 4, 2), counter-clockwise
        cos, sin = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        corners = center[:, None, :] + np.stack([local_xy[..., 0] * cos - local_xy[..., 1] * sin,
                                                 local_xy[..., 0] * sin + local_xy[..., 1] * cos], axis=-1)
        for slot, xy in zip(np.flatnonzero(is_rect), corners, strict=True):
            outlines[slot] = xy
    for slot in np.flatnonzero(~is_rect):
        outlines[slot] = outline_xy(regions[slot])
    return np.concatenate(outlines), np.array([len(o) for o in outlines], dtype=np.int64)


def grid_present(region: Mapping[str, Any]) -> np.ndarray:
    """(rows, cols) bool: which cells of a normalized grid region are present (not removed)."""
    present = np.ones((region["rows"], region["cols"]), dtype=bool)
    removed = np.asarray(region["removed"], dtype=np.intp).reshape(-1, 2)
    present[removed[:, 1], removed[:, 0]] = False
    return present


def grid_cell_edges(region: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Cell edge coordinates along x (cols + 1,) and y (rows + 1,), computed one way everywhere."""
    (ox, oy), cell = region["origin"], region["cell"]
    return ox + cell * np.arange(region["cols"] + 1), oy + cell * np.arange(region["rows"] + 1)


def region_geometry(region: Mapping[str, Any],
                    transform: Callable[[np.ndarray], np.ndarray] | None = None) -> BaseGeometry:
    """Shapely geometry of one normalized region (a polygon; a grid gives the union of its present cells).

    ``transform`` maps the coordinates (an array) before the geometry is built (the terrain snaps them
    to ``UNION_GRID_SIZE_M``); None keeps them as computed.
    """
    move = transform or (lambda xy: xy)
    if region["shape"] == "grid":
        edges_x, edges_y = grid_cell_edges(region)
        return cells_geometry(grid_present(region), move(edges_x), move(edges_y))
    return Polygon(move(outline_xy(region)))


# ---------------------------------------------------------------------------------------------
# Grids: cells -> polygons
# ---------------------------------------------------------------------------------------------
def outline_corner_count(present: np.ndarray) -> int:
    """Vertices of the outline of the present cells (a corner where two cells touch diagonally counts twice)."""
    padded = np.pad(present, 1).astype(np.int8)
    sw, se, nw, ne = padded[:-1, :-1], padded[:-1, 1:], padded[1:, :-1], padded[1:, 1:]
    around = sw + se + nw + ne
    pinch = (around == 2) & (sw == ne)
    return int(np.count_nonzero((around == 1) | (around == 3)) + 2 * np.count_nonzero(pinch))


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(row, first, last) of every maximal run of True along the rows of a 2D mask, in row-major order."""
    padded = np.zeros((mask.shape[0], mask.shape[1] + 2), dtype=np.int8)
    padded[:, 1:-1] = mask
    step = np.diff(padded, axis=1)
    rows, first = np.nonzero(step == 1)
    _, end = np.nonzero(step == -1)
    return rows, first, end - 1


class _Components:
    """4-connected components of the present cells, found on the rows' runs of present cells."""

    def __init__(self, present: np.ndarray):
        rows, first, last = _runs(present)
        self.stride = present.shape[1] + 1
        self.start_key = rows * self.stride + first
        end_key = rows * self.stride + last
        # Runs of the next row that share a column with run i are a contiguous range [lo, hi).
        lo = np.searchsorted(end_key, (rows + 1) * self.stride + first, side="left")
        hi = np.searchsorted(self.start_key, (rows + 1) * self.stride + last, side="right")
        count = np.maximum(hi - lo, 0)
        src = np.repeat(np.arange(len(rows)), count)
        dst = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(int(count.sum()))
        self.root = _union_find(len(rows), src, dst)

    def of(self, row: np.ndarray, col: np.ndarray) -> np.ndarray:
        """Component id of present cells (row, col)."""
        run = np.searchsorted(self.start_key, row * self.stride + col, side="right") - 1
        return self.root[run]


def label_components(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 4-connected components of the True cells of a 2D mask, in time linear in its runs of True.

    Returns (label of every cell (rows, cols) int64: 0..k-1, -1 where the mask is False; (row, col) of one
    cell of each component (k, 2)).
    """
    labels = np.full(mask.shape, -1, dtype=np.int64)
    rows, first, last = _runs(mask)
    if not len(rows):
        return labels, np.zeros((0, 2), dtype=np.int64)
    root = _Components(mask).root
    roots, component = np.unique(root, return_inverse=True)
    lengths = last - first + 1
    start = rows * mask.shape[1] + first
    flat = np.repeat(start - np.cumsum(lengths) + lengths, lengths) + np.arange(int(lengths.sum()))
    labels.reshape(-1)[flat] = np.repeat(component, lengths)
    return labels, np.column_stack([rows[roots], first[roots]])


def _union_find(n: int, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Root (the smallest node) of every node's component, for the undirected edges src-dst.

    Rounds of hooking every root onto the smallest root next to it, each followed by full path
    compression; the number of roots drops geometrically on these row-run graphs. A plain loop
    finishes the rare input that needs more rounds.
    """
    parent = np.arange(n)
    for _ in range(_MAX_HOOK_ROUNDS):
        root_src, root_dst = parent[src], parent[dst]
        apart = root_src != root_dst
        if not apart.any():
            return parent
        low, high = np.minimum(root_src[apart], root_dst[apart]), np.maximum(root_src[apart], root_dst[apart])
        np.minimum.at(parent, high, low)
        while True:
            grand = parent[parent]
            if np.array_equal(grand, parent):
                break
            parent = grand
    links = parent.tolist()  # pragma: no cover - fallback, not reached by the tests' grids

    def find(i: int) -> int:  # pragma: no cover
        while links[i] != i:
            links[i] = links[links[i]]
            i = links[i]
        return i

    for a, b in zip(src.tolist(), dst.tolist(), strict=True):  # pragma: no cover
        ra, rb = find(a), find(b)
        if ra != rb:
            links[max(ra, rb)] = min(ra, rb)
    return np.array([find(i) for i in range(n)])  # pragma: no cover


def cells_geometry(present: np.ndarray, edges_x: np.ndarray, edges_y: np.ndarray) -> BaseGeometry:
    """The union of the present cells of a (rows, cols) raster as a valid (Multi)Polygon.

    Cell (col, row) spans ``edges_x[col]..edges_x[col + 1]`` by ``edges_y[row]..edges_y[row + 1]``.
    Linear in the number of cells; an empty Polygon when no cell is present.
    """
    rows, cols = present.shape
    if not present.any():
        return Polygon()
    components = _Components(present)
    padded = np.zeros((rows + 2, cols + 2), dtype=bool)
    padded[1:-1, 1:-1] = present
    below, above = padded[:-1, 1:-1], padded[1:, 1:-1]  # horizontal unit edges: vertex row j, cell col i
    left, right = padded[1:-1, :-1], padded[1:-1, 1:]  # vertical unit edges: vertex col i, cell row j
    sides = []  # (start i, start j, end i, end j, direction, left cell row, left cell col)
    j, a, b = _runs(above & ~below)
    sides.append((a, j, b + 1, j, np.full(len(j), _EAST), j, a))
    j, a, b = _runs(below & ~above)
    sides.append((b + 1, j, a, j, np.full(len(j), _WEST), j - 1, b))
    i, a, b = _runs((left & ~right).T)
    sides.append((i, a, i, b + 1, np.full(len(i), _NORTH), a, i - 1))
    i, a, b = _runs((right & ~left).T)
    sides.append((i, b + 1, i, a, np.full(len(i), _SOUTH), b, i))
    start_i, start_j, end_i, end_j, direction, cell_row, cell_col = (np.concatenate(v) for v in zip(*sides, strict=True))
    label = components.of(cell_row, cell_col)
    count = len(direction)

    # The side that follows each side: a left or a right turn at its end vertex (never straight on).
    vertex_stride = cols + 1
    start_key = (start_j * vertex_stride + start_i) * 4 + direction
    order = np.argsort(start_key)
    sorted_key = start_key[order]
    end_vertex = end_j * vertex_stride + end_i

    def side_starting(turn: int) -> tuple[np.ndarray, np.ndarray]:
        key = end_vertex * 4 + (direction + turn) % 4
        at = np.minimum(np.searchsorted(sorted_key, key), count - 1)
        return order[at], sorted_key[at] == key

    left_next, left_exists = side_starting(1)
    right_next, right_exists = side_starting(3)
    pinch = left_exists & right_exists
    turn_left = left_exists.copy()
    if pinch.any():  # the two present cells at a pinch: SW & NE, or SE & NW
        pi, pj = end_i[pinch], end_j[pinch]
        south_west = padded[pj, pi]
        first = components.of(pj - 1, np.where(south_west, pi - 1, pi))
        second = components.of(pj, np.where(south_west, pi, pi - 1))
        turn_left[pinch] = first != second
    following = np.where(turn_left, left_next, right_next).tolist()

    # Rings: the cycles of `following`.
    seen = bytearray(count)
    sequence: list[int] = []
    ring_length: list[int] = []
    for begin in range(count):
        if seen[begin]:
            continue
        side, length = begin, 0
        while not seen[side]:
            seen[side] = 1
            sequence.append(side)
            side = following[side]
            length += 1
        ring_length.append(length)
    ring_sides = np.asarray(sequence)
    lengths = np.asarray(ring_length)
    first_side = np.cumsum(lengths) - lengths
    vertex_i, vertex_j = start_i[ring_sides], start_j[ring_sides]
    successor = np.arange(len(ring_sides)) + 1
    successor[first_side + lengths - 1] = first_side
    doubled_area = np.add.reduceat(vertex_i * vertex_j[successor] - vertex_i[successor] * vertex_j, first_side)
    ring_label = label[ring_sides[first_side]]
    is_hole = doubled_area < 0
    if np.count_nonzero(~is_hole) != len(np.unique(ring_label)):  # pragma: no cover - defensive
        raise AssertionError("grid outline: not exactly one shell per component")

    # Closed rings, grouped per component with the shell first.
    ring_order = np.lexsort((is_hole, ring_label))
    closed = lengths[ring_order] + 1
    offset = np.repeat(np.cumsum(closed) - closed, closed)
    within = np.arange(int(closed.sum())) - offset
    within[within == np.repeat(closed - 1, closed)] = 0
    picked = ring_sides[np.repeat(first_side[ring_order], closed) + within]
    coords_xy = np.column_stack([np.asarray(edges_x)[start_i[picked]], np.asarray(edges_y)[start_j[picked]]])
    rings = shapely.linearrings(coords_xy, indices=np.repeat(np.arange(len(closed)), closed))
    polygon_index = np.unique(ring_label[ring_order], return_inverse=True)[1]
    polygons = shapely.polygons(rings, indices=polygon_index)
    return polygons[0] if len(polygons) == 1 else shapely.multipolygons(polygons)
