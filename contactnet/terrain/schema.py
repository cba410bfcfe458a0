"""The terrain file format: limits, `TerrainError` and strict validation of the JSON.

A terrain file (``terrains/*.json``) is one JSON object with ``name``, ``start``, ``goal_x``,
``regions`` and the optional ``description`` and ``surface_z`` (the nominal ground level). Every region
may carry ``z``, the height of its flat top (default ``surface_z``, at most ``MAX_HEIGHT_OFFSET_M`` from
it); where regions overlap, the highest top wins; ``slope_deg`` makes it sloped (``contactnet.terrain.planes``).
Every problem raises `TerrainError` with a one-line message naming the file and the field, e.g.
``terrains/bad.json: regions[3].size: expected ...``. This module turns raw JSON values into normalized ones (floats, defaults filled in, sorted cells; a `Terrain` freezes them: ``contactnet.terrain.frozen``) and
back, and reads and writes the files (``contactnet.strict_json``: size, depth, number length and
duplicate keys limited; pretty, atomic writes). Of geometry it knows only a region's bounds, for the
extent check, and how many outline vertices a region has, for the complexity budget.

The complexity budget (the ``MAX_*`` limits below) holds for every terrain that validates, so that
whatever validates also validates fast (well under a second), simulates and renders: the input-side
limits are checked here while parsing, the ones on the steppable union (outline vertices of grids,
edge contacts between regions, mesh faces) by ``contactnet.terrain.union``, the ones on the tops of
a terrain with several heights (``MAX_LEVEL_*``, mesh faces) by ``contactnet.terrain.levels``.
"""

from __future__ import annotations

import json
import math
import numbers
import os
from collections.abc import Mapping, Sequence
from dataclasses import replace
from itertools import chain
from types import MappingProxyType
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon

from contactnet.atomic import atomic_write_text
from contactnet.strict_json import JsonInputError, JsonLimits, loads_strict
from contactnet.terrain.planes import SLOPE_KEYS, parse_slope

# ---------------------------------------------------------------------------------------------
# Limits and constants (immutable)
# ---------------------------------------------------------------------------------------------
MAX_ABS_COORD_M = 1000.0
"""Every coordinate and every region's extent must lie within +-this (metres)."""
MIN_SIZE_M = 1e-3
"""Smallest accepted size, radius or grid cell (metres)."""
MAX_SIZE_M = 1000.0
"""Largest accepted size or radius (metres)."""
# The complexity budget: every terrain that validates respects all of these.
MAX_REGIONS = 10_000
"""Regions in one terrain."""
MAX_GRID_REGIONS = 100
"""Grid regions in one terrain (each is traced on its own; the paper's fields are one grid each)."""
MAX_GRID_CELLS = 250_000
"""Cells (cols x rows, removed ones included) of one grid region, and of all grid regions of a terrain
together (a 500 x 500 grid of 2.5 cm cells is 12.5 x 12.5 m)."""
MAX_POLYGON_VERTICES = 10_000
"""Vertices of one polygon region."""
MAX_OUTLINE_VERTICES = 100_000
"""Outline vertices of all regions together, before they are united: 4 per rect, a circle's segments
(``circle_segments``), 2 per star point, a polygon's vertices and the corners of a grid's present cells
(a 500 x 500 grid with 20,000 random cells removed has about 68,000)."""
MAX_EDGE_CONTACTS = 50_000
"""Pairs of outline edges of different regions that cross or touch. Each adds up to two vertices to
the union, and their number grows with the product of the regions' vertices when detailed regions
overlap (two overlapping combs of 1,000 vertices cross a million times)."""
MAX_MESH_FACES = 400_000
"""Triangles of the terrain's mesh (``Terrain.mesh``, what the simulator and the browser load),
counted from the steppable outline: 4 per outline vertex and 4 per hole (the 500 x 500 grid above:
340,000 by this count, 270,000 in fact). The simulator cuts meshes into chunks PyBullet takes."""
CONTACT_CHECK_MAX_PIECES = 500_000
"""Counting edge contacts cuts the edges into pieces no longer than the extent / sqrt(edges); outlines
that need more pieces (kilometres of edges, e.g. thousands of huge overlapping regions or combs with
long teeth; the 500 x 500 grid above needs 130,000) are refused."""
CONTACT_CHECK_MAX_CANDIDATES = 500_000
"""Pairs of edges of different regions that lie in the same cell of the contact check's grid (each is
tested exactly); more are refused without testing them."""
MAX_FILE_BYTES = 16 * 1024 * 1024
"""Largest terrain file or JSON document (a terrain at every limit above needs about 10 MB)."""
TERRAIN_JSON_LIMITS = JsonLimits(max_bytes=MAX_FILE_BYTES, max_depth=8, max_values=2_000_000,
                                 max_number_chars=40)
