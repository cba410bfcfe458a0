"""Fast exact point location on a terrain: a raster classified once, shapely asked only next to edges.

`PointLocator` answers "does this (multi)polygon cover the point?" (``Terrain.is_safe``, and
``Terrain.height_at`` on a terrain whose tops are all at one height); `HeightLocator` answers
"what is the highest top of the regions covering the point?" (``Terrain.height_at`` with several
heights). Both lay a square raster over the geometry: a cell whose box, padded by ``pad_m``, may
touch an outline is a BOUNDARY cell, where the point itself is asked of shapely; every other cell
lies entirely inside or entirely outside each region, so one point of it decides for all of it.
The answers are therefore exact with respect to shapely.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from contactnet.terrain.crossings import (
    CELL_BOUNDARY,
    CELL_INSIDE,
    CELL_OUTSIDE,
    INSIDE,
    ON_OUTLINE,
    near_outline,
    running_reach,
)
from contactnet.terrain.regions import label_components

RASTER_TARGET_CELLS = 1 << 20  # capped by max_side=1000 per axis: 1.5 mm cells on the paper's field
_OUTSIDE, _INSIDE, _BOUNDARY = CELL_OUTSIDE, CELL_INSIDE, CELL_BOUNDARY
_intersects_xy = getattr(shapely.lib, "intersects_xy", shapely.intersects_xy)
"""shapely's ufunc without its Python wrapper (saves ~2 us per call); same semantics, uses preparation."""
_FEW_BOUNDARY_POINTS = 8
"""``HeightLocator.heights``: up to this many points next to outlines are asked of their cells' regions one by one
(an STRtree query costs a fixed ~50 us)."""
_SMALL_QUERY = 16
"""Batches up to this size go straight to shapely (a raster lookup costs a fixed ~10 numpy calls; shapely's
cost per point grows with the number of holes, so larger batches, e.g. the trot's 36 cells, use the raster)."""


