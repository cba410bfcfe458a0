"""Terrain geometry: the validated :class:`Terrain`, its steppable union and fast exact point queries on it.

A terrain is the union of 2D *regions* (rectangles, circles, stars, polygons and grids of square
cells; their shapes are in ``contactnet.terrain.regions``, their union, built within the complexity
budget, in ``contactnet.terrain.union``) whose tops are steppable; everything else is a hole with
nothing to stand on. Every region's
top is at the terrain's ``surface_z`` today; ``surface_z`` is also the nominal ground level, the
height to measure from where there is no top (:meth:`Terrain.ground_z`).

The hot path is :meth:`Terrain.is_safe`, vectorized over many candidate footholds;
:meth:`Terrain.height_at` uses the same machinery. Both answer from a raster built once per margin
(cells fully inside / fully outside / on the boundary) and ask shapely only for points in boundary
cells, so they are exact with respect to shapely. The mesh and the top view live in
``contactnet.terrain.mesh`` and ``contactnet.terrain.render``; :class:`Terrain` delegates to them.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from contactnet.terrain import render as _render
from contactnet.terrain.mesh import extruded_mesh
from contactnet.terrain.regions import region_geometry
from contactnet.terrain.schema import (
    CIRCLE_MAX_ERROR_M,
    CIRCLE_MIN_SEGMENTS,
    MAX_FILE_BYTES,
    check_top_level,
    field_error,
    finite_float,
    freeze_region,
    loads_terrain_json,
    parse_fields,
    read_terrain_json,
    show,
    thaw,
    write_terrain_json,
)
from contactnet.terrain.union import UNION_GRID_SIZE_M, steppable_union

__all__ = ["CIRCLE_MAX_ERROR_M", "CIRCLE_MIN_SEGMENTS", "UNION_GRID_SIZE_M", "Terrain", "region_geometry",
           "validate_terrain_bytes"]

if TYPE_CHECKING:
    import trimesh
    from matplotlib.axes import Axes

_RASTER_TARGET_CELLS = 1 << 20  # capped by max_side=1000 per axis: 1.5 mm cells on the paper's field
_SAFE_CACHE_MAX = 16


# ---------------------------------------------------------------------------------------------
# Fast exact point location
# ---------------------------------------------------------------------------------------------
_OUTSIDE, _INSIDE, _BOUNDARY = 0, 1, 2
_intersects_xy = getattr(shapely.lib, "intersects_xy", shapely.intersects_xy)
"""shapely's ufunc without its Python wrapper (saves ~2 us per call); same semantics, uses preparation."""
_SMALL_QUERY = 16
"""Batches up to this size go straight to shapely (a raster lookup costs a fixed ~10 numpy calls; shapely's
cost per point grows with the number of holes, so larger batches, e.g. the trot's 36 cells, use the raster)."""


