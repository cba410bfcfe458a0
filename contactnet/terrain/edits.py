"""Terrain editing as pure functions on terrain dicts (the JSON form of `contactnet.terrain.Terrain`).

Every edit takes a terrain dict and returns a new, validated one (the input is never modified);
a change that would make the terrain invalid raises `EditError` with the terrain's own
one-line message. `EditHistory` adds undo. Nothing here knows about files, viser or the
browser: the web app (``app/live/editor.py`` for files, ``app/live/editing.py`` for the 3D view) turns clicks,
drags and uploads into these calls.

Holes. A terrain is a union of regions, so a punched square must leave every region that covers
it. We keep each region's kind where we can:
- a ``grid`` region loses the cells the square covers (its ``removed`` list grows): the paper's
  random field stays a grid, and a 5 cm punch in it removes exactly one cell;
- any other region (rect, circle, star, polygon) becomes ``polygon`` regions: its exact outline
  minus the square. The file format's polygons have no interior rings, so a hole strictly inside
  a region is represented by cutting the region in two along a vertical line through the hole
  (each half then has a notch instead of a hole; their union is exactly the punched shape).
  Converting such regions to a grid instead would quantize round stones to 5 cm squares.
Filling a square first restores removed cells of a grid it falls in, else adds a 5 x 5 cm rect.
Squares snap to the 5 cm world lattice (or to the cells of the grid region under the click), so
repeated punches tile without slivers.

Edits of the tops' heights (a stone's ``z``, a grid cell raised or lowered) are in
`contactnet.terrain.height_edits`.
"""

from __future__ import annotations

import copy
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon, box
from shapely.geometry.base import BaseGeometry

from contactnet.terrain.geometry import Terrain, region_geometry
from contactnet.terrain.scenes import SHIPPED
from contactnet.terrain.schema import TerrainError

__all__ = [
    "HOLE_SIZE_M",
    "MAX_UNDO",
    "SHIPPED_NAMES",
    "STONE_SHAPES",
    "EditError",
    "EditHistory",
    "TerrainDict",
    "add_stone",
    "delete_region",
    "fill_hole",
    "is_shipped",
    "move_region",
    "punch_hole",
    "region_at",
    "region_geometry",
    "region_pose",
    "renamed",
    "snap_square",
    "to_terrain",
    "validate_name",
    "validated",
]

HOLE_SIZE_M = 0.05
MIN_PIECE_AREA_M2 = 1e-7  # slivers smaller than this (0.3 x 0.3 mm) are dropped
MAX_UNDO = 100
STONE_SHAPES = ("rect", "circle", "star")
NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
SHIPPED_NAMES: frozenset[str] = frozenset(SHIPPED)

TerrainDict = dict[str, Any]


class EditError(ValueError):
    """An edit that cannot be done (the message says why, in one line)."""


