"""Terrain: the steppable surface the planner checks candidate footholds against.

A terrain is the union of 2D *regions* (rectangles, circles, stars, polygons and grids of square
cells) at the height ``surface_z``; everything else is a hole with nothing to stand on. Terrains
are read from and written to JSON files (``terrains/*.json``, format in DESIGN.md "Terrain file")
with strict validation: every problem raises :class:`TerrainError` with a one-line message that
names the file and the field, e.g. ``terrains/bad.json: regions[3].size: expected ...``.

The hot path is :meth:`Terrain.is_safe`, vectorized over many candidate footholds. It answers
from a raster built once per margin (cells fully inside / fully outside / on the boundary) and
asks shapely only for points in boundary cells, so it is exact with respect to shapely.

Generators build the paper's scenes: :func:`flat`, :func:`random_field` (experiment 3),
:func:`stepping_stones` (experiment 1), :func:`narrow_stones` (experiment 2) and
:func:`push_field` (experiment 5). ``python -m contactnet.terrain`` rewrites the shipped files.
"""

from __future__ import annotations

import argparse
import json
import math
import numbers
import os
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

if TYPE_CHECKING:
    import trimesh
    from matplotlib.axes import Axes

__all__ = [
    "Terrain",
    "TerrainError",
    "available",
    "benchmark_is_safe",
    "by_name",
    "flat",
    "main",
    "narrow_stones",
    "push_field",
    "random_field",
    "resolve",
    "stepping_stones",
    "terrains_dir",
]

# ---------------------------------------------------------------------------------------------
# Limits and constants (immutable)
# ---------------------------------------------------------------------------------------------
MAX_ABS_COORD_M = 1000.0
"""Every coordinate and every region's extent must lie within +-this (metres)."""
MIN_SIZE_M = 1e-3
"""Smallest accepted size, radius or grid cell (metres)."""
MAX_SIZE_M = 1000.0
"""Largest accepted size or radius (metres)."""
MAX_GRID_CELLS = 250_000
MAX_REGIONS = 10_000
MAX_POLYGON_VERTICES = 10_000
MAX_FILE_BYTES = 64 * 1024 * 1024
STAR_POINTS_RANGE = (3, 64)
CIRCLE_MAX_ERROR_M = 5e-4
"""Largest distance between a circle and its inscribed polygon (metres)."""
CIRCLE_MIN_SEGMENTS = 64
UNION_GRID_SIZE_M = 1e-9
"""Coordinates are snapped to this grid when regions are united (closes sub-nm cracks)."""
SHAPES = ("circle", "grid", "polygon", "rect", "star")
SOLO12_HIP_XY_BASE = np.array([[0.1946, 0.1015], [0.1946, -0.1015], [-0.1946, 0.1015], [-0.1946, -0.1015]])
"""Solo12 hip positions in the base frame (FL, FR, HL, HR), metres; used by the generators."""
SOLO12_NOMINAL_FOOT_XY_BASE = np.array([[0.1946, 0.14], [0.1946, -0.14], [-0.1946, 0.14], [-0.1946, -0.14]])
"""Nominal standing feet in the base frame (FL, FR, HL, HR), metres."""
_RASTER_TARGET_CELLS = 1 << 20  # capped by max_side=1000 per axis: 1.5 mm cells on the paper's field
_SAFE_CACHE_MAX = 16
_TOP_LEVEL_KEYS = ("name", "description", "start", "goal_x", "surface_z", "regions")
_REQUIRED_TOP_LEVEL = ("name", "start", "goal_x", "regions")
_REGION_KEYS: Mapping[str, tuple[tuple[str, ...], tuple[str, ...]]] = MappingProxyType(
    {  # shape -> (required keys, optional keys); "shape" itself is implied
        "rect": (("center", "size"), ("yaw",)),
        "circle": (("center", "radius"), ()),
        "star": (("center", "outer_radius", "inner_radius", "points"), ("yaw",)),
        "polygon": (("vertices",), ()),
        "grid": (("origin", "cell", "cols", "rows"), ("removed",)),
    }
)


class TerrainError(ValueError):
    """A terrain file or dict is invalid. ``str(err)`` is one line: ``source: field: problem``."""

    def __init__(self, message: str, *, source: str | None = None, field_path: str | None = None):
        super().__init__(" ".join(message.split()) if "\n" in message else message)
        self.source = source
        self.field_path = field_path


# ---------------------------------------------------------------------------------------------
# Validation helpers
# ---------------------------------------------------------------------------------------------
def _show(value: Any, limit: int = 60) -> str:
    """Compact one-line rendering of a user value for an error message."""
    try:
        text = json.dumps(value.tolist() if isinstance(value, np.ndarray) else value)
    except (TypeError, ValueError):
        text = repr(value)
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _error(source: str, path: str, message: str) -> TerrainError:
    prefix = f"{source}: " if source else ""
    where = f"{path}: " if path else ""
    return TerrainError(f"{prefix}{where}{message}", source=source, field_path=path)


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _finite_float(value: Any) -> float | None:
    """``float(value)`` when value is a finite real number (not bool), else None."""
    if not _is_number(value):
        return None
    try:
        result = float(value)
    except (OverflowError, ValueError):
        return None
    return result if math.isfinite(result) else None


def _number(value: Any, source: str, path: str, lo: float, hi: float, what: str) -> float:
    result = _finite_float(value)
    if result is None or not lo <= result <= hi:
        raise _error(source, path, f"expected {what}, got {_show(value)}")
    return result


def _integer(value: Any, source: str, path: str, lo: int, hi: int) -> int:
    if not isinstance(value, numbers.Integral) or isinstance(value, (bool, np.bool_)) or not lo <= value <= hi:
        raise _error(source, path, f"expected an integer in {lo}..{hi}, got {_show(value)}")
    return int(value)


def _pair(value: Any, source: str, path: str, lo: float, hi: float, what: str) -> list[float]:
    """Two finite numbers in [lo, hi] given as a JSON array."""
    if isinstance(value, (list, tuple, np.ndarray)) and len(value) == 2:
        items = [_finite_float(v) for v in value]
        if all(v is not None and lo <= v <= hi for v in items):
            return [float(v) for v in items]  # type: ignore[arg-type]
    raise _error(source, path, f"expected {what}, got {_show(value)}")