@dataclass(frozen=True)
class _Frame:
    """Where a raster lies: cell (col, row) covers ``[col0 + col, col0 + col + 1) * cell_m`` along x
    (likewise y from ``row0``), ``n_cols`` x ``n_rows`` cells, two free cells beyond the bounds on every side."""

    cell_m: float
    inv_cell: float
    first: np.ndarray  # (2,) int: (col0, row0)
    n_cols: int
    n_rows: int

    @classmethod
    def around(cls, bounds: tuple[float, float, float, float], target_cells: int, max_side: int) -> _Frame:
        minx, miny, maxx, maxy = bounds
        width, height = max(maxx - minx, 1e-6), max(maxy - miny, 1e-6)
        cell_m = max(math.sqrt(width * height / target_cells), width / max_side, height / max_side)
        inv_cell = 1.0 / cell_m
        col0, row0 = math.floor(minx * inv_cell) - 2, math.floor(miny * inv_cell) - 2
        n_cols = math.floor(maxx * inv_cell) + 3 - col0
        n_rows = math.floor(maxy * inv_cell) + 3 - row0
        return cls(cell_m, inv_cell, np.array([col0, row0]), n_cols, n_rows)

    def boundary(self, rings: np.ndarray, pad_m: float) -> np.ndarray:
        """(n_rows, n_cols) bool: the cells whose box padded by ``pad_m`` may touch one of the rings."""
        boundary = np.zeros((self.n_rows, self.n_cols), dtype=bool)
        # Boundary segments no longer than a cell: each one's padded bounding box spans <= 3x3 cells
        # and contains the segment, so marking those cells over-approximates the boundary cells.
        rings = shapely.segmentize(rings, self.cell_m * 0.999)
        ring_xy, ring_index = shapely.get_coordinates(rings, return_index=True)
        same_ring = ring_index[1:] == ring_index[:-1]
        start_xy, end_xy = ring_xy[:-1][same_ring], ring_xy[1:][same_ring]
        lo = np.floor((np.minimum(start_xy, end_xy) - pad_m) * self.inv_cell).astype(np.intp) - self.first
        hi = np.floor((np.maximum(start_xy, end_xy) + pad_m) * self.inv_cell).astype(np.intp) - self.first
        if np.any(hi - lo > 2) or lo.min(initial=1) < 1 or np.any(hi >= (self.n_cols - 1, self.n_rows - 1)):
            raise AssertionError("raster: a boundary segment is longer than a cell or too close to the edge")
        for d_col in range(3):
            for d_row in range(3):
                use = (lo[:, 0] + d_col <= hi[:, 0]) & (lo[:, 1] + d_row <= hi[:, 1])
                boundary[lo[use, 1] + d_row, lo[use, 0] + d_col] = True
        return boundary

    def centres(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World x, y of the centres of cells (rows, cols)."""
        return (self.first[0] + cols + 0.5) * self.cell_m, (self.first[1] + rows + 0.5) * self.cell_m


@dataclass(frozen=True)
class OutlineRows:
    """A region's outline for an exact point test in compiled code (``contactnet.terrain.crossings.near_outline``):
    every segment of its rings (``segments``) listed by the `PointLocator` raster's rows it may reach
    (``entries[row_first[r]:row_first[r + 1]]`` for row r, one row of padding each side, so a point whose computed row
    is off by one still finds them), each row's sorted by the segment's lowest x. An entry (``crossings.X0`` ...
    ``REACH_X``) is the segment (x0, y0, x1, y1), its lowest x, and the highest x of it and of the row's entries
    before it: a point's test looks only at the entries that may reach the stretch of its ray, found by bisection."""

    segments: np.ndarray  # (S, 4) float64: x0, y0, x1, y1, every segment once
    entries: np.ndarray  # (K, 6) float64
    row_first: np.ndarray  # (side + 1,) int64

    @classmethod
    def of(cls, geometry: BaseGeometry, raster: np.ndarray) -> OutlineRows:
        """``raster``: `PointLocator.raster` (inv_cell, col0, row0, clamp_hi, side)."""
        side = 0 if geometry.is_empty else int(raster[4])
        if side == 0:
            return cls(np.zeros((0, 4)), np.zeros((0, 6)), np.zeros(1, dtype=np.int64))
        xy, ring = shapely.get_coordinates(shapely.get_rings(shapely.get_parts(geometry)), return_index=True)
        same = ring[1:] == ring[:-1]
        segments = np.column_stack([xy[:-1][same], xy[1:][same]]).astype(np.float64)
        low = np.minimum(segments[:, 1], segments[:, 3]) * raster[0] - raster[2]
        high = np.maximum(segments[:, 1], segments[:, 3]) * raster[0] - raster[2]
        first = np.clip(np.floor(low).astype(np.int64) - 1, 0, side - 1)
        last = np.clip(np.floor(high).astype(np.int64) + 1, 0, side - 1)
        counts = last - first + 1
        index = np.repeat(np.arange(len(segments), dtype=np.int64), counts)
        rows = np.repeat(first, counts) + (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts))
        low_x = np.minimum(segments[:, 0], segments[:, 2])
        order = np.lexsort((low_x[index], rows))  # by row, then by lowest x
        row_first = np.zeros(side + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows, minlength=side), out=row_first[1:])
        index = index[order]
        reach = running_reach(row_first, np.maximum(segments[index, 0], segments[index, 2]))
        entries = np.ascontiguousarray(np.column_stack([segments[index], low_x[index], reach]))
        return cls(segments, entries, row_first)