# ---- names ---------------------------------------------------------------------------------------
def validate_name(name: str) -> str:
    """A terrain file stem: letters, digits, '_' and '-', 1..64 characters, no path separators."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise EditError(
            f"invalid terrain name {name!r}: use 1-64 letters, digits, '_' or '-' "
            "(starting with a letter or digit; no '/', '.' or spaces)"
        )
    return name


def is_shipped(name: str) -> bool:
    """Is ``name`` one of the terrain files shipped with contactnet (:data:`contactnet.terrain.SHIPPED`)?"""
    return name in SHIPPED_NAMES


# ---- validation --------------------------------------------------------------------------------
def validated(data: Mapping[str, Any], source: str = "<edit>") -> TerrainDict:
    """The normalized dict of a valid terrain; EditError (the terrain's message) otherwise."""
    return to_terrain(data, source).to_dict()


def to_terrain(data: Mapping[str, Any], source: str = "<edit>") -> Terrain:
    """The Terrain of a terrain dict; EditError (the terrain's message) when it is invalid."""
    try:
        return Terrain.from_dict(data, source=source)
    except TerrainError as exc:
        raise EditError(str(exc)) from None


def _with_regions(data: Mapping[str, Any], regions: list[dict[str, Any]]) -> TerrainDict:
    new = copy.deepcopy(dict(data))
    new["regions"] = regions
    return validated(new)


# ---- geometry helpers ----------------------------------------------------------------------------
def _grid_cell_of(region: Mapping[str, Any], xy: Sequence[float]) -> tuple[int, int] | None:
    (ox, oy), cell = region["origin"], region["cell"]
    col, row = math.floor((xy[0] - ox) / cell), math.floor((xy[1] - oy) / cell)
    if 0 <= col < region["cols"] and 0 <= row < region["rows"]:
        return col, row
    return None


def snap_square(data: Mapping[str, Any], xy: Sequence[float], size: float = HOLE_SIZE_M) -> tuple[float, ...]:
    """The square (minx, miny, maxx, maxy) an edit at xy acts on.

    Inside a grid region with cells of `size`: that grid's cell. Elsewhere: the cell of the world
    lattice of pitch `size` (origin at 0, 0).
    """
    _check_xy(xy)
    for region in reversed(data["regions"]):
        if region["shape"] == "grid" and abs(region["cell"] - size) < 1e-9:
            cell = _grid_cell_of(region, xy)
            if cell is not None:
                (ox, oy), pitch = region["origin"], region["cell"]
                return (
                    ox + cell[0] * pitch,
                    oy + cell[1] * pitch,
                    ox + (cell[0] + 1) * pitch,
                    oy + (cell[1] + 1) * pitch,
                )
    col, row = math.floor(xy[0] / size), math.floor(xy[1] / size)
    return (
        round(col * size, 9),
        round(row * size, 9),
        round((col + 1) * size, 9),
        round((row + 1) * size, 9),
    )


def _check_xy(xy: Sequence[float]) -> None:
    if len(xy) != 2 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in xy):
        raise EditError(f"expected a finite point [x, y], got {list(xy)!r}")


def _hole_free_parts(geometry: BaseGeometry) -> list[Polygon]:
    """Split a (multi)polygon into polygons without interior rings, with the same union.

    A polygon with holes is cut in two by a vertical line through its first hole; the cut turns
    that hole into a notch on both sides. Repeats until no piece has holes.
    """
    out: list[Polygon] = []
    stack = [g for g in shapely.get_parts(geometry) if isinstance(g, Polygon)]
    while stack:
        polygon = stack.pop()
        if polygon.is_empty or polygon.area < MIN_PIECE_AREA_M2:
            continue
        if not polygon.interiors:
            out.append(shapely.simplify(polygon, 0.0))
            continue
        cut_x = polygon.interiors[0].centroid.x
        minx, miny, maxx, maxy = polygon.bounds
        for half in (
            box(minx - 1.0, miny - 1.0, cut_x, maxy + 1.0),
            box(cut_x, miny - 1.0, maxx + 1.0, maxy + 1.0),
        ):
            stack.extend(g for g in shapely.get_parts(polygon.intersection(half)) if isinstance(g, Polygon))
    return out


def _polygon_region(polygon: Polygon, z: float | None = None) -> dict[str, Any]:
    """A polygon region of a hole-free polygon, its top at ``z`` (None: no ``z``, the terrain's surface)."""
    coords = np.asarray(polygon.exterior.coords)[:-1]
    region = {"shape": "polygon", "vertices": [[float(x), float(y)] for x, y in coords]}
    return region if z is None else {**region, "z": z}


# ---- edits -------------------------------------------------------------------------------------
def punch_hole(data: Mapping[str, Any], xy: Sequence[float], size: float = HOLE_SIZE_M) -> TerrainDict:
    """Remove the square at xy (see `snap_square`) from every region that covers part of it."""
    square = box(*snap_square(data, xy, size))
    regions: list[dict[str, Any]] = []
    changed = False
    for region in data["regions"]:
        region = copy.deepcopy(dict(region))
        geometry = region_geometry(region)
        if geometry.intersection(square).area <= 1e-12:
            regions.append(region)
            continue
        changed = True
        if region["shape"] == "grid":
            regions.append(_grid_without(region, square))
            continue
        regions.extend(_polygon_region(p, region.get("z")) for p in _hole_free_parts(geometry.difference(square)))
    if not changed:
        return validated(data)
    if not regions:
        raise EditError("this hole would remove the last steppable region")
    return _with_regions(data, regions)