def _coords(value: Any, source: str, path: str) -> list[float]:
    return _pair(value, source, path, -MAX_ABS_COORD_M, MAX_ABS_COORD_M,
                 f"[x, y] with 2 finite numbers in [-{MAX_ABS_COORD_M:g}, {MAX_ABS_COORD_M:g}]")


def _size(value: Any, source: str, path: str, what: str = "a size") -> float:
    return _number(value, source, path, MIN_SIZE_M, MAX_SIZE_M,
                   f"{what} in [{MIN_SIZE_M:g}, {MAX_SIZE_M:g}] m")


def _check_keys(raw: Mapping[str, Any], allowed: Sequence[str], required: Sequence[str], source: str,
                prefix: str) -> None:
    """Reject unknown keys (naming them) and missing required keys."""
    for key in raw:
        if key not in allowed:
            path = f"{prefix}.{key}" if prefix else str(key)
            raise _error(source, path, f"unknown key {_show(key)}; allowed keys: {', '.join(sorted(allowed))}")
    for key in required:
        if key not in raw:
            raise _error(source, f"{prefix}.{key}" if prefix else key, "missing required field")


def _freeze(value: Any) -> Any:
    """Recursively turn dicts into read-only mappings and lists into tuples."""
    if isinstance(value, Mapping):
        return MappingProxyType({k: _freeze(v) for k, v in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(_freeze(v) for v in value)
    return value


def _thaw(value: Any) -> Any:
    """Inverse of :func:`_freeze`: plain dicts and lists for JSON."""
    if isinstance(value, Mapping):
        return {k: _thaw(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [_thaw(v) for v in value]
    return value


# ---------------------------------------------------------------------------------------------
# Regions: validation (raw JSON -> normalized dict) and geometry (normalized dict -> shapely)
# ---------------------------------------------------------------------------------------------
def _parse_region(raw: Any, source: str, path: str) -> dict[str, Any]:
    """Validate one region and return it normalized (floats, defaults filled in, sorted cells)."""
    if not isinstance(raw, Mapping):
        raise _error(source, path, f"expected an object with a 'shape', got {_show(raw)}")
    if "shape" not in raw:
        raise _error(source, f"{path}.shape", "missing required field")
    shape = raw["shape"]
    if not isinstance(shape, str) or shape not in _REGION_KEYS:
        raise _error(source, f"{path}.shape", f"unknown shape {_show(shape)}; expected one of {', '.join(SHAPES)}")
    required, optional = _REGION_KEYS[shape]
    _check_keys(raw, ("shape", *required, *optional), required, source, path)

    def yaw() -> float:
        return _number(raw.get("yaw", 0.0), source, f"{path}.yaw", -MAX_ABS_COORD_M, MAX_ABS_COORD_M,
                       "a finite yaw angle in radians")

    region: dict[str, Any] = {"shape": shape}
    if shape == "rect":
        region["center"] = _coords(raw["center"], source, f"{path}.center")
        region["size"] = _pair(raw["size"], source, f"{path}.size", MIN_SIZE_M, MAX_SIZE_M,
                               f"2 numbers in [{MIN_SIZE_M:g}, {MAX_SIZE_M:g}] m")
        region["yaw"] = yaw()
    elif shape == "circle":
        region["center"] = _coords(raw["center"], source, f"{path}.center")
        region["radius"] = _size(raw["radius"], source, f"{path}.radius", "a radius")
    elif shape == "star":
        region["center"] = _coords(raw["center"], source, f"{path}.center")
        region["outer_radius"] = _size(raw["outer_radius"], source, f"{path}.outer_radius", "a radius")
        region["inner_radius"] = _size(raw["inner_radius"], source, f"{path}.inner_radius", "a radius")
        region["points"] = _integer(raw["points"], source, f"{path}.points", *STAR_POINTS_RANGE)
        region["yaw"] = yaw()
        if region["inner_radius"] >= region["outer_radius"]:
            raise _error(source, f"{path}.inner_radius",
                         f"must be smaller than outer_radius ({region['outer_radius']:g}), "
                         f"got {region['inner_radius']:g}")
    elif shape == "polygon":
        vertices = raw["vertices"]
        if not isinstance(vertices, (list, tuple)) or not 3 <= len(vertices) <= MAX_POLYGON_VERTICES:
            count = len(vertices) if isinstance(vertices, (list, tuple)) else _show(vertices)
            raise _error(source, f"{path}.vertices",
                         f"expected a list of 3..{MAX_POLYGON_VERTICES} [x, y] vertices, got {count}")
        region["vertices"] = [_coords(v, source, f"{path}.vertices[{i}]") for i, v in enumerate(vertices)]
        polygon = Polygon(region["vertices"])
        if not polygon.is_valid:
            reason = shapely.is_valid_reason(polygon)
            raise _error(source, f"{path}.vertices", f"polygon is not simple ({reason})")
        if polygon.area <= 1e-12:
            raise _error(source, f"{path}.vertices", "polygon has zero area")
    else:  # grid
        region["origin"] = _coords(raw["origin"], source, f"{path}.origin")
        region["cell"] = _size(raw["cell"], source, f"{path}.cell", "a cell size")
        region["cols"] = _integer(raw["cols"], source, f"{path}.cols", 1, MAX_GRID_CELLS)
        region["rows"] = _integer(raw["rows"], source, f"{path}.rows", 1, MAX_GRID_CELLS)
        if region["cols"] * region["rows"] > MAX_GRID_CELLS:
            raise _error(source, f"{path}.cols",
                         f"cols * rows = {region['cols'] * region['rows']} exceeds {MAX_GRID_CELLS}")
        region["removed"] = _parse_removed(raw.get("removed", []), region["cols"], region["rows"], source,
                                           f"{path}.removed")
    minx, miny, maxx, maxy = _region_bounds(region)
    if min(minx, miny) < -MAX_ABS_COORD_M or max(maxx, maxy) > MAX_ABS_COORD_M:
        raise _error(source, path, f"region extends beyond +-{MAX_ABS_COORD_M:g} m "
                                   f"(bounds {minx:.6g}, {miny:.6g}, {maxx:.6g}, {maxy:.6g})")
    return region


def _parse_removed(value: Any, cols: int, rows: int, source: str, path: str) -> list[list[int]]:
    if not isinstance(value, (list, tuple)):
        raise _error(source, path, f"expected a list of [col, row] pairs, got {_show(value)}")
    cells: set[tuple[int, int]] = set()
    for i, item in enumerate(value):
        ok = isinstance(item, (list, tuple)) and len(item) == 2 and all(
            isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_)) for v in item)
        if not ok or not (0 <= item[0] < cols and 0 <= item[1] < rows):
            raise _error(source, f"{path}[{i}]",
                         f"expected [col, row] integers with col in 0..{cols - 1}, row in 0..{rows - 1}, "
                         f"got {_show(item)}")
        cell = (int(item[0]), int(item[1]))
        if cell in cells:
            raise _error(source, f"{path}[{i}]", f"duplicate cell {list(cell)}")
        cells.add(cell)
    return [list(c) for c in sorted(cells, key=lambda c: (c[1], c[0]))]


def _region_bounds(region: Mapping[str, Any]) -> tuple[float, float, float, float]:
    """Axis-aligned bounds of a normalized region (a cheap superset for the extent check)."""
    shape = region["shape"]
    if shape == "grid":
        (ox, oy), cell = region["origin"], region["cell"]
        return ox, oy, ox + cell * region["cols"], oy + cell * region["rows"]
    if shape == "polygon":
        xy = np.asarray(region["vertices"], dtype=float)
        return float(xy[:, 0].min()), float(xy[:, 1].min()), float(xy[:, 0].max()), float(xy[:, 1].max())
    if shape == "rect":
        corners_xy = _rect_corners_xy(region["center"], region["size"], region["yaw"])
        return (float(corners_xy[:, 0].min()), float(corners_xy[:, 1].min()), float(corners_xy[:, 0].max()),
                float(corners_xy[:, 1].max()))
    (cx, cy), radius = region["center"], region.get("radius", region.get("outer_radius"))
    return cx - radius, cy - radius, cx + radius, cy + radius


def _circle_segments(radius_m: float) -> int:
    """Segments of an inscribed polygon within CIRCLE_MAX_ERROR_M of the circle."""
    if radius_m <= CIRCLE_MAX_ERROR_M:
        return CIRCLE_MIN_SEGMENTS
    return max(CIRCLE_MIN_SEGMENTS, math.ceil(math.pi / math.acos(1.0 - CIRCLE_MAX_ERROR_M / radius_m)))


def _rect_corners_xy(center: Sequence[float], size: Sequence[float], yaw: float) -> np.ndarray:
    """Corners (4, 2), counter-clockwise, of a rectangle rotated by yaw about its centre."""
    half_x, half_y = 0.5 * size[0], 0.5 * size[1]
    local_xy = np.array([[-half_x, -half_y], [half_x, -half_y], [half_x, half_y], [-half_x, half_y]])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.asarray(center) + local_xy @ np.array([[c, s], [-s, c]])


def _circle_xy(center: Sequence[float], radius: float) -> np.ndarray:
    n = _circle_segments(radius)
    angles = np.arange(n) * (2.0 * math.pi / n)
    return np.asarray(center) + radius * np.column_stack([np.cos(angles), np.sin(angles)])


def _star_xy(region: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """(outer tips (n, 2), inner vertices (n, 2)); inner vertex k lies between tips k and k + 1."""
    n, yaw = region["points"], region["yaw"]
    angles = yaw + np.arange(n) * (2.0 * math.pi / n)
    half = math.pi / n
    center = np.asarray(region["center"])
    tips = center + region["outer_radius"] * np.column_stack([np.cos(angles), np.sin(angles)])
    inner = center + region["inner_radius"] * np.column_stack([np.cos(angles + half), np.sin(angles + half)])
    return tips, inner


def _grid_rectangles(region: Mapping[str, Any]) -> list[tuple[int, int, int, int]]:
    """Present cells of a grid merged greedily into rectangles (col0, row0, col1, row1), ends exclusive.

    Each row is split into runs of present cells; a run identical to one in the previous row extends
    that rectangle upwards.
    """
    cols, rows = region["cols"], region["rows"]
    present = np.ones((rows, cols), dtype=bool)
    for col, row in region["removed"]:
        present[row, col] = False
    rectangles: list[tuple[int, int, int, int]] = []
    open_runs: dict[tuple[int, int], int] = {}  # (col0, col1) -> first row
    for row in range(rows + 1):
        runs: set[tuple[int, int]] = set()
        if row < rows:
            padded = np.concatenate([[False], present[row], [False]]).astype(np.int8)
            edges = np.flatnonzero(np.diff(padded))
            runs = {(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)}
        for run in [r for r in open_runs if r not in runs]:
            rectangles.append((run[0], open_runs.pop(run), run[1], row))
        for run in runs:
            open_runs.setdefault(run, row)
    return sorted(rectangles, key=lambda r: (r[1], r[0]))


def _grid_cell_edges(region: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Cell edge coordinates along x (cols + 1,) and y (rows + 1,), computed one way everywhere."""
    (ox, oy), cell = region["origin"], region["cell"]
    return ox + cell * np.arange(region["cols"] + 1), oy + cell * np.arange(region["rows"] + 1)


def _region_geometry(region: Mapping[str, Any]) -> BaseGeometry:
    """Shapely geometry of one normalized region."""
    shape = region["shape"]
    if shape == "rect":
        return Polygon(_rect_corners_xy(region["center"], region["size"], region["yaw"]))
    if shape == "circle":
        return Polygon(_circle_xy(region["center"], region["radius"]))
    if shape == "star":
        tips, inner = _star_xy(region)
        return Polygon(np.stack([tips, inner], axis=1).reshape(-1, 2))
    if shape == "polygon":
        return Polygon(region["vertices"])
    edges_x, edges_y = _grid_cell_edges(region)
    rectangles = _grid_rectangles(region)
    if not rectangles:
        return Polygon()
    c0, r0, c1, r1 = (np.array(v) for v in zip(*rectangles, strict=True))
    return shapely.union_all(shapely.box(edges_x[c0], edges_y[r0], edges_x[c1], edges_y[r1]))


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
    """An immutable, validated terrain: steppable regions at height ``surface_z``.

    Construct with :meth:`from_dict`, :meth:`load` or a generator; the constructor itself also
    validates everything (raising :class:`TerrainError`), using the file's field names
    (``start`` for ``start_xy``) in messages. Two terrains are equal when their ``to_dict()`` are.
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
        if not isinstance(self.name, str) or not self.name.strip() or len(self.name) > 200 or "\n" in self.name:
            raise _error(src, "name", f"expected a non-empty one-line string (<= 200 chars), got {_show(self.name)}")
        if not isinstance(self.description, str):
            raise _error(src, "description", f"expected a string, got {_show(self.description)}")
        start_xy = np.array(_coords(self.start_xy, src, "start"))
        start_xy.flags.writeable = False
        setattr_(self, "start_xy", start_xy)
        setattr_(self, "goal_x", _number(self.goal_x, src, "goal_x", -MAX_ABS_COORD_M, MAX_ABS_COORD_M,
                                         f"a finite number in [-{MAX_ABS_COORD_M:g}, {MAX_ABS_COORD_M:g}]"))
        setattr_(self, "surface_z", _number(self.surface_z, src, "surface_z", -MAX_ABS_COORD_M,
                                            MAX_ABS_COORD_M,
                                            f"a finite number in [-{MAX_ABS_COORD_M:g}, {MAX_ABS_COORD_M:g}]"))
        regions = self.regions
        if not isinstance(regions, (list, tuple)):
            raise _error(src, "regions", f"expected a list of regions, got {_show(regions)}")
        if not regions:
            raise _error(src, "regions", "expected at least one region, got an empty list")
        if len(regions) > MAX_REGIONS:
            raise _error(src, "regions", f"expected at most {MAX_REGIONS} regions, got {len(regions)}")
        parsed = [_parse_region(r, src, f"regions[{i}]") for i, r in enumerate(regions)]
        setattr_(self, "regions", tuple(_freeze(r) for r in parsed))
        union = shapely.union_all([_region_geometry(r) for r in parsed], grid_size=UNION_GRID_SIZE_M)
        steppable = shapely.simplify(union, 0.0)  # drops exactly collinear vertices only
        if not steppable.is_valid:  # pragma: no cover - defensive; GEOS overlay output is valid
            steppable = shapely.make_valid(steppable)
        shapely.prepare(steppable)
        setattr_(self, "steppable", steppable)
        setattr_(self, "bounds", tuple(float(v) for v in steppable.bounds))
        setattr_(self, "_locators", {})
        if not shapely.intersects_xy(steppable, start_xy[0], start_xy[1]):
            raise _error(src, "start", f"{_show(start_xy.tolist())} is not on steppable ground")
        if self.goal_x <= start_xy[0]:
            raise _error(src, "goal_x", f"must be beyond the start x ({start_xy[0]:g}), got {self.goal_x:g}")

    # -- construction and files -----------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>") -> Terrain:
        """Validate a terrain dict (the JSON file's content); errors name ``source`` and the field."""
        if not isinstance(data, Mapping):
            raise _error(source, "", f"expected a JSON object at the top level, got {_show(data)}")
        _check_keys(data, _TOP_LEVEL_KEYS, _REQUIRED_TOP_LEVEL, source, "")
        return cls(name=data["name"], start_xy=data["start"], goal_x=data["goal_x"], regions=data["regions"],
                   surface_z=data.get("surface_z", 0.0), description=data.get("description", ""),
                   source=source)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Terrain:
        """Read and validate a terrain JSON file; every problem raises TerrainError naming ``path``."""
        source = str(path)
        try:
            with open(path, "rb") as file:
                raw = file.read(MAX_FILE_BYTES + 1)
        except OSError as exc:
            raise _error(source, "", f"cannot read file: {exc.strerror or exc}") from exc
        if len(raw) > MAX_FILE_BYTES:
            raise _error(source, "", f"file is larger than {MAX_FILE_BYTES} bytes")
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise _error(source, "", f"not UTF-8 text (byte {exc.start})") from exc
        try:
            data = json.loads(text, object_pairs_hook=_reject_duplicate_keys)
        except json.JSONDecodeError as exc:
            raise _error(source, "", f"not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})") from exc
        except RecursionError as exc:
            raise _error(source, "", "not valid JSON: nested too deeply") from exc
        except _DuplicateKeyError as exc:
            raise _error(source, "", f"duplicate key {_show(exc.args[0])} in a JSON object") from exc
        return cls.from_dict(data, source=source)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict; ``Terrain.from_dict(t.to_dict()) == t``."""
        data: dict[str, Any] = {"name": self.name}
        if self.description:
            data["description"] = self.description
        data.update(start=[float(v) for v in self.start_xy], goal_x=self.goal_x, surface_z=self.surface_z,
                    regions=[_thaw(r) for r in self.regions])
        return data

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write pretty JSON (2-space indent) atomically: a temp file in the same directory, then replace."""
        target = Path(path)
        text = _pretty_json(self.to_dict()) + "\n"
        mode = target.stat().st_mode & 0o777 if target.exists() else 0o644
        fd, tmp_name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
        try:
            os.chmod(tmp_name, mode)  # mkstemp creates 0600; keep the usual permissions
            with os.fdopen(fd, "w", encoding="utf-8") as file:
                file.write(text)
                file.flush()
                os.fsync(file.fileno())
            os.replace(tmp_name, target)
        except BaseException:
            Path(tmp_name).unlink(missing_ok=True)
            raise

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
        points = np.asarray(points_xy, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 2:
            if points.shape != (2,):
                raise ValueError(f"points_xy must have shape (N, 2) or (2,), got {points.shape}")
            points = points.reshape(1, 2)
        return self._locator(margin).covers(points)

    def _locator(self, margin: float) -> _PointLocator:
        locator = self._locators.get(margin) if type(margin) is float else None
        if locator is not None:
            return locator
        key = _finite_float(margin)
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

    # -- geometry for simulation and display --------------------------------------------------------
    def mesh(self, thickness: float = 0.4) -> trimesh.Trimesh:
        """The steppable union extruded from ``surface_z - thickness`` to ``surface_z``.

        One closed mesh (each polygon of the union is a watertight prism; pieces that touch at a
        single point keep separate vertices there, so edges stay manifold).
        """
        import trimesh

        thickness = _positive_thickness(thickness)
        vertices: list[np.ndarray] = []
        faces: list[np.ndarray] = []
        offset = 0
        for polygon in shapely.get_parts(self.steppable):
            if polygon.is_empty or polygon.area <= 0.0:
                continue
            prism_xyz, prism_faces = _extrude(polygon, self.surface_z - thickness, self.surface_z)
            vertices.append(prism_xyz)
            faces.append(prism_faces + offset)
            offset += len(prism_xyz)
        return trimesh.Trimesh(vertices=np.concatenate(vertices), faces=np.concatenate(faces), process=False)

    def render(self, ax: Axes | None = None, show_start: bool = True) -> Axes:
        """Top view: steppable area filled, holes white, start (and nominal feet) marked, goal line."""
        from matplotlib.patches import PathPatch
        from matplotlib.path import Path as MplPath

        if ax is None:
            import matplotlib.pyplot as plt

            _, ax = plt.subplots(figsize=_figure_size(self.bounds))
        minx, miny, maxx, maxy = self.bounds
        pad = 0.05 * max(maxx - minx, maxy - miny, 0.2)
        ax.set_facecolor("white")
        for polygon in shapely.get_parts(self.steppable):
            polygon = orient(polygon, sign=1.0)
            rings = [np.asarray(polygon.exterior.coords)] + [np.asarray(r.coords) for r in polygon.interiors]
            path = MplPath.make_compound_path(*[MplPath(r, closed=True) for r in rings])
            ax.add_patch(PathPatch(path, facecolor="#cdb891", edgecolor="#6b5a3a", linewidth=0.6))
        ax.axvline(self.goal_x, color="#2a8a3a", linestyle="--", linewidth=1.2, label=f"goal x = {self.goal_x:g} m")
        if show_start:
            feet_xy = self.start_xy + SOLO12_NOMINAL_FOOT_XY_BASE
            ax.plot(*self.start_xy, marker="o", color="#c0392b", markersize=6, linestyle="none", label="start")
            ax.plot(feet_xy[:, 0], feet_xy[:, 1], marker="x", color="#c0392b", markersize=5, linestyle="none",
                    label="nominal feet")
        ax.set_xlim(min(minx, self.goal_x) - pad, max(maxx, self.goal_x) + pad)
        ax.set_ylim(miny - pad, maxy + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(self.name)
        ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
        return ax

    def render_png(self, path: str | os.PathLike[str], dpi: int = 120) -> Path:
        """Render the top view to a PNG with the Agg backend (no display, no pyplot state)."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        figure = Figure(figsize=_figure_size(self.bounds))
        FigureCanvasAgg(figure)
        self.render(ax=figure.add_subplot(), show_start=True)
        figure.tight_layout()
        target = Path(path)
        target.parent.mkdir(parents=True, exist_ok=True)
        figure.savefig(target, dpi=dpi)
        return target


class _DuplicateKeyError(Exception):
    pass


def _reject_duplicate_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise _DuplicateKeyError(key)
        result[key] = value
    return result


def _pretty_json(value: Any, indent: int = 2, level: int = 0, width: int = 100) -> str:
    """JSON with 2-space indent where short arrays of scalars (and of short arrays) stay on one line."""
    inline = json.dumps(value, allow_nan=False)
    pad, inner = " " * (indent * level), " " * (indent * (level + 1))
    if isinstance(value, dict) and value:
        items = [f"{inner}{json.dumps(k)}: {_pretty_json(v, indent, level + 1, width).lstrip()}"
                 for k, v in value.items()]
        return pad + "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(value, list) and value:
        scalar_like = all(not isinstance(v, (dict, list)) or
                          (isinstance(v, list) and all(not isinstance(w, (dict, list)) for w in v)) for v in value)
        if scalar_like and len(inline) + len(pad) <= width:
            return pad + inline
        if scalar_like:  # pack several short items per line
            lines: list[str] = []
            for item in (json.dumps(v, allow_nan=False) for v in value):
                if lines and len(lines[-1]) + len(item) + 2 <= width:
                    lines[-1] += " " + item + ","
                else:
                    lines.append(inner + item + ",")
            return pad + "[\n" + "\n".join(lines)[:-1] + "\n" + pad + "]"
        items = [_pretty_json(v, indent, level + 1, width) for v in value]
        return pad + "[\n" + ",\n".join(items) + "\n" + pad + "]"
    return pad + inline


def _positive_thickness(thickness: float) -> float:
    value = _finite_float(thickness)
    if value is None or value <= 0.0:
        raise ValueError(f"thickness must be a finite number > 0 (metres), got {thickness!r}")
    return value


def _figure_size(bounds: tuple[float, float, float, float]) -> tuple[float, float]:
    width, height = max(bounds[2] - bounds[0], 0.1), max(bounds[3] - bounds[1], 0.1)
    aspect = min(max(width / height, 0.5), 6.0)
    return (min(4.0 * aspect, 14.0), min(4.0 * aspect, 14.0) / aspect + 1.0)


def _earcut(vertices_xy: np.ndarray, ring_ends: Sequence[int]) -> np.ndarray:
    """Triangles (T, 3) of indices into vertices_xy, all counter-clockwise.

    ``ring_ends`` are the cumulative end indices of the rings (exterior first, then holes).
    """
    import mapbox_earcut

    triangles = mapbox_earcut.triangulate_float64(
        np.ascontiguousarray(vertices_xy, dtype=np.float64), np.asarray(ring_ends, dtype=np.uint32)
    ).reshape(-1, 3).astype(np.int64)
    a, b, c = (vertices_xy[triangles[:, i]] for i in range(3))
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    triangles[cross < 0] = triangles[cross < 0][:, ::-1]
    return triangles


def _border_edges(triangles: np.ndarray) -> np.ndarray:
    """Directed edges (E, 2) used by exactly one triangle (u -> v with the surface on the left)."""
    directed = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    _, inverse, counts = np.unique(np.sort(directed, axis=1), axis=0, return_inverse=True, return_counts=True)
    return directed[counts[inverse.ravel()] == 1]


def _split_pinched_vertices(triangles: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Give each fan of triangles around a pinch vertex its own copy of that vertex.

    Where two parts of a polygon touch at one point (earcut merges coincident points), the vertex
    is shared by separate fans; copying it per fan keeps every edge of the prism manifold.
    Returns (triangles, original vertex index of every vertex (V',)).
    """
    triangles = triangles.copy()
    original = list(range(n_vertices))
    out_degree = np.bincount(_border_edges(triangles)[:, 0], minlength=n_vertices)
    for vertex in np.flatnonzero(out_degree > 1):
        fan_of = {int(t): int(t) for t in np.flatnonzero((triangles == vertex).any(axis=1))}

        def root(t: int, fan_of: dict[int, int] = fan_of) -> int:
            while fan_of[t] != t:
                t = fan_of[t]
            return t

        by_edge: dict[int, list[int]] = {}  # other end of an edge at `vertex` -> triangles using it
        for t in fan_of:
            for other in triangles[t]:
                if other != vertex:
                    by_edge.setdefault(int(other), []).append(t)
        for sharing in by_edge.values():
            for t in sharing[1:]:
                fan_of[root(t)] = root(sharing[0])
        fans: dict[int, list[int]] = {}
        for t in fan_of:
            fans.setdefault(root(t), []).append(t)
        for members in list(fans.values())[1:]:
            copy_index = len(original)
            original.append(int(vertex))
            for t in members:
                triangles[t][triangles[t] == vertex] = copy_index
    return triangles, np.asarray(original, dtype=np.int64)


def _extrude(polygon: Polygon, bottom_z: float, top_z: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed prism over one polygon (holes allowed): (vertices (V, 3), faces (F, 3)), outward normals.

    The top is an earcut triangulation; side walls are built on the triangulation's own boundary
    edges (edges used by one triangle), so the prism is closed even where earcut drops or merges
    vertices; vertices where the polygon touches itself are split per triangle fan.
    """
    polygon = orient(polygon, sign=1.0)
    rings = [np.asarray(polygon.exterior.coords)[:-1]] + [np.asarray(r.coords)[:-1] for r in polygon.interiors]
    ring_xy = np.concatenate(rings)
    top, original = _split_pinched_vertices(_earcut(ring_xy, np.cumsum([len(r) for r in rings]).tolist()),
                                            len(ring_xy))
    border = _border_edges(top)  # u -> v with the solid on the left; outward is to the right
    n = len(original)
    vertex_xy = ring_xy[original]
    vertices = np.concatenate([np.column_stack([vertex_xy, np.full(n, top_z)]),
                               np.column_stack([vertex_xy, np.full(n, bottom_z)])])
    u, v = border[:, 0], border[:, 1]
    sides = np.concatenate([np.column_stack([v, u, u + n]), np.column_stack([v, u + n, v + n])])
    faces = np.concatenate([top, top[:, ::-1] + n, sides])
    used = np.unique(faces)
    remap = np.full(2 * n, -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return vertices[used], remap[faces]


# ---------------------------------------------------------------------------------------------
# Generators
# ---------------------------------------------------------------------------------------------
def _rect(center_xy: Sequence[float], size_xy: Sequence[float], yaw: float = 0.0) -> dict[str, Any]:
    return {"shape": "rect", "center": [float(v) for v in center_xy], "size": [float(v) for v in size_xy],
            "yaw": float(yaw)}


def _circle(center_xy: Sequence[float], radius: float) -> dict[str, Any]:
    return {"shape": "circle", "center": [float(v) for v in center_xy], "radius": float(radius)}


def _star(center_xy: Sequence[float], outer: float, inner: float, points: int, yaw: float = 0.0) -> dict[str, Any]:
    return {"shape": "star", "center": [float(v) for v in center_xy], "outer_radius": float(outer),
            "inner_radius": float(inner), "points": int(points), "yaw": float(yaw)}


def flat(size: tuple[float, float] = (20.0, 20.0)) -> Terrain:
    """One big rectangle centred on the start (0, 0); goal_x = 8 m (or 0.5 m before the far edge)."""
    size_x, size_y = (float(v) for v in size)
    if not (size_x >= 1.2 and size_y >= 0.6):
        raise TerrainError(f"flat: size must be at least (1.2, 0.6) m to hold the robot, got {_show(list(size))}")
    return Terrain(name="flat", start_xy=(0.0, 0.0), goal_x=min(8.0, 0.5 * size_x - 0.5),
                   regions=[_rect((0.0, 0.0), (size_x, size_y))],
                   description=f"flat ground, {size_x:g} x {size_y:g} m")


RANDOM_FIELD_CELL_M = 0.05
RANDOM_FIELD_COLS = 30
RANDOM_FIELD_ROWS = 10
RANDOM_FIELD_PLATFORM_M = 0.5


def random_field(removed: int, seed: int) -> Terrain:
    """The paper's random field (experiment 3): 30 x 10 squares of 5 cm with ``removed`` squares missing.

    Layout along x: a solid 0.5 x 0.5 m start platform centred on the start (0, 0), the 1.5 x 0.5 m
    field from x = 0.25 to 1.75 m, then a solid 0.5 x 0.5 m end platform. ``goal_x`` = 1.75 m: the
    base has crossed the whole field. The removed cells are ``default_rng(seed).choice(300, removed)``.
    """
    n_cells = RANDOM_FIELD_COLS * RANDOM_FIELD_ROWS
    if not _is_number(removed) or not isinstance(removed, numbers.Integral) or not 0 <= removed <= n_cells:
        raise TerrainError(f"random_field: removed must be an integer in 0..{n_cells}, got {_show(removed)}")
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool) or seed < 0:
        raise TerrainError(f"random_field: seed must be a non-negative integer, got {_show(seed)}")
    cell, platform = RANDOM_FIELD_CELL_M, RANDOM_FIELD_PLATFORM_M
    width_y = RANDOM_FIELD_ROWS * cell
    field_x0 = 0.5 * platform
    field_x1 = field_x0 + RANDOM_FIELD_COLS * cell
    flat_index = np.random.default_rng(int(seed)).choice(n_cells, size=int(removed), replace=False)
    removed_cells = [[int(i % RANDOM_FIELD_COLS), int(i // RANDOM_FIELD_COLS)] for i in flat_index]
    regions = [
        _rect((0.0, 0.0), (platform, width_y)),
        {"shape": "grid", "origin": [field_x0, -0.5 * width_y], "cell": cell, "cols": RANDOM_FIELD_COLS,
         "rows": RANDOM_FIELD_ROWS, "removed": removed_cells},
        _rect((field_x1 + 0.5 * platform, 0.0), (platform, width_y)),
    ]
    return Terrain(name=f"random_{int(removed)}_{int(seed)}", start_xy=(0.0, 0.0), goal_x=field_x1,
                   regions=regions,
                   description=f"paper field: 300 squares of 5 x 5 cm, {int(removed)} removed (seed {int(seed)})")


def stepping_stones() -> Terrain:
    """The paper's Fig. 2 scene: start square, 8 stones (3 stars, 2 circles, 3 rectangles), end square.

    The stones sit irregularly in a left lane (y ~ +0.12 m), a right lane (y ~ -0.12 m) and the
    middle, ~1 m along x; holes between consecutive stones of a lane are at most ~7 cm wide, so each
    leg's 5 x 5 candidate grid (5 cm spacing around its hip) always contains safe footholds.
    """
    stones = [
        _circle((0.37, 0.12), 0.085),
        _rect((0.39, -0.13), (0.17, 0.16), yaw=0.12),
        _rect((0.585, 0.145), (0.14, 0.12), yaw=-0.2),
        _star((0.62, -0.095), 0.15, 0.08, 5, yaw=0.3),
        _star((0.80, 0.10), 0.12, 0.07, 6, yaw=0.1),
        _circle((0.87, -0.14), 0.095),
        _star((1.065, 0.125), 0.13, 0.07, 5, yaw=-0.25),
        _rect((1.08, -0.12), (0.16, 0.18), yaw=0.3),
    ]
    end_x0 = 1.25
    regions = [_rect((0.0, 0.0), (0.5, 0.5)), *stones, _rect((end_x0 + 0.25, 0.0), (0.5, 0.5))]
    return Terrain(name="stepping_stones", start_xy=(0.0, 0.0), goal_x=end_x0 + 0.15, regions=regions,
                   description="paper Fig. 2: 8 stepping stones (3 stars, 2 circles, 3 rectangles)")


def narrow_stones(bar_width_m: float | None = None, last_gap_m: float | None = None) -> Terrain:
    """The paper's Fig. 6 scene: start square, 3 narrow bars across the path, end square.

    The paper gives no dimensions, only "narrow", "different sizes", "unevenly spaced" and "the last
    stepping stone farthest from the previous". Ours: bars 4.5, 4 and 5 cm wide along x and 42, 50 and
    38 cm long along y, behind gaps of 7, 9 and 18 cm, then a 9 cm gap to the end square. "Narrow" is
    measured against the candidate grid: a bar narrower than the 5 cm candidate spacing plus twice the
    planner's 8 mm edge margin (6.6 cm) has, for part of the hip positions, no candidate of a given leg
    on it, so a leg whose turn it is may have no safe option, which is the situation the paper's Fig. 6
    is about. The acyclic ContactNet crosses it and the fixed cyclic gait falls; the map of bar width x
    last gap (`contactnet experiment narrow_map`, README) shows this is not a knife edge.

    ``bar_width_m`` makes all three bars that wide and ``last_gap_m`` sets the gap before the last bar
    (the map's two axes); the terrain is then named ``narrow_stones_w<cm>_g<cm>`` (the parts given).
    """
    widths = (0.045, 0.04, 0.05)
    gaps = [0.07, 0.09, 0.18]
    name = "narrow_stones"
    for label, value, low, high in (("bar_width_m", bar_width_m, 0.01, 0.2), ("last_gap_m", last_gap_m, 0.0, 0.4)):
        if value is not None and (not isinstance(value, numbers.Real) or isinstance(value, bool)
                                  or not low <= float(value) <= high):
            raise TerrainError(f"narrow_stones: {label} must be a number in [{low}, {high}] m, got {_show(value)}")
    if bar_width_m is not None:
        widths = (float(bar_width_m),) * 3
        name += f"_w{100 * widths[0]:g}"
    if last_gap_m is not None:
        gaps[2] = float(last_gap_m)
        name += f"_g{100 * gaps[2]:g}"
    lengths_y, centers_y = (0.42, 0.50, 0.38), (0.01, -0.01, 0.0)
    start_x1 = 0.25
    regions = [_rect((0.0, 0.0), (0.5, 0.5))]
    x = start_x1
    for gap, width, length, center_y in zip(gaps, widths, lengths_y, centers_y, strict=True):
        x += gap
        regions.append(_rect((round(x + 0.5 * width, 6), center_y), (width, length)))
        x += width
    end_x0 = round(x + 0.09, 6)
    regions.append(_rect((end_x0 + 0.25, 0.0), (0.5, 0.5)))
    return Terrain(name=name, start_xy=(0.0, 0.0), goal_x=end_x0 + 0.15, regions=regions,
                   description="paper Fig. 6: 3 narrow bars (narrower than the 5 cm candidate spacing), "
                               "unevenly spaced, the last gap the widest")


def push_field(seed: int = 0) -> Terrain:
    """Flat 4 x 2 m ground with random 10 x 10 cm holes (~15 % of the area) for the push experiment.

    No hole within the 0.6 x 0.6 m square around the start (0, 0); goal_x = 3 m.
    """
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool) or seed < 0:
        raise TerrainError(f"push_field: seed must be a non-negative integer, got {_show(seed)}")
    cell, cols, rows, origin_xy = 0.1, 40, 20, (-0.5, -1.0)
    col_index, row_index = np.meshgrid(np.arange(cols), np.arange(rows))
    cell_x0 = origin_xy[0] + cell * col_index
    cell_y0 = origin_xy[1] + cell * row_index
    keep_clear = (cell_x0 + cell > -0.3 + 1e-9) & (cell_x0 < 0.3 - 1e-9) & (cell_y0 + cell > -0.3 + 1e-9) & (
        cell_y0 < 0.3 - 1e-9)
    eligible = np.flatnonzero(~keep_clear.ravel())
    n_holes = round(0.15 * cols * rows)
    chosen = np.sort(np.random.default_rng(int(seed)).choice(eligible, size=n_holes, replace=False))
    removed = [[int(i % cols), int(i // cols)] for i in chosen]
    grid = {"shape": "grid", "origin": list(origin_xy), "cell": cell, "cols": cols, "rows": rows, "removed": removed}
    name = "push_field" if seed == 0 else f"push_field_{int(seed)}"
    return Terrain(name=name, start_xy=(0.0, 0.0), goal_x=3.0, regions=[grid],
                   description=f"4 x 2 m ground with {n_holes} random 10 x 10 cm holes (seed {int(seed)})")


_GENERATORS: Mapping[str, Callable[..., Terrain]] = MappingProxyType({
    "flat": flat, "narrow_stones": narrow_stones, "push_field": push_field, "stepping_stones": stepping_stones,
})


def by_name(name: str, removed: int | None = None, seed: int = 0) -> Terrain:
    """Generator by name: 'flat', 'random' (needs ``removed``), 'stepping_stones', 'narrow_stones', 'push_field'."""
    if name == "random":
        if removed is None:
            raise TerrainError("random: the random field needs 'removed' (number of squares to remove, 0..300)")
        return random_field(removed, seed)
    if name == "push_field":
        return push_field(seed)
    if name in _GENERATORS:
        return _GENERATORS[name]()
    raise TerrainError(f"unknown terrain generator {_show(name)}; expected one of: random, {', '.join(_GENERATORS)}")


def terrains_dir() -> Path:
    """Directory of the shipped terrain files: $CONTACTNET_TERRAINS, else <repo>/terrains."""
    override = os.environ.get("CONTACTNET_TERRAINS")
    return Path(override) if override else Path(__file__).resolve().parent.parent / "terrains"


def available() -> list[str]:
    """Sorted stems of the terrain files in :func:`terrains_dir`."""
    directory = terrains_dir()
    return sorted(p.stem for p in directory.glob("*.json")) if directory.is_dir() else []


def resolve(name_or_path: str | os.PathLike[str], removed: int | None = None, seed: int = 0) -> Terrain:
    """Terrain from a CLI argument: a .json path, 'random' (with ``removed``/``seed``), or a shipped name.

    Order: an existing file or a name ending in .json is loaded; 'random' builds the random field
    (and 'push_field' with a non-zero ``seed`` builds that field); ``<terrains_dir>/<name>.json`` is
    loaded; a generator name ('flat', ...) is generated; anything else raises TerrainError listing
    the available names.
    """
    text = os.fspath(name_or_path)
    if text.endswith(".json") or Path(text).is_file():
        return Terrain.load(text)
    if text == "random" or (text == "push_field" and seed != 0):
        return by_name(text, removed=removed, seed=seed)
    shipped = terrains_dir() / f"{text}.json"
    if shipped.is_file():
        return Terrain.load(shipped)
    if text in _GENERATORS:
        return by_name(text, seed=seed)
    names = sorted({*available(), *_GENERATORS, "random"})
    raise TerrainError(f"unknown terrain {_show(text)}: expected a .json path or one of: {', '.join(names)}")


SHIPPED: Mapping[str, Callable[[], Terrain]] = MappingProxyType({
    "flat": flat,
    "stepping_stones": stepping_stones,
    "narrow_stones": narrow_stones,
    "push_field": push_field,
    "random_80_0": lambda: random_field(80, 0),
})
"""File stem -> generator of the terrain files shipped in terrains/."""


# ---------------------------------------------------------------------------------------------
# Benchmark (formatted by benchmarks/bench_terrain.py)
# ---------------------------------------------------------------------------------------------
def benchmark_is_safe(repeats: int = 2000, margins: Sequence[float] = (0.0, 0.016),
                      sizes: Sequence[int] = (1, 100, 1000)) -> list[dict[str, Any]]:
    """Time ``is_safe`` against plain prepared-shapely ``contains_xy`` on the same geometry.

    Points are uniform in the terrain's bounds padded by 5 cm (seeded). One row per terrain, margin
    and batch size with median and p90 microseconds of each and ``speedup`` = shapely / is_safe
    (median).
    """
    rows: list[dict[str, Any]] = []
    rng = np.random.default_rng(0)
    for terrain in (random_field(80, 0), stepping_stones()):
        minx, miny, maxx, maxy = terrain.bounds
        for margin in margins:
            reference = shapely.from_wkb(shapely.to_wkb(terrain.safe_region(margin)))
            shapely.prepare(reference)
            for n_points in sizes:
                points_xy_world = rng.uniform((minx - 0.05, miny - 0.05), (maxx + 0.05, maxy + 0.05), (n_points, 2))
                x_world, y_world = points_xy_world[:, 0].copy(), points_xy_world[:, 1].copy()
                ours, theirs = _time_pair_us(partial(terrain.is_safe, points_xy_world, margin=margin),
                                             partial(shapely.contains_xy, reference, x_world, y_world), repeats)
                rows.append({
                    "terrain": terrain.name, "margin_m": float(margin), "n_points": int(n_points),
                    "is_safe_median_us": float(np.median(ours)), "is_safe_p90_us": float(np.percentile(ours, 90)),
                    "shapely_median_us": float(np.median(theirs)),
                    "shapely_p90_us": float(np.percentile(theirs, 90)),
                    "speedup": float(np.median(theirs) / np.median(ours)),
                })
    return rows


def _time_pair_us(first: Callable[[], Any], second: Callable[[], Any], repeats: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-call wall times (microseconds) of two calls, alternated so both see the same machine load."""
    for _ in range(min(20, repeats)):
        first()
        second()
    times_ns = np.empty((2, repeats))
    clock = time.perf_counter_ns
    for i in range(repeats):
        t0 = clock()
        first()
        t1 = clock()
        second()
        times_ns[0, i], times_ns[1, i] = t1 - t0, clock() - t1
    return times_ns[0] / 1e3, times_ns[1] / 1e3


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m contactnet.terrain [--out DIR]``: regenerate the shipped terrain files."""
    parser = argparse.ArgumentParser(prog="python -m contactnet.terrain", description=main.__doc__)
    parser.add_argument("--out", type=Path, default=None, help="output directory (default: terrains_dir())")
    args = parser.parse_args(argv)
    out_dir = args.out or terrains_dir()
    out_dir.mkdir(parents=True, exist_ok=True)
    for stem, generate in SHIPPED.items():
        terrain = generate()
        terrain.save(out_dir / f"{stem}.json")
        print(f"wrote {out_dir / f'{stem}.json'}  ({terrain.steppable.area:.3f} m^2 steppable)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