@dataclass(frozen=True)
class PointLocator:
    """Exact point-in-region test: a raster of cells classified once, shapely for boundary cells.

    Cell (col, row) covers ``[col0 + col, col0 + col + 1) * cell_m`` along x (likewise y, from
    ``row0``); a point's cell is ``floor(xy / cell_m - (col0, row0))``. A cell is BOUNDARY when its
    box padded by ``pad_m`` may touch the region's boundary; every other cell is entirely inside or
    entirely outside, decided by its centre, and so is each 4-connected component of them (the build asks
    shapely about one centre per component, as `HeightLocator`). The padding keeps the answer exact when a point's
    computed cell is off by one through floating-point rounding. The raster is stored as an
    ``n x n`` square (unused rows/cols OUTSIDE) so one scalar clamp to the outermost cells, which
    are always OUTSIDE, handles points off the raster and non-finite points.
    """

    geometry: BaseGeometry
    inv_cell: float
    first_cell: np.ndarray  # (2,) float: (col0, row0), whole numbers
    clamp_hi: float  # n - 0.5
    strides: np.ndarray  # (2,) intp: (1, n)
    codes: np.ndarray  # (n * n,) uint8, row-major; empty for an empty region
    # The same as Python objects, for scalar lookups (``covers_xy``).
    code_bytes: bytes = field(init=False, repr=False, compare=False)
    #: ``covers_xy`` as a function with the raster's constants bound (no attribute lookups: the planner's hot path)
    covers_xy: Callable[[float, float], bool] = field(init=False, repr=False, compare=False)
    #: (inv_cell, col0, row0, clamp_hi, n) as float64, for compiled lookups (``contactnet.planning.safe_walk``)
    raster: np.ndarray = field(init=False, repr=False, compare=False)
    #: The outline for compiled lookups in BOUNDARY cells (`OutlineRows`): its segments listed by raster row.
    outline: OutlineRows = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "code_bytes", self.codes.tobytes())
        object.__setattr__(self, "raster", np.array([self.inv_cell, self.first_cell[0], self.first_cell[1],
                                                     self.clamp_hi, self.strides[1]], dtype=np.float64))
        object.__setattr__(self, "outline", OutlineRows.of(self.geometry, self.raster))
        object.__setattr__(self, "covers_xy", _scalar_covers(self))

    @classmethod
    def build(cls, geometry: BaseGeometry, target_cells: int = RASTER_TARGET_CELLS, max_side: int = 1000,
              pad_m: float = 1e-9) -> PointLocator:
        shapely.prepare(geometry)
        if geometry.is_empty:
            return cls(geometry, 1.0, np.zeros(2), 0.0, np.zeros(2, dtype=np.intp), np.zeros(0, dtype=np.uint8))
        frame = _Frame.around(geometry.bounds, target_cells, max_side)
        boundary = frame.boundary(shapely.get_rings(shapely.get_parts(geometry)), pad_m)
        n_rows, n_cols = boundary.shape
        side = max(n_cols, n_rows)
        codes = np.full((side, side), _OUTSIDE, dtype=np.uint8)
        # No outline passes through a 4-connected component of non-BOUNDARY cells (see HeightLocator): the
        # centre of one cell per component decides for all of it.
        labels, representative = label_components(~boundary)
        centre_x, centre_y = frame.centres(*representative.T)
        component_code = np.where(shapely.contains_xy(geometry, centre_x, centre_y), _INSIDE, _OUTSIDE)
        codes[:n_rows, :n_cols] = np.where(boundary, _BOUNDARY, component_code.astype(np.uint8)[labels])
        return cls(geometry, frame.inv_cell, frame.first.astype(float), side - 0.5,
                   np.array([1, side], dtype=np.intp), codes.ravel())

    def covers(self, points_xy_world: np.ndarray) -> np.ndarray:
        """Boolean (N,): does the region cover each point of (N, 2) (boundary counts as covered)."""
        if self.codes.size == 0:
            return np.zeros(len(points_xy_world), dtype=bool)
        if len(points_xy_world) <= _SMALL_QUERY:
            return _intersects_xy(self.geometry, points_xy_world[:, 0], points_xy_world[:, 1])
        cell = points_xy_world * self.inv_cell
        cell -= self.first_cell
        np.fmax(cell, 0.0, out=cell)  # also maps NaN onto the (outside) border
        np.fmin(cell, self.clamp_hi, out=cell)
        code = self.codes.take(cell.astype(np.intp) @ self.strides)  # truncation == floor: cell >= 0
        on_boundary = (code == _BOUNDARY).nonzero()[0]
        result = code.view(np.bool_)  # 0 / 1 are False / True; the BOUNDARY entries are replaced below
        if on_boundary.size:
            points = points_xy_world.take(on_boundary, axis=0)
            result[on_boundary] = _intersects_xy(self.geometry, points[:, 0], points[:, 1])
        return result