def _grid_without(region: dict[str, Any], square: Polygon) -> dict[str, Any]:
    """The grid region without the cells whose interior overlaps the square."""
    (ox, oy), cell = region["origin"], region["cell"]
    minx, miny, maxx, maxy = square.bounds
    eps = 1e-9
    col0, col1 = (
        max(0, math.floor((minx - ox) / cell + eps)),
        min(region["cols"], math.ceil((maxx - ox) / cell - eps)),
    )
    row0, row1 = (
        max(0, math.floor((miny - oy) / cell + eps)),
        min(region["rows"], math.ceil((maxy - oy) / cell - eps)),
    )
    removed = {tuple(c) for c in region.get("removed", [])}
    removed.update((c, r) for c in range(col0, col1) for r in range(row0, row1))
    region["removed"] = [list(c) for c in sorted(removed, key=lambda c: (c[1], c[0]))]
    return region


def fill_hole(data: Mapping[str, Any], xy: Sequence[float], size: float = HOLE_SIZE_M) -> TerrainDict:
    """Make the square at xy steppable: restore a removed grid cell, else add a rect there."""
    x0, y0, x1, y1 = snap_square(data, xy, size)
    centre = ((x0 + x1) / 2, (y0 + y1) / 2)
    regions = copy.deepcopy(list(data["regions"]))
    for region in reversed(regions):
        if region["shape"] == "grid":
            cell = _grid_cell_of(region, centre)
            if cell is not None and list(cell) in region.get("removed", []):
                region["removed"] = [c for c in region["removed"] if list(c) != list(cell)]
                return _with_regions(data, regions)
    union = shapely.union_all([region_geometry(r) for r in regions])
    if union.covers(box(x0, y0, x1, y1)):
        return validated(data)
    regions.append(
        {
            "shape": "rect",
            "center": [round(c, 9) for c in centre],
            "size": [round(x1 - x0, 9), round(y1 - y0, 9)],
            "yaw": 0.0,
        }
    )
    return _with_regions(data, regions)


def add_stone(data: Mapping[str, Any], shape: str, xy: Sequence[float], yaw: float = 0.0) -> TerrainDict:
    """Add a stone of a default size (rect 12 x 10 cm, circle r 6 cm, 5-point star r 9/5 cm) at xy."""
    _check_xy(xy)
    centre = [float(xy[0]), float(xy[1])]
    if shape == "rect":
        stone = {"shape": "rect", "center": centre, "size": [0.12, 0.10], "yaw": float(yaw)}
    elif shape == "circle":
        stone = {"shape": "circle", "center": centre, "radius": 0.06}
    elif shape == "star":
        stone = {
            "shape": "star",
            "center": centre,
            "outer_radius": 0.09,
            "inner_radius": 0.05,
            "points": 5,
            "yaw": float(yaw),
        }
    else:
        raise EditError(f"unknown stone shape {shape!r}: choose one of {', '.join(STONE_SHAPES)}")
    return _with_regions(data, [*copy.deepcopy(list(data["regions"])), stone])


def region_at(data: Mapping[str, Any], xy: Sequence[float]) -> int | None:
    """Index of the region seen from above at xy: of the regions covering it, the one with the highest top
    (its ``z``, else the terrain's ``surface_z``), the last listed among equal tops; None when none covers it."""
    _check_xy(xy)
    surface_z = data.get("surface_z", 0.0)
    best: tuple[float, int] | None = None
    for index in range(len(data["regions"]) - 1, -1, -1):
        region = data["regions"][index]
        top_z = region.get("z", surface_z)
        if (best is None or top_z > best[0]) and shapely.intersects_xy(region_geometry(region), xy[0], xy[1]):
            best = (top_z, index)
    return None if best is None else best[1]