@dataclass(frozen=True)
class _PointLocator:
    """Exact point-in-region test: a raster of cells classified once, shapely for boundary cells.

    Cell (col, row) covers ``[col0 + col, col0 + col + 1) * cell_m`` along x (likewise y, from
    ``row0``); a point's cell is ``floor(xy / cell_m - (col0, row0))``. A cell is BOUNDARY when its
    box padded by ``pad_m`` may touch the region's boundary; every other cell is entirely inside or
    entirely outside, decided by its centre. The padding keeps the answer exact when a point's
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
    def build(cls, geometry: BaseGeometry, target_cells: int = _RASTER_TARGET_CELLS, max_side: int = 1000,
              pad_m: float = 1e-9) -> _PointLocator:
        shapely.prepare(geometry)
        if geometry.is_empty:
            return cls(geometry, 1.0, np.zeros(2), 0.0, np.zeros(2, dtype=np.intp), np.zeros(0, dtype=np.uint8))
        minx, miny, maxx, maxy = geometry.bounds
        width, height = max(maxx - minx, 1e-6), max(maxy - miny, 1e-6)
        cell_m = max(math.sqrt(width * height / target_cells), width / max_side, height / max_side)
        inv_cell = 1.0 / cell_m
        col0, row0 = math.floor(minx * inv_cell) - 2, math.floor(miny * inv_cell) - 2
        n_cols = math.floor(maxx * inv_cell) + 3 - col0
        n_rows = math.floor(maxy * inv_cell) + 3 - row0
        first = np.array([col0, row0])
        boundary = np.zeros((n_rows, n_cols), dtype=bool)
        # Boundary segments no longer than a cell: each one's padded bounding box spans <= 3x3 cells
        # and contains the segment, so marking those cells over-approximates the boundary cells.
        rings = shapely.segmentize(shapely.get_rings(shapely.get_parts(geometry)), cell_m * 0.999)
        ring_xy, ring_index = shapely.get_coordinates(rings, return_index=True)
        same_ring = ring_index[1:] == ring_index[:-1]
        start_xy, end_xy = ring_xy[:-1][same_ring], ring_xy[1:][same_ring]
        lo = np.floor((np.minimum(start_xy, end_xy) - pad_m) * inv_cell).astype(np.intp) - first
        hi = np.floor((np.maximum(start_xy, end_xy) + pad_m) * inv_cell).astype(np.intp) - first
        if np.any(hi - lo > 2) or lo.min(initial=1) < 1 or np.any(hi >= (n_cols - 1, n_rows - 1)):
            raise AssertionError("raster: a boundary segment is longer than a cell or too close to the edge")
        for d_col in range(3):
            for d_row in range(3):
                use = (lo[:, 0] + d_col <= hi[:, 0]) & (lo[:, 1] + d_row <= hi[:, 1])
                boundary[lo[use, 1] + d_row, lo[use, 0] + d_col] = True
        side = max(n_cols, n_rows)
        codes = np.full((side, side), _OUTSIDE, dtype=np.uint8)
        rows, cols = np.nonzero(~boundary)
        centre_x = (col0 + cols + 0.5) * cell_m
        centre_y = (row0 + rows + 0.5) * cell_m
        codes[rows, cols] = np.where(shapely.contains_xy(geometry, centre_x, centre_y), _INSIDE, _OUTSIDE)
        codes[:n_rows, :n_cols][boundary] = _BOUNDARY
        return cls(geometry, inv_cell, first.astype(float), side - 0.5, np.array([1, side], dtype=np.intp),
                   codes.ravel())

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


# ---------------------------------------------------------------------------------------------
# Terrain
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Terrain:
    """An immutable, validated terrain: steppable regions whose tops are at ``surface_z``.

    Construct with :meth:`from_dict`, :meth:`load` or a generator (``contactnet.terrain.scenes``);
    the constructor itself also validates everything (raising :class:`TerrainError`), using the
    file's field names (``start`` for ``start_xy``) in messages. Two terrains are equal when their
    ``to_dict()`` are. ``surface_z`` is the file's field: the nominal ground level, and today also
    the height of every region's top; ask :meth:`height_at` for the top under a point and
    :meth:`ground_z` for the height to measure from.
    """

    name: str
    start_xy: np.ndarray
    goal_x: float
    regions: tuple[Mapping[str, Any], ...] = field(repr=False)
    surface_z: float = 0.0
    description: str = ""
    source: str = field(default="<dict>", repr=False)
    steppable: BaseGeometry = field(init=False, repr=False)
    bounds: tuple[float, float, float, float] = field(init=False)
    _locators: dict[float, _PointLocator] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        src = self.source
        setattr_ = object.__setattr__
        start_xy, goal_x, surface_z, parsed = parse_fields(
            self.name, self.description, self.start_xy, self.goal_x, self.surface_z, self.regions, src)
        setattr_(self, "start_xy", start_xy)
        setattr_(self, "goal_x", goal_x)
        setattr_(self, "surface_z", surface_z)
        setattr_(self, "regions", tuple(map(freeze_region, parsed)))
        steppable = steppable_union(parsed, src)  # within the complexity budget, or TerrainError
        shapely.prepare(steppable)
        setattr_(self, "steppable", steppable)
        setattr_(self, "bounds", tuple(float(v) for v in steppable.bounds))
        setattr_(self, "_locators", {})
        if not shapely.intersects_xy(steppable, start_xy[0], start_xy[1]):
            raise field_error(src, "start", f"{show(start_xy.tolist())} is not on steppable ground")
        if self.goal_x <= start_xy[0]:
            raise field_error(src, "goal_x",
                              f"must be beyond the start x ({start_xy[0]:g}), got {self.goal_x:g}")

    # -- construction and files -----------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>") -> Terrain:
        """Validate a terrain dict (the JSON file's content); errors name ``source`` and the field."""
        check_top_level(data, source)
        return cls(name=data["name"], start_xy=data["start"], goal_x=data["goal_x"], regions=data["regions"],
                   surface_z=data.get("surface_z", 0.0), description=data.get("description", ""),
                   source=source)

    @classmethod
    def from_json(cls, content: bytes | str, source: str = "<json>", max_bytes: int = MAX_FILE_BYTES) -> Terrain:
        """Read a terrain JSON document (e.g. an upload's bytes) with the terrain JSON limits and validate it.

        Every problem, from bytes that are not JSON to a terrain over the complexity budget, raises a
        one-line TerrainError naming ``source``. Pure (no files, no globals) and safe to run in a worker
        thread; any terrain it accepts takes well under a second.
        """
        return cls.from_dict(loads_terrain_json(content, source, max_bytes), source=source)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Terrain:
        """Read and validate a terrain JSON file; every problem raises TerrainError naming ``path``."""
        return cls.from_dict(read_terrain_json(path), source=str(path))

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict; ``Terrain.from_dict(t.to_dict()) == t``."""
        data: dict[str, Any] = {"name": self.name}
        if self.description:
            data["description"] = self.description
        data.update(start=[float(v) for v in self.start_xy], goal_x=self.goal_x, surface_z=self.surface_z,
                    regions=[thaw(r) for r in self.regions])
        return data

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write pretty JSON (2-space indent) atomically: a temp file in the same directory, then replace."""
        write_terrain_json(self.to_dict(), path)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Terrain):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None  # type: ignore[assignment]

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle as the validated dict (read-only mappings and caches are not picklable/needed)."""
        return (Terrain.from_dict, (self.to_dict(), self.source))

    # -- queries ----------------------------------------------------------------------------------
    def safe_region(self, margin: float = 0.0) -> BaseGeometry:
        """The steppable set shrunk by ``margin`` metres (cached; margin 0 is ``steppable`` itself)."""
        return self._locator(margin).geometry

    def is_safe(self, points_xy: Any, margin: float = 0.0) -> np.ndarray:
        """Which points are safe footholds: inside the steppable set shrunk by ``margin`` (metres).

        ``points_xy`` is an (N, 2) array-like of world-frame x, y in metres; a single (2,) point is
        accepted and gives a result of shape (1,). Returns a bool array (N,). Points on the boundary
        count as safe (shapely ``covers``); non-finite points are unsafe. The shrunk geometry and its
        lookup raster are built on the first call with a new margin and cached on the terrain.
        """
        points, _ = _as_points(points_xy)
        return self._locator(margin).covers(points)

    def height_at(self, points_xy: Any, outside: float = np.nan) -> np.ndarray:
        """World z (metres) of the steppable top under each point, ``outside`` where there is none.

        ``points_xy`` is an (N, 2) array-like of world-frame x, y in metres, giving a float array (N,),
        or a single (2,) point, giving a float array of shape (). A point has a top when the steppable
        set covers it (its boundary included, like :meth:`is_safe` with margin 0); over holes, off
        the terrain and for non-finite points the result is ``outside`` (NaN by default). Every
        region's top is at ``surface_z`` today, so the tops are all ``surface_z``. Vectorized on the
        same cached raster as :meth:`is_safe`.
        """
        points, single = _as_points(points_xy)
        heights = np.where(self._locator(0.0).covers(points), self.surface_z, float(outside))
        return heights.reshape(()) if single else heights

    def ground_z(self, points_xy: Any) -> np.ndarray:
        """World z (metres) to measure heights from: the top where steppable, else ``surface_z``.

        Over a hole (or off the terrain) there is no top, and the reference is the nominal ground
        level ``surface_z``: a foot or a base above a hole is as high as above the ground next to
        it, it is not "below the ground" nor infinitely high. Use it for fall detection (base height
        above the ground), the ends of swing trajectories and CoM height references; use
        :meth:`height_at` to know whether there is a top at all. Same shapes as :meth:`height_at`.
        """
        return self.height_at(points_xy, outside=self.surface_z)

    def _locator(self, margin: float) -> _PointLocator:
        locator = self._locators.get(margin) if type(margin) is float else None
        if locator is not None:
            return locator
        key = finite_float(margin)
        if key is None or key < 0.0:
            raise ValueError(f"margin must be a finite number >= 0 (metres), got {margin!r}")
        locator = self._locators.get(key)
        if locator is None:
            geometry = self.steppable if key == 0.0 else shapely.buffer(self.steppable, -key, quad_segs=16)
            locator = _PointLocator.build(geometry)
            if len(self._locators) >= _SAFE_CACHE_MAX:
                self._locators.pop(next(iter(self._locators)))
            self._locators[key] = locator
        return locator

    def summary(self) -> str:
        """A few human-readable lines describing the terrain."""
        minx, miny, maxx, maxy = self.bounds
        counts: dict[str, int] = {}
        for region in self.regions:
            counts[region["shape"]] = counts.get(region["shape"], 0) + 1
        holes_m2 = (maxx - minx) * (maxy - miny) - self.steppable.area
        lines = [
            f"terrain {self.name!r}" + (f": {self.description}" if self.description else ""),
            f"  bounds     x [{minx:.3f}, {maxx:.3f}] m, y [{miny:.3f}, {maxy:.3f}] m, surface z {self.surface_z:g} m",
            f"  steppable  {self.steppable.area:.4f} m^2; holes inside bounds {holes_m2:.4f} m^2",
            f"  regions    {len(self.regions)}: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())),
            f"  start      ({self.start_xy[0]:.3f}, {self.start_xy[1]:.3f}) m; goal_x {self.goal_x:.3f} m",
        ]
        return "\n".join(lines)

    # -- geometry for simulation and display (contactnet.terrain.mesh, contactnet.terrain.render) ---
    def mesh(self, thickness: float = 0.4) -> trimesh.Trimesh:
        """The steppable union as one closed mesh: each piece extruded down by ``thickness`` from its top.

        Each polygon of the union is a watertight prism from its top (:meth:`height_at`) down to
        ``top - thickness``; pieces that touch at a single point keep separate vertices there, so
        edges stay manifold.
        """
        pieces = [(polygon, float(self.height_at(shapely.get_coordinates(polygon.representative_point())[0])))
                  for polygon in shapely.get_parts(self.steppable)]
        return extruded_mesh(pieces, thickness)

    def render(self, ax: Axes | None = None, show_start: bool = True,
               feet_xy_start: Sequence[Sequence[float]] | np.ndarray | None = None) -> Axes:
        """Top view: steppable area filled, holes white, start marked, goal line.

        ``feet_xy_start`` (N, 2), world-frame x, y in metres: feet to mark (e.g. a robot's nominal
        stance at the start, given by the caller); None marks none.
        """
        return _render.render(self, ax=ax, show_start=show_start, feet_xy_start=feet_xy_start)

    def render_png(self, path: str | os.PathLike[str], dpi: int = 120,
                   feet_xy_start: Sequence[Sequence[float]] | np.ndarray | None = None) -> Path:
        """Render the top view to a PNG with the Agg backend (no display, no pyplot state)."""
        return _render.render_png(self, path, dpi=dpi, feet_xy_start=feet_xy_start)


def validate_terrain_bytes(content: bytes | str, source: str = "upload", max_bytes: int = MAX_FILE_BYTES) -> Terrain:
    """The validated Terrain of a JSON document's bytes, or a one-line TerrainError naming ``source``.

    The same as :meth:`Terrain.from_json`: read with the terrain JSON limits (size, depth, values,
    number length, duplicate keys), validated within the complexity budget. Thread-safe.
    """
    return Terrain.from_json(content, source=source, max_bytes=max_bytes)


def _as_points(points_xy: Any) -> tuple[np.ndarray, bool]:
    """(points (N, 2) float64, whether a single (2,) point was given); ValueError for other shapes."""
    points = np.asarray(points_xy, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        if points.shape != (2,):
            raise ValueError(f"points_xy must have shape (N, 2) or (2,), got {points.shape}")
        return points.reshape(1, 2), True
    return points, False