def _scalar_covers(locator: PointLocator) -> Callable[[float, float], bool]:
    """``PointLocator.covers_xy``: ``covers`` of one point given as two Python floats, without numpy arrays (a
    fraction of a microsecond; about a microsecond in a BOUNDARY cell, where the outline's segments in the point's
    raster row that may reach the point's stretch of the row decide, ``contactnet.terrain.crossings.near_outline``,
    and shapely only within ``NEAR_OUTLINE_M`` of the outline): the planner's walk down a ranking, one candidate at
    a time. The same cell as ``covers``, so the same answer."""
    code_bytes, geometry = locator.code_bytes, locator.geometry
    raster, codes = locator.raster, locator.codes
    entries, row_first = locator.outline.entries, locator.outline.row_first
    if not code_bytes:
        return lambda x, y: False
    inv_cell, clamp_hi = float(locator.inv_cell), float(locator.clamp_hi)
    first_col, first_row = float(locator.first_cell[0]), float(locator.first_cell[1])
    side = int(locator.strides[1])

    def covers_xy(x: float, y: float) -> bool:
        col = x * inv_cell - first_col
        row = y * inv_cell - first_row
        if not col > 0.0:  # also NaN, as np.fmax does
            col = 0.0
        elif col > clamp_hi:
            col = clamp_hi
        if not row > 0.0:
            row = 0.0
        elif row > clamp_hi:
            row = clamp_hi
        code = code_bytes[int(col) + int(row) * side]
        if code == _BOUNDARY:
            state = near_outline(x, y, int(col), int(row), raster, codes, entries, row_first)
            return bool(_intersects_xy(geometry, x, y)) if state == ON_OUTLINE else state == INSIDE
        return code == _INSIDE

    return covers_xy