def region_pose(region: Mapping[str, Any]) -> tuple[tuple[float, float], float]:
    """((x, y) centre, yaw) of a region: its own centre and yaw where it has them."""
    shape = region["shape"]
    if shape in ("rect", "circle", "star"):
        return (float(region["center"][0]), float(region["center"][1])), float(region.get("yaw", 0.0))
    centroid = region_geometry(region).centroid
    return (float(centroid.x), float(centroid.y)), 0.0


def move_region(
    data: Mapping[str, Any], index: int, xy: Sequence[float], yaw: float | None = None
) -> TerrainDict:
    """Move region `index` so its centre is at xy (and turn it to `yaw` where it can turn)."""
    _check_xy(xy)
    regions = copy.deepcopy(list(data["regions"]))
    if not 0 <= index < len(regions):
        raise EditError(f"no region {index} (the terrain has {len(regions)})")
    region = regions[index]
    (cx, cy), old_yaw = region_pose(region)
    dx, dy = float(xy[0]) - cx, float(xy[1]) - cy
    shape = region["shape"]
    if shape in ("rect", "circle", "star"):
        region["center"] = [float(xy[0]), float(xy[1])]
        if yaw is not None and shape != "circle":
            region["yaw"] = float(yaw)
    elif shape == "polygon":
        turn = 0.0 if yaw is None else float(yaw) - old_yaw
        c, s = math.cos(turn), math.sin(turn)
        region["vertices"] = [
            [cx + dx + c * (x - cx) - s * (y - cy), cy + dy + s * (x - cx) + c * (y - cy)]
            for x, y in region["vertices"]
        ]
    else:  # grid: translate only
        region["origin"] = [region["origin"][0] + dx, region["origin"][1] + dy]
    return _with_regions(data, regions)


def delete_region(data: Mapping[str, Any], index: int) -> TerrainDict:
    """Remove region `index` (never the last one; the start must stay on steppable ground)."""
    regions = copy.deepcopy(list(data["regions"]))
    if not 0 <= index < len(regions):
        raise EditError(f"no region {index} (the terrain has {len(regions)})")
    if len(regions) == 1:
        raise EditError("cannot delete the last region: a terrain needs steppable ground")
    del regions[index]
    return _with_regions(data, regions)


def renamed(data: Mapping[str, Any], name: str) -> TerrainDict:
    """The terrain dict with its "name" set to `name` (checked by `validate_name`)."""
    new = copy.deepcopy(dict(data))
    new["name"] = validate_name(name)
    return validated(new)


# ---- undo --------------------------------------------------------------------------------------
class EditHistory:
    """The current terrain dict, the ones before it (undo) and the ones undone (redo), each bounded to
    `limit` steps. A new edit forgets what was undone, as in every editor."""

    def __init__(self, initial: Mapping[str, Any], limit: int = MAX_UNDO):
        self.current: TerrainDict = validated(initial)
        self._undo: list[TerrainDict] = []
        self._redo: list[TerrainDict] = []
        self.limit = limit

    def apply(self, new: Mapping[str, Any]) -> bool:
        """Make `new` current (remembering the old one); False when nothing changed."""
        new = dict(new)
        if new == self.current:
            return False
        self._undo.append(self.current)
        del self._undo[: max(0, len(self._undo) - self.limit)]
        self._redo.clear()
        self.current = new
        return True

    def undo(self) -> TerrainDict:
        previous = self.previous
        self._undo.pop()
        self._redo.append(self.current)
        self.current = previous
        return self.current

    def redo(self) -> TerrainDict:
        following = self.following
        self._redo.pop()
        self._undo.append(self.current)
        self.current = following
        return self.current

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    @property
    def previous(self) -> TerrainDict:
        """What `undo()` would make current."""
        if not self._undo:
            raise EditError("nothing to undo")
        return self._undo[-1]

    @property
    def following(self) -> TerrainDict:
        """What `redo()` would make current."""
        if not self._redo:
            raise EditError("nothing to redo")
        return self._redo[-1]

    def reset(self, data: Mapping[str, Any]) -> None:
        """Start over from `data` (a terrain loaded from a file): forget the undo and redo steps."""
        self.current = validated(data)
        self._undo.clear()
        self._redo.clear()