"""How terrain JSON is read (``contactnet.strict_json``): a terrain nests 5 levels deep (object, regions,
region, vertices, vertex) and needs about 1.2 million values at most."""
MAX_LEVEL_PAIRS = 200_000
"""Tops at several heights: pairs of parts (of the unions at each height) whose bounding boxes overlap."""
MAX_LEVEL_CUT_VERTICES = 200_000
"""Tops at several heights: outline vertices of the higher parts that cut each height's union, summed."""
MAX_HEIGHT_OFFSET_M = 0.5
"""A region's top ``z`` lies within +-this of the terrain's ``surface_z`` (metres)."""
CIRCLE_MAX_ERROR_M = 5e-4
"""Largest distance between a circle and its inscribed polygon (metres)."""
CIRCLE_MIN_SEGMENTS = 64
STAR_POINTS_RANGE = (3, 64)
SHAPES = ("circle", "grid", "polygon", "rect", "star")
_TOP_LEVEL_KEYS = ("name", "description", "start", "goal_x", "surface_z", "regions")
_REQUIRED_TOP_LEVEL = ("name", "start", "goal_x", "regions")
_REGION_KEYS: Mapping[str, tuple[tuple[str, ...], tuple[str, ...]]] = MappingProxyType(
    {  # shape -> (required keys, optional keys); "shape" itself is implied
        "rect": (("center", "size"), ("yaw", "z", *SLOPE_KEYS)),
        "circle": (("center", "radius"), ("z", *SLOPE_KEYS)),
        "star": (("center", "outer_radius", "inner_radius", "points"), ("yaw", "z", *SLOPE_KEYS)),
        "polygon": (("vertices",), ("z", *SLOPE_KEYS)),
        "grid": (("origin", "cell", "cols", "rows"), ("removed", "z", *SLOPE_KEYS)),
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
def show(value: Any, limit: int = 60) -> str:
    """Compact one-line rendering of a user value for an error message (JSON-like, at most ``limit`` chars).

    Safe and cheap for any value: only the first ``limit`` characters' worth of a value is rendered (a
    list of a million items or nested ten thousand deep costs nothing), an integer too long to print
    is described by its number of digits, and objects that cannot be rendered show their type.
    """
    parts: list[str] = []
    _render_value(value, parts, limit + 1)
    text = " ".join("".join(parts).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _render_value(value: Any, out: list[str], budget: int) -> int:
    """Append the rendering of ``value`` to ``out`` until about ``budget`` characters; returns what is left."""
    if budget <= 0:
        return 0
    if value is None or isinstance(value, (bool, np.bool_)):
        text = "null" if value is None else ("true" if value else "false")
    elif isinstance(value, numbers.Integral):
        number = int(value)
        if number.bit_length() > 200:  # str() of a huge int is slow and refused beyond 4,300 digits
            text = f"<an integer of about {int(number.bit_length() * math.log10(2)) + 1} digits>"
        else:
            text = str(number)
    elif isinstance(value, numbers.Real):
        try:
            text = json.dumps(float(value))
        except (OverflowError, TypeError, ValueError):
            text = f"<{type(value).__name__}>"
    elif isinstance(value, str):
        text = json.dumps(value[:budget]) + ("..." if len(value) > budget else "")
    elif isinstance(value, (Mapping, list, tuple, np.ndarray)):
        return _render_container(value, out, budget)
    else:
        text = f"<{type(value).__name__}>"
    out.append(text[: budget + 3])
    return budget - len(text)


def _render_container(value: Any, out: list[str], budget: int) -> int:
    is_mapping = isinstance(value, Mapping)
    if isinstance(value, np.ndarray):
        value = value.ravel()[:budget].tolist() if value.ndim <= 1 else list(value[:budget])
    out.append("{" if is_mapping else "[")
    budget -= 1
    try:
        items = iter(value.items() if is_mapping else value)
        for index, item in enumerate(items):
            if budget <= 0:
                break
            if index:
                out.append(", ")
                budget -= 2
            if is_mapping:
                key, item = item
                budget = _render_value(key, out, budget)
                out.append(": ")
                budget -= 2
            budget = _render_value(item, out, budget)
    except Exception:  # noqa: BLE001 - a hostile container; what was rendered so far is enough
        pass
    out.append("}" if is_mapping else "]")
    return budget - 1


def field_error(source: str, path: str, message: str) -> TerrainError:
    """The TerrainError ``source: path: message`` (either prefix left out when empty)."""
    prefix = f"{source}: " if source else ""
    where = f"{path}: " if path else ""
    return TerrainError(f"{prefix}{where}{message}", source=source, field_path=path)


def is_number(value: Any) -> bool:
    """A real number that is not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def finite_float(value: Any) -> float | None:
    """``float(value)`` when value is a finite real number (not bool), else None."""
    if type(value) is float:  # the usual case, first: JSON numbers with a fraction
        return value if math.isfinite(value) else None
    if not is_number(value):
        return None
    try:
        result = float(value)
    except (OverflowError, TypeError, ValueError):
        return None
    return result if math.isfinite(result) else None


def _number(value: Any, source: str, path: str, lo: float, hi: float, what: str) -> float:
    result = finite_float(value)
    if result is None or not lo <= result <= hi:
        raise field_error(source, path, f"expected {what}, got {show(value)}")
    return result


def _integer(value: Any, source: str, path: str, lo: int, hi: int) -> int:
    if not isinstance(value, numbers.Integral) or isinstance(value, (bool, np.bool_)) or not lo <= value <= hi:
        raise field_error(source, path, f"expected an integer in {lo}..{hi}, got {show(value)}")
    return int(value)


def _pair(value: Any, source: str, path: str, lo: float, hi: float, what: str) -> list[float]:
    """Two finite numbers in [lo, hi] given as a JSON array."""
    if isinstance(value, (list, tuple, np.ndarray)) and len(value) == 2:
        first, second = finite_float(value[0]), finite_float(value[1])
        if first is not None and second is not None and lo <= first <= hi and lo <= second <= hi:
            return [float(first), float(second)]
    raise field_error(source, path, f"expected {what}, got {show(value)}")


def _coords(value: Any, source: str, path: str) -> list[float]:
    return _pair(value, source, path, -MAX_ABS_COORD_M, MAX_ABS_COORD_M,
                 f"[x, y] with 2 finite numbers in [-{MAX_ABS_COORD_M:g}, {MAX_ABS_COORD_M:g}]")


def _size(value: Any, source: str, path: str, what: str = "a size") -> float:
    return _number(value, source, path, MIN_SIZE_M, MAX_SIZE_M,
                   f"{what} in [{MIN_SIZE_M:g}, {MAX_SIZE_M:g}] m")


def circle_segments(radius_m: float) -> int:
    """Segments of a circle's inscribed polygon, within CIRCLE_MAX_ERROR_M of the circle."""
    if radius_m <= CIRCLE_MAX_ERROR_M:
        return CIRCLE_MIN_SEGMENTS
    return max(CIRCLE_MIN_SEGMENTS, math.ceil(math.pi / math.acos(1.0 - CIRCLE_MAX_ERROR_M / radius_m)))


def outline_vertex_count(region: Mapping[str, Any]) -> int:
    """Outline vertices of a normalized region that is not a grid (a grid's depend on its removed cells)."""
    shape = region["shape"]
    if shape == "rect":
        return 4
    if shape == "circle":
        return circle_segments(region["radius"])
    if shape == "star":
        return 2 * region["points"]
    if shape == "polygon":
        return len(region["vertices"])
    raise ValueError(f"the outline of a {shape} region is counted from its cells")


def _check_keys(raw: Mapping[str, Any], allowed: Sequence[str], required: Sequence[str], source: str,
                prefix: str) -> None:
    """Reject unknown keys (naming them) and missing required keys."""
    for key in raw:
        if key not in allowed:
            name = key if isinstance(key, str) and len(key) <= 40 and key.isprintable() else show(key, 40)
            path = f"{prefix}.{name}" if prefix else name
            raise field_error(source, path,
                              f"unknown key {show(key)}; allowed keys: {', '.join(sorted(allowed))}")
    for key in required:
        if key not in raw:
            raise field_error(source, f"{prefix}.{key}" if prefix else key, "missing required field")


# ---------------------------------------------------------------------------------------------
# Top level and regions: raw JSON -> normalized values
# ---------------------------------------------------------------------------------------------
def check_top_level(data: Any, source: str) -> None:
    """``data`` is a JSON object with the allowed top-level keys and all required ones."""
    if not isinstance(data, Mapping):
        raise field_error(source, "", f"expected a JSON object at the top level, got {show(data)}")
    _check_keys(data, _TOP_LEVEL_KEYS, _REQUIRED_TOP_LEVEL, source, "")


def parse_fields(name: Any, description: Any, start_xy: Any, goal_x: Any, surface_z: Any, regions: Any,
                 source: str) -> tuple[np.ndarray, float, float, list[dict[str, Any]]]:
    """Validate a terrain's fields in file order; returns (read-only start (2,), goal_x, surface_z, regions).

    Error messages use the file's field names (``start`` for ``start_xy``). What needs the geometry
    (the start on steppable ground, the goal beyond it) is checked by the terrain itself.
    """
    if not isinstance(name, str) or not name.strip() or len(name) > 200 or "\n" in name:
        raise field_error(source, "name",
                          f"expected a non-empty one-line string (<= 200 chars), got {show(name)}")
    if not isinstance(description, str):
        raise field_error(source, "description", f"expected a string, got {show(description)}")
    start = np.array(_coords(start_xy, source, "start"))
    start.flags.writeable = False
    goal = _number(goal_x, source, "goal_x", -MAX_ABS_COORD_M, MAX_ABS_COORD_M,
                   f"a finite number in [-{MAX_ABS_COORD_M:g}, {MAX_ABS_COORD_M:g}]")
    surface = _number(surface_z, source, "surface_z", -MAX_ABS_COORD_M, MAX_ABS_COORD_M,
                      f"a finite number in [-{MAX_ABS_COORD_M:g}, {MAX_ABS_COORD_M:g}]")
    if not isinstance(regions, (list, tuple)):
        raise field_error(source, "regions", f"expected a list of regions, got {show(regions)}")
    if not regions:
        raise field_error(source, "regions", "expected at least one region, got an empty list")
    if len(regions) > MAX_REGIONS:
        raise field_error(source, "regions", f"expected at most {MAX_REGIONS} regions, got {len(regions)}")
    parsed: list[dict[str, Any]] = []
    budget = _Budget(source)
    for i, raw in enumerate(regions):
        parsed.append(_parse_region(raw, source, f"regions[{i}]", budget, surface))
    return start, goal, surface, parsed


class _Budget:
    """Running totals of the input-side limits, checked before each region's bulk (vertices, cells) is read."""

    def __init__(self, source: str):
        self.source = source
        self.outline_vertices = 0
        self.grids = 0
        self.grid_cells = 0

    def add_outline(self, count: int, path: str) -> None:
        self.outline_vertices += count
        if self.outline_vertices > MAX_OUTLINE_VERTICES:
            raise field_error(self.source, path, f"the regions up to here have {self.outline_vertices} outline "
                                                 f"vertices; the limit is {MAX_OUTLINE_VERTICES}")

    def add_cells(self, count: int, path: str) -> None:
        self.grids += 1
        if self.grids > MAX_GRID_REGIONS:
            raise field_error(self.source, path.rpartition(".")[0], f"the regions up to here have {self.grids} "
                                                                    f"grids; the limit is {MAX_GRID_REGIONS}")
        self.grid_cells += count
        if self.grid_cells > MAX_GRID_CELLS:
            raise field_error(self.source, path, f"the grids up to here have {self.grid_cells} cells; "
                                                 f"the limit is {MAX_GRID_CELLS}")


def _parse_region(raw: Any, source: str, path: str, budget: _Budget | None = None,
                  surface_z: float = 0.0) -> dict[str, Any]:
    """Validate one region and return it normalized (floats, defaults filled in, sorted cells; ``z`` if given)."""
    if not isinstance(raw, Mapping):
        raise field_error(source, path, f"expected an object with a 'shape', got {show(raw)}")
    if "shape" not in raw:
        raise field_error(source, f"{path}.shape", "missing required field")
    shape = raw["shape"]
    if not isinstance(shape, str) or shape not in _REGION_KEYS:
        raise field_error(source, f"{path}.shape",
                          f"unknown shape {show(shape)}; expected one of {', '.join(SHAPES)}")
    required, optional = _REGION_KEYS[shape]
    _check_keys(raw, ("shape", *required, *optional), required, source, path)
    budget = budget or _Budget(source)

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
            raise field_error(source, f"{path}.inner_radius",
                              f"must be smaller than outer_radius ({region['outer_radius']:g}), "
                              f"got {region['inner_radius']:g}")
    elif shape == "polygon":
        vertices = raw["vertices"]
        if not isinstance(vertices, (list, tuple)) or not 3 <= len(vertices) <= MAX_POLYGON_VERTICES:
            count = len(vertices) if isinstance(vertices, (list, tuple)) else show(vertices)
            raise field_error(source, f"{path}.vertices",
                              f"expected a list of 3..{MAX_POLYGON_VERTICES} [x, y] vertices, got {count}")
        budget.add_outline(len(vertices), path)
        region["vertices"] = [_coords(v, source, f"{path}.vertices[{i}]") for i, v in enumerate(vertices)]
        polygon = Polygon(region["vertices"])
        if not polygon.is_valid:
            reason = shapely.is_valid_reason(polygon)
            raise field_error(source, f"{path}.vertices", f"polygon is not simple ({reason})")
        if polygon.area <= 1e-12:
            raise field_error(source, f"{path}.vertices", "polygon has zero area")
    else:  # grid
        region["origin"] = _coords(raw["origin"], source, f"{path}.origin")
        region["cell"] = _size(raw["cell"], source, f"{path}.cell", "a cell size")
        region["cols"] = _integer(raw["cols"], source, f"{path}.cols", 1, MAX_GRID_CELLS)
        region["rows"] = _integer(raw["rows"], source, f"{path}.rows", 1, MAX_GRID_CELLS)
        if region["cols"] * region["rows"] > MAX_GRID_CELLS:
            raise field_error(source, f"{path}.cols",
                              f"cols * rows = {region['cols'] * region['rows']} exceeds {MAX_GRID_CELLS}")
        budget.add_cells(region["cols"] * region["rows"], f"{path}.rows")
        region["removed"] = _parse_removed(raw.get("removed", []), region["cols"], region["rows"], source,
                                           f"{path}.removed")
    if shape != "grid":
        budget.add_outline(0 if shape == "polygon" else outline_vertex_count(region), path)
    if "z" in raw:
        low, high = surface_z - MAX_HEIGHT_OFFSET_M, surface_z + MAX_HEIGHT_OFFSET_M
        region["z"] = _number(raw["z"], source, f"{path}.z", low, high, f"a finite top height within "
                              f"{MAX_HEIGHT_OFFSET_M:g} m of surface_z ({surface_z:g}), in [{low:g}, {high:g}] m")
    minx, miny, maxx, maxy = _region_bounds(region)
    if min(minx, miny) < -MAX_ABS_COORD_M or max(maxx, maxy) > MAX_ABS_COORD_M:
        raise field_error(source, path, f"region extends beyond +-{MAX_ABS_COORD_M:g} m "
                                        f"(bounds {minx:.6g}, {miny:.6g}, {maxx:.6g}, {maxy:.6g})")
    problem = parse_slope(raw, region, surface_z, (minx, miny, maxx, maxy), MAX_HEIGHT_OFFSET_M)  # a sloped top
    if problem is not None:
        raise field_error(source, f"{path}.{problem[0]}", problem[1] + "".join(f", got {show(v)}" for v in problem[2:]))
    return region


def _parse_removed(value: Any, cols: int, rows: int, source: str, path: str) -> list[list[int]]:
    """The removed cells as [col, row] lists sorted by (row, col): linear in the cells, vectorized when they
    are all pairs of integers (the usual case), checked one by one otherwise to name the first bad one."""
    if not isinstance(value, (list, tuple)):
        raise field_error(source, path, f"expected a list of [col, row] pairs, got {show(value)}")
    if len(value) > cols * rows:
        raise field_error(source, path, f"expected at most cols * rows = {cols * rows} distinct cells, "
                                        f"got {len(value)}")
    cells = _int_pairs(value)
    if cells is not None:
        col, row = cells[:, 0], cells[:, 1]
        inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
        keys = np.where(inside, col + cols * row, -1)
        unique, first_index = np.unique(keys, return_index=True)
        repeated = np.ones(len(keys), dtype=bool)
        repeated[first_index] = False
        bad = min(np.flatnonzero(~inside).min(initial=len(keys)), np.flatnonzero(repeated).min(initial=len(keys)))
        if bad == len(keys):
            return np.column_stack([unique % cols, unique // cols]).tolist()
        value = value[: bad + 1]  # the loop below names the first bad cell
    seen: set[tuple[int, int]] = set()
    for i, item in enumerate(value):
        ok = isinstance(item, (list, tuple)) and len(item) == 2 and all(_is_int(v) for v in item)
        if not ok or not (0 <= item[0] < cols and 0 <= item[1] < rows):
            raise field_error(source, f"{path}[{i}]",
                              f"expected [col, row] integers with col in 0..{cols - 1}, row in 0..{rows - 1}, "
                              f"got {show(item)}")
        cell = (int(item[0]), int(item[1]))
        if cell in seen:
            raise field_error(source, f"{path}[{i}]", f"duplicate cell {list(cell)}")
        seen.add(cell)
    return [list(c) for c in sorted(seen, key=lambda c: (c[1], c[0]))]


def _is_int(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _int_pairs(value: Sequence[Any]) -> np.ndarray | None:
    """(n, 2) int64 array when every item is a list or tuple of two integers (not bools) that fit, else None.

    Checked with C-level passes (the sets of item types, lengths and element types), not a Python loop.
    """
    if not value:
        return np.zeros((0, 2), dtype=np.int64)
    if not set(map(type, value)) <= {list, tuple} or set(map(len, value)) != {2}:
        return None
    if not all(kind is int or issubclass(kind, np.integer) for kind in set(map(type, chain.from_iterable(value)))):
        return None
    try:
        return np.array(value, dtype=np.int64)
    except OverflowError:
        return None


def rect_corners_xy(center: Sequence[float], size: Sequence[float], yaw: float) -> np.ndarray:
    """Corners (4, 2), counter-clockwise, of a ``rect`` region (``size`` turned by ``yaw`` about ``center``)."""
    half_x, half_y = 0.5 * size[0], 0.5 * size[1]
    local_xy = np.array([[-half_x, -half_y], [half_x, -half_y], [half_x, half_y], [-half_x, half_y]])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.asarray(center) + local_xy @ np.array([[c, s], [-s, c]])


def _region_bounds(region: Mapping[str, Any]) -> tuple[float, float, float, float]:
    """Axis-aligned bounds of a normalized region (a cheap superset for the extent check)."""
    shape = region["shape"]
    if shape == "grid":
        (ox, oy), cell = region["origin"], region["cell"]
        return ox, oy, ox + cell * region["cols"], oy + cell * region["rows"]
    if shape == "polygon":
        xy = np.asarray(region["vertices"], dtype=float)
        return float(xy[:, 0].min()), float(xy[:, 1].min()), float(xy[:, 0].max()), float(xy[:, 1].max())
    if shape == "rect":  # the turned rect's half extents, without building its corners
        (cx, cy), (sx, sy), yaw = region["center"], region["size"], region["yaw"]
        c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
        half_x, half_y = 0.5 * (sx * c + sy * s), 0.5 * (sx * s + sy * c)
        return cx - half_x, cy - half_y, cx + half_x, cy + half_y
    (cx, cy), radius = region["center"], region.get("radius", region.get("outer_radius"))
    return cx - radius, cy - radius, cx + radius, cy + radius


# ---------------------------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------------------------
def read_terrain_json(path: str | os.PathLike[str]) -> Any:
    """The JSON value of a terrain file (not yet validated); TerrainError naming ``path`` when unreadable.

    Rejects files over MAX_FILE_BYTES and what `loads_terrain_json` rejects.
    """
    source = str(path)
    try:
        with open(path, "rb") as file:
            raw = file.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise field_error(source, "", f"cannot read file: {exc.strerror or exc}") from exc
    if len(raw) > MAX_FILE_BYTES:
        raise field_error(source, "", f"file is larger than {MAX_FILE_BYTES} bytes")
    return loads_terrain_json(raw, source)


def loads_terrain_json(content: bytes | str, source: str = "<json>", max_bytes: int = MAX_FILE_BYTES) -> Any:
    """The JSON value of a terrain document (a file's or an upload's bytes), not yet validated.

    Read with ``TERRAIN_JSON_LIMITS`` (at most ``max_bytes``): more bytes, text that is not UTF-8,
    invalid JSON, nesting deeper than a terrain needs, too many values, a number of more than 40
    characters (Python refuses integers of more than 4,300 digits) and objects with a duplicate key
    raise a one-line TerrainError naming ``source``. NaN and Infinity are read, and rejected by the
    validation as non-finite numbers naming their field.
    """
    limits = replace(TERRAIN_JSON_LIMITS, max_bytes=min(max_bytes, TERRAIN_JSON_LIMITS.max_bytes))
    try:
        return loads_strict(content, source, limits)
    except JsonInputError as exc:
        raise TerrainError(str(exc), source=source) from None


def write_terrain_json(data: Mapping[str, Any], path: str | os.PathLike[str]) -> None:
    """Write pretty JSON (2-space indent) atomically (``contactnet.atomic``): readers see the old file or the
    new one, never half of one."""
    atomic_write_text(path, pretty_json(data) + "\n")


def pretty_json(value: Any, indent: int = 2, level: int = 0, width: int = 100) -> str:
    """JSON with 2-space indent where short arrays of scalars (and of short arrays) stay on one line."""
    inline = json.dumps(value, allow_nan=False)
    pad, inner = " " * (indent * level), " " * (indent * (level + 1))
    if isinstance(value, dict) and value:
        items = [f"{inner}{json.dumps(k)}: {pretty_json(v, indent, level + 1, width).lstrip()}"
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
        items = [pretty_json(v, indent, level + 1, width) for v in value]
        return pad + "[\n" + ",\n".join(items) + "\n" + pad + "]"
    return pad + inline