@dataclass(frozen=True)
class HeightLocator:
    """Exact highest top under points: ``max(tops_z[i] for the regions i covering the point)``, NaN for none.

    The raster of `PointLocator`, with the outlines of every region marked: the cells that are
    not BOUNDARY form 4-connected components, and no outline passes through a component (the segment
    between two neighbouring centres stays inside the two cells' boxes), so every point of a component
    is covered by the same regions. One point per component is asked of shapely when the raster is
    built; a query then costs a cell lookup, and a shapely question only for points in BOUNDARY cells:
    for a few, each asked of the regions its cell's padded box touches (listed when the raster is built),
    for many, an STRtree of the regions' bounding boxes, then the point in the few candidates.
    """

    geometries: np.ndarray  # (R,) prepared polygons, the regions
    tops_z: np.ndarray  # (R,) float
    tree: shapely.STRtree
    inv_cell: float
    first_cell: np.ndarray  # (2,) float
    clamp_hi: float
    strides: np.ndarray  # (2,) intp
    codes: np.ndarray  # (n * n,) int32: 0 no top, k + 1 the k-th of the distinct tops, -2 - b the b-th BOUNDARY cell
    code_z: np.ndarray  # (distinct tops + 1,) float: NaN, then the distinct tops ascending
    upper_codes: np.ndarray  # (n * n,) int32: ``codes`` with each BOUNDARY cell's highest top touching it
    starts: np.ndarray  # (B + 1,) int32: the b-th BOUNDARY cell's regions are candidates[starts[b]:starts[b + 1]]
    candidates: np.ndarray  # int32
    _code_z_below: np.ndarray = field(init=False, repr=False, compare=False)  # code_z, -inf for no top

    def __post_init__(self) -> None:
        object.__setattr__(self, "_code_z_below", np.concatenate([[-math.inf], self.code_z[1:]]))

    @classmethod
    def build(cls, geometries: np.ndarray, tops_z: np.ndarray, target_cells: int = RASTER_TARGET_CELLS,
              max_side: int = 1000, pad_m: float = 1e-9) -> HeightLocator:
        geometries = np.asarray(geometries, dtype=object)
        keep = ~shapely.is_empty(geometries)
        geometries, tops_z = geometries[keep], np.asarray(tops_z, dtype=float)[keep]
        shapely.prepare(geometries)
        tree = shapely.STRtree(geometries)
        code_z = np.concatenate([[np.nan], np.unique(tops_z)])
        frame = _Frame.around(tuple(shapely.total_bounds(geometries)), target_cells, max_side)
        boundary = frame.boundary(shapely.get_rings(shapely.get_parts(geometries)), pad_m)
        labels, representative = label_components(~boundary)
        top = _highest_top(tree, geometries, tops_z, np.column_stack(frame.centres(*representative.T)))
        component_code = np.where(np.isnan(top), 0, np.searchsorted(code_z[1:], top) + 1).astype(np.int32)
        side = max(frame.n_cols, frame.n_rows)
        codes = np.zeros((side, side), dtype=np.int32)
        codes[: frame.n_rows, : frame.n_cols] = component_code[labels]
        # Each BOUNDARY cell: the regions its padded box touches, and the highest of their tops (upper bounds).
        rows, cols = np.nonzero(boundary)
        codes[rows, cols] = -2 - np.arange(len(rows), dtype=np.int32)
        x0 = (frame.first[0] + cols) * frame.cell_m - pad_m
        y0 = (frame.first[1] + rows) * frame.cell_m - pad_m
        width = frame.cell_m + 2.0 * pad_m
        cell, region = tree.query(shapely.box(x0, y0, x0 + width, y0 + width), predicate="intersects")
        highest = np.full(len(rows), -np.inf)
        np.maximum.at(highest, cell, tops_z[region])
        upper = codes.copy()
        upper[rows, cols] = np.where(np.isfinite(highest), np.searchsorted(code_z[1:], highest) + 1, 0)
        order = np.lexsort((region, cell))
        starts = np.searchsorted(cell[order], np.arange(len(rows) + 1)).astype(np.int32)
        return cls(geometries, tops_z, tree, frame.inv_cell, frame.first.astype(float), side - 0.5,
                   np.array([1, side], dtype=np.intp), codes.ravel(), code_z, upper.ravel(), starts,
                   region[order].astype(np.int32))

    def heights(self, points_xy_world: np.ndarray, outside: float = np.nan) -> np.ndarray:
        """Float (N,): the highest top covering each point of (N, 2) (boundaries count), ``outside`` for none."""
        cell = points_xy_world * self.inv_cell
        cell -= self.first_cell
        np.fmax(cell, 0.0, out=cell)  # also maps NaN onto the (no top) border
        np.fmin(cell, self.clamp_hi, out=cell)
        code = self.codes.take(cell.astype(np.intp) @ self.strides)
        on_boundary = (code < 0).nonzero()[0]
        boundary_cells = code[on_boundary]
        code[on_boundary] = 0
        result = self.code_z.take(code)
        if on_boundary.size > _FEW_BOUNDARY_POINTS:
            result[on_boundary] = _highest_top(self.tree, self.geometries, self.tops_z,
                                               points_xy_world.take(on_boundary, axis=0))
        elif on_boundary.size:
            for i, cell_code, (x, y) in zip(on_boundary.tolist(), boundary_cells.tolist(),
                                            points_xy_world[on_boundary].tolist(), strict=True):
                result[i] = self._highest_top_xy(-2 - cell_code, x, y)
        if not math.isnan(outside):
            result[np.isnan(result)] = outside
        return result

    def height_xy(self, x: float, y: float) -> float:
        """``heights`` of one point given as two Python floats (NaN for no top): the same answer."""
        col = x * self.inv_cell - self.first_cell[0]
        row = y * self.inv_cell - self.first_cell[1]
        if not col > 0.0:  # also NaN, as np.fmax does
            col = 0.0
        elif col > self.clamp_hi:
            col = self.clamp_hi
        if not row > 0.0:
            row = 0.0
        elif row > self.clamp_hi:
            row = self.clamp_hi
        code = int(self.codes[int(col) + int(row) * int(self.strides[1])])
        return float(self.code_z[code]) if code >= 0 else self._highest_top_xy(-2 - code, x, y)

    def _highest_top_xy(self, boundary_cell: int, x: float, y: float) -> float:
        """The highest top of the regions covering (x, y), in the ``boundary_cell``-th BOUNDARY cell; NaN for none."""
        candidates = self.candidates[self.starts[boundary_cell]: self.starts[boundary_cell + 1]]
        hit = _intersects_xy(self.geometries[candidates], x, y)
        return float(self.tops_z[candidates[hit]].max()) if hit.any() else math.nan


    def upper_heights(self, points_xy_world: np.ndarray, outside: float = np.nan) -> np.ndarray:
        """Float (N,): an upper bound of ``heights``, from the raster alone (no shapely): exact away from
        outlines; next to one (a BOUNDARY cell, ``1 / inv_cell`` wide) the highest top touching the cell."""
        cell = points_xy_world * self.inv_cell
        cell -= self.first_cell
        np.fmax(cell, 0.0, out=cell)
        np.fmin(cell, self.clamp_hi, out=cell)
        result = self.code_z.take(self.upper_codes.take(cell.astype(np.intp) @ self.strides))
        if not math.isnan(outside):
            result[np.isnan(result)] = outside
        return result

    def upper_heights_of(self, points_xy_world: np.ndarray, outside: float = -math.inf) -> np.ndarray:
        """``upper_heights`` of points given coordinate first, (2, ...) -> (...): numpy's loops run along the
        long axes (the checks of ``contactnet.planning.footholds`` look up hundreds of points at once)."""
        shape = points_xy_world.shape[1:]
        cell = points_xy_world * self.inv_cell
        cell -= self.first_cell.reshape((2,) + (1,) * len(shape))
        np.fmax(cell, 0.0, out=cell)
        np.fmin(cell, self.clamp_hi, out=cell)
        index = cell.astype(np.intp)
        if math.isnan(outside):
            code_z = self.code_z
        elif outside == -math.inf:
            code_z = self._code_z_below
        else:
            code_z = np.concatenate([[outside], self.code_z[1:]])
        return code_z.take(self.upper_codes.take(index[0] + index[1] * int(self.strides[1])))


