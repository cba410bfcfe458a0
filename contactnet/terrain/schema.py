"""The terrain file format: limits, :class:`TerrainError` and strict validation of the JSON.

A terrain file (``terrains/*.json``) is one JSON object with ``name``, ``start``, ``goal_x``,
``regions`` and the optional ``description`` and ``surface_z`` (the nominal ground level; every
region's top is at it today). Every problem raises :class:`TerrainError` with a one-line message
that names the file and the field, e.g. ``terrains/bad.json: regions[3].size: expected ...``. This
module turns raw JSON values into normalized ones (floats, defaults filled in, sorted cells) and
back, and reads and writes the files (duplicate keys rejected; pretty, atomic writes). Of geometry
it knows only a region's bounds, for the extent check.
"""

from __future__ import annotations

import json
import math
import numbers
import os
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon

from contactnet.atomic import atomic_write_text

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
SHAPES = ("circle", "grid", "polygon", "rect", "star")
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
def show(value: Any, limit: int = 60) -> str:
    """Compact one-line rendering of a user value for an error message."""
    try:
        text = json.dumps(value.tolist() if isinstance(value, np.ndarray) else value)
    except (TypeError, ValueError):
        text = repr(value)
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


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
    if not is_number(value):
        return None
    try:
        result = float(value)
    except (OverflowError, ValueError):
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
        items = [finite_float(v) for v in value]
        if all(v is not None and lo <= v <= hi for v in items):
            return [float(v) for v in items]  # type: ignore[arg-type]
    raise field_error(source, path, f"expected {what}, got {show(value)}")


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
            raise field_error(source, path,
                              f"unknown key {show(key)}; allowed keys: {', '.join(sorted(allowed))}")
    for key in required:
        if key not in raw:
            raise field_error(source, f"{prefix}.{key}" if prefix else key, "missing required field")


def freeze(value: Any) -> Any:
    """Recursively turn dicts into read-only mappings and lists into tuples."""
    if isinstance(value, Mapping):
        return MappingProxyType({k: freeze(v) for k, v in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(freeze(v) for v in value)
    return value


def thaw(value: Any) -> Any:
    """Inverse of :func:`freeze`: plain dicts and lists for JSON."""
    if isinstance(value, Mapping):
        return {k: thaw(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [thaw(v) for v in value]
    return value


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
    parsed = [_parse_region(r, source, f"regions[{i}]") for i, r in enumerate(regions)]
    return start, goal, surface, parsed


def _parse_region(raw: Any, source: str, path: str) -> dict[str, Any]:
    """Validate one region and return it normalized (floats, defaults filled in, sorted cells)."""
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
        region["removed"] = _parse_removed(raw.get("removed", []), region["cols"], region["rows"], source,
                                           f"{path}.removed")
    minx, miny, maxx, maxy = _region_bounds(region)
    if min(minx, miny) < -MAX_ABS_COORD_M or max(maxx, maxy) > MAX_ABS_COORD_M:
        raise field_error(source, path, f"region extends beyond +-{MAX_ABS_COORD_M:g} m "
                                        f"(bounds {minx:.6g}, {miny:.6g}, {maxx:.6g}, {maxy:.6g})")
    return region


def _parse_removed(value: Any, cols: int, rows: int, source: str, path: str) -> list[list[int]]:
    if not isinstance(value, (list, tuple)):
        raise field_error(source, path, f"expected a list of [col, row] pairs, got {show(value)}")
    cells: set[tuple[int, int]] = set()
    for i, item in enumerate(value):
        ok = isinstance(item, (list, tuple)) and len(item) == 2 and all(
            isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_)) for v in item)
        if not ok or not (0 <= item[0] < cols and 0 <= item[1] < rows):
            raise field_error(source, f"{path}[{i}]",
                              f"expected [col, row] integers with col in 0..{cols - 1}, row in 0..{rows - 1}, "
                              f"got {show(item)}")
        cell = (int(item[0]), int(item[1]))
        if cell in cells:
            raise field_error(source, f"{path}[{i}]", f"duplicate cell {list(cell)}")
        cells.add(cell)
    return [list(c) for c in sorted(cells, key=lambda c: (c[1], c[0]))]


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
    if shape == "rect":
        corners_xy = rect_corners_xy(region["center"], region["size"], region["yaw"])
        return (float(corners_xy[:, 0].min()), float(corners_xy[:, 1].min()), float(corners_xy[:, 0].max()),
                float(corners_xy[:, 1].max()))
    (cx, cy), radius = region["center"], region.get("radius", region.get("outer_radius"))
    return cx - radius, cy - radius, cx + radius, cy + radius


# ---------------------------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------------------------
class _DuplicateKeyError(Exception):
    pass


def _reject_duplicate_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise _DuplicateKeyError(key)
        result[key] = value
    return result


def read_terrain_json(path: str | os.PathLike[str]) -> Any:
    """The JSON value of a terrain file (not yet validated); TerrainError naming ``path`` when unreadable.

    Rejects files over MAX_FILE_BYTES, non-UTF-8 text, invalid JSON (NaN and Infinity are read and
    rejected later as non-finite numbers) and objects with a duplicate key.
    """
    source = str(path)
    try:
        with open(path, "rb") as file:
            raw = file.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise field_error(source, "", f"cannot read file: {exc.strerror or exc}") from exc
    if len(raw) > MAX_FILE_BYTES:
        raise field_error(source, "", f"file is larger than {MAX_FILE_BYTES} bytes")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise field_error(source, "", f"not UTF-8 text (byte {exc.start})") from exc
    try:
        return json.loads(text, object_pairs_hook=_reject_duplicate_keys)
    except json.JSONDecodeError as exc:
        raise field_error(source, "",
                          f"not valid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})") from exc
    except RecursionError as exc:
        raise field_error(source, "", "not valid JSON: nested too deeply") from exc
    except _DuplicateKeyError as exc:
        raise field_error(source, "", f"duplicate key {show(exc.args[0])} in a JSON object") from exc


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
