"""Fast exact point location on a terrain: a raster classified once, shapely asked only next to edges.

:class:`PointLocator` answers "does this (multi)polygon cover the point?" (``Terrain.is_safe``, and
``Terrain.height_at`` on a terrain whose tops are all at one height); :class:`HeightLocator` answers
"what is the highest top of the regions covering the point?" (``Terrain.height_at`` with several
heights). Both lay a square raster over the geometry: a cell whose box, padded by ``pad_m``, may
touch an outline is a BOUNDARY cell, where the point itself is asked of shapely; every other cell
lies entirely inside or entirely outside each region, so one point of it decides for all of it.
The answers are therefore exact with respect to shapely.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from contactnet.terrain.regions import label_components

RASTER_TARGET_CELLS = 1 << 20  # capped by max_side=1000 per axis: 1.5 mm cells on the paper's field
_OUTSIDE, _INSIDE, _BOUNDARY = 0, 1, 2
_intersects_xy = getattr(shapely.lib, "intersects_xy", shapely.intersects_xy)
"""shapely's ufunc without its Python wrapper (saves ~2 us per call); same semantics, uses preparation."""
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
class PointLocator:
    """Exact point-in-region test: a raster of cells classified once, shapely for boundary cells.

    Cell (col, row) covers ``[col0 + col, col0 + col + 1) * cell_m`` along x (likewise y, from
    ``row0``); a point's cell is ``floor(xy / cell_m - (col0, row0))``. A cell is BOUNDARY when its
    box padded by ``pad_m`` may touch the region's boundary; every other cell is entirely inside or
    entirely outside, decided by its centre, and so is each 4-connected component of them (the build asks
    shapely about one centre per component, as :class:`HeightLocator`). The padding keeps the answer exact when a point's
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


@dataclass(frozen=True)
class HeightLocator:
    """Exact highest top under points: ``max(tops_z[i] for the regions i covering the point)``, NaN for none.

    The raster of :class:`PointLocator`, with the outlines of every region marked: the cells that are
    not BOUNDARY form 4-connected components, and no outline passes through a component (the segment
    between two neighbouring centres stays inside the two cells' boxes), so every point of a component
    is covered by the same regions. One point per component is asked of shapely when the raster is
    built; a query then costs a cell lookup, and a shapely question (an STRtree of the regions'
    bounding boxes, then the point in the few candidates) only for points in BOUNDARY cells.
    """

    geometries: np.ndarray  # (R,) prepared polygons, the regions
    tops_z: np.ndarray  # (R,) float
    tree: shapely.STRtree
    inv_cell: float
    first_cell: np.ndarray  # (2,) float
    clamp_hi: float
    strides: np.ndarray  # (2,) intp
    codes: np.ndarray  # (n * n,) int32: 0 no top, k + 1 the k-th of the distinct tops, -1 BOUNDARY
    code_z: np.ndarray  # (distinct tops + 1,) float: NaN, then the distinct tops ascending
    upper_codes: np.ndarray  # (n * n,) int32: ``codes`` with each BOUNDARY cell's highest top touching it

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
        codes[: frame.n_rows, : frame.n_cols] = np.where(boundary, -1, component_code[labels])
        # Upper bounds: each BOUNDARY cell gets the highest top of the regions its padded box touches.
        rows, cols = np.nonzero(boundary)
        x0 = (frame.first[0] + cols) * frame.cell_m - pad_m
        y0 = (frame.first[1] + rows) * frame.cell_m - pad_m
        width = frame.cell_m + 2.0 * pad_m
        cell, region = tree.query(shapely.box(x0, y0, x0 + width, y0 + width), predicate="intersects")
        highest = np.full(len(rows), -np.inf)
        np.maximum.at(highest, cell, tops_z[region])
        upper = codes.copy()
        upper[rows, cols] = np.where(np.isfinite(highest), np.searchsorted(code_z[1:], highest) + 1, 0)
        return cls(geometries, tops_z, tree, frame.inv_cell, frame.first.astype(float), side - 0.5,
                   np.array([1, side], dtype=np.intp), codes.ravel(), code_z, upper.ravel())

    def heights(self, points_xy_world: np.ndarray, outside: float = np.nan) -> np.ndarray:
        """Float (N,): the highest top covering each point of (N, 2) (boundaries count), ``outside`` for none."""
        cell = points_xy_world * self.inv_cell
        cell -= self.first_cell
        np.fmax(cell, 0.0, out=cell)  # also maps NaN onto the (no top) border
        np.fmin(cell, self.clamp_hi, out=cell)
        code = self.codes.take(cell.astype(np.intp) @ self.strides)
        on_boundary = (code < 0).nonzero()[0]
        code[on_boundary] = 0
        result = self.code_z.take(code)
        if on_boundary.size:
            result[on_boundary] = _highest_top(self.tree, self.geometries, self.tops_z,
                                               points_xy_world.take(on_boundary, axis=0))
        if not math.isnan(outside):
            result[np.isnan(result)] = outside
        return result


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