@dataclass(frozen=True)
class CoverLocator:
    """Which of some polygons covers a point, the one with the highest top where several do: its index, -1 for
    none (``contactnet.terrain.top_parts.TopParts.part_at``), exactly, from a raster.

    The raster of `HeightLocator` (whose argument this borrows: the non-BOUNDARY cells form components
    no outline crosses, each answered once by ``exact`` when the raster is built), stored as a rectangle, with
    each BOUNDARY cell's candidates: the polygons its padded box touches. A point in a BOUNDARY cell is asked of
    those polygons alone (``shapely.intersects_xy``), or of ``exact`` (the STRtree) when two of them have the
    same top. ``index_xy`` answers one point given as two Python floats without numpy arrays."""

    polygons: np.ndarray  # (P,) prepared polygons
    tops_z: np.ndarray  # (P,) float
    exact: Callable[[np.ndarray], np.ndarray]  # (N, 2) -> (N,) int, the same answer from the polygons themselves
    inv_cell: float
    first_cell: np.ndarray  # (2,) float: (col0, row0)
    clamp_hi: np.ndarray  # (2,) float: (n_cols - 0.5, n_rows - 0.5)
    n_cols: int
    codes: np.ndarray  # (n_rows * n_cols,) int32: the index, -1 for none, -2 - k for the k-th BOUNDARY cell
    starts: np.ndarray  # (K + 1,) int32: the k-th BOUNDARY cell's candidates are candidates[starts[k]:starts[k + 1]]
    candidates: np.ndarray  # int32
    # The same as Python objects, for scalar lookups (``index_xy``).
    _views: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_views", (
            float(self.first_cell[0]), float(self.first_cell[1]), float(self.clamp_hi[0]), float(self.clamp_hi[1]),
            memoryview(self.codes), memoryview(self.starts), memoryview(self.candidates), list(self.polygons),
            self.tops_z.tolist()))

    @classmethod
    def build(cls, polygons: np.ndarray, tops_z: np.ndarray, exact: Callable[[np.ndarray], np.ndarray],
              target_cells: int = RASTER_TARGET_CELLS, max_side: int = 4000, pad_m: float = 1e-9) -> CoverLocator:
        """``polygons`` (P,) with their tops (P,) and the exact answer ``exact``; P >= 1."""
        shapely.prepare(polygons)
        frame = _Frame.around(tuple(shapely.total_bounds(polygons)), target_cells, max_side)
        boundary = frame.boundary(shapely.get_rings(polygons), pad_m)
        labels, representative = label_components(~boundary)
        component = np.asarray(exact(np.column_stack(frame.centres(*representative.T))), dtype=np.int32)
        codes = np.where(boundary, 0, component[labels]).astype(np.int32)
        rows, cols = np.nonzero(boundary)
        codes[rows, cols] = -2 - np.arange(len(rows), dtype=np.int32)
        x0 = (frame.first[0] + cols) * frame.cell_m - pad_m
        y0 = (frame.first[1] + rows) * frame.cell_m - pad_m
        width = frame.cell_m + 2.0 * pad_m
        cell, polygon = shapely.STRtree(polygons).query(shapely.box(x0, y0, x0 + width, y0 + width),
                                                        predicate="intersects")
        order = np.lexsort((polygon, cell))
        starts = np.searchsorted(cell[order], np.arange(len(rows) + 1)).astype(np.int32)
        return cls(polygons, np.asarray(tops_z, dtype=float), exact, frame.inv_cell, frame.first.astype(float),
                   np.array([frame.n_cols - 0.5, frame.n_rows - 0.5]), frame.n_cols, codes.ravel(), starts,
                   polygon[order].astype(np.int32))

    def indices(self, points_xy_world: np.ndarray) -> np.ndarray:
        """(N,) intp: the answer for each point of (N, 2)."""
        return self.indices_of(np.ascontiguousarray(points_xy_world.T))

    def indices_of(self, points_xy_world: np.ndarray) -> np.ndarray:
        """(N,) intp: the answer for each point given coordinate first, (2, N) (numpy's loops run along N)."""
        cell = points_xy_world * self.inv_cell
        cell -= self.first_cell[:, None]
        np.fmax(cell, 0.0, out=cell)  # also maps NaN onto the border, which covers nothing
        np.fmin(cell, self.clamp_hi[:, None], out=cell)
        index = cell.astype(np.intp)
        result = self.codes.take(index[0] + index[1] * self.n_cols).astype(np.intp)
        on_boundary = (result <= -2).nonzero()[0]
        if on_boundary.size > _FEW_BOUNDARY_POINTS:
            result[on_boundary] = self.exact(points_xy_world[:, on_boundary].T)
        else:
            for i, x, y in zip(on_boundary.tolist(), *points_xy_world[:, on_boundary].tolist(), strict=True):
                result[i] = self.index_xy(x, y)
        return result

    def index_xy(self, x: float, y: float) -> int:
        """The answer for one point given as two Python floats (the same arithmetic as ``indices``)."""
        first_col, first_row, hi_col, hi_row, codes, starts, candidates, polygons, tops = self._views
        col = x * self.inv_cell - first_col
        row = y * self.inv_cell - first_row
        if not col > 0.0:  # also NaN, as np.fmax does
            col = 0.0
        elif col > hi_col:
            col = hi_col
        if not row > 0.0:
            row = 0.0
        elif row > hi_row:
            row = hi_row
        code = codes[int(col) + int(row) * self.n_cols]
        if code >= -1:
            return code
        best, best_z, tie = -1, -math.inf, False
        for j in range(starts[-2 - code], starts[-1 - code]):
            polygon = candidates[j]
            if _intersects_xy(polygons[polygon], x, y):
                if tops[polygon] > best_z:
                    best, best_z, tie = polygon, tops[polygon], False
                elif tops[polygon] == best_z:
                    tie = True
        return int(self.exact(np.array([[x, y]]))[0]) if tie else best


def _highest_top(tree: shapely.STRtree, geometries: np.ndarray, tops_z: np.ndarray,
                 points_xy: np.ndarray) -> np.ndarray:
    """Float (N,): the highest ``tops_z`` of the (prepared) geometries covering each finite point, NaN for none."""
    result = np.full(len(points_xy), -np.inf)
    finite = np.isfinite(points_xy).all(axis=1).nonzero()[0]
    if finite.size:
        point, candidate = tree.query(shapely.points(points_xy[finite]))
        x, y = points_xy[finite[point], 0], points_xy[finite[point], 1]
        hit = _intersects_xy(geometries[candidate], x, y)
        np.maximum.at(result, finite[point[hit]], tops_z[candidate[hit]])
    result[result == -np.inf] = np.nan
    return result
