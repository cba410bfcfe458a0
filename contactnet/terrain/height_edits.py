"""Height edits: pure functions that change the tops of a terrain dict (its regions' ``z``).

Like the edits of `contactnet.terrain.edits`, each takes a terrain dict and returns a new,
validated one (the input is never modified), or raises `contactnet.terrain.edits.EditError`
with a one-line message naming the field (``regions[3].z``).

- `set_region_height` puts one region's top (a selected stone, a platform, a whole grid) at a
  height;
- `raise_cell` raises or lowers the one grid cell under a point: a cell of a ``grid`` region is
  cut out of the grid (its ``removed`` list grows, as `contactnet.terrain.edits.punch_hole` does)
  and comes back as a cell-sized ``rect`` with its own ``z``; a region that already is one cell-sized
  rect (the squares of ``random_heights``, a filled hole) just gets a new ``z``. Bigger regions (a
  platform, a stone) are refused: their whole top moves with `set_region_height`.

Heights are world z in metres; the schema's bound applies (``|z - surface_z| <= MAX_HEIGHT_OFFSET_M``),
and new heights are rounded to the micrometre so repeated steps of 1 cm stay exact in the file.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

from contactnet.terrain.edits import (
    HOLE_SIZE_M,
    EditError,
    TerrainDict,
    _check_xy,
    _grid_cell_of,
    _with_regions,
    region_at,
    validated,
)
from contactnet.terrain.schema import MAX_HEIGHT_OFFSET_M, finite_float

__all__ = ["HEIGHT_DIGITS", "cell_square", "raise_cell", "region_top_z", "set_region_height"]

HEIGHT_DIGITS = 6
"""New heights are rounded to this many decimals of a metre (a micrometre)."""
_SIZE_TOLERANCE_M = 1e-9


def region_top_z(data: Mapping[str, Any], index: int) -> float:
    """World z (metres) of region ``index``'s top: its ``z``, else the terrain's ``surface_z``."""
    regions = data["regions"]
    if not 0 <= index < len(regions):
        raise EditError(f"no region {index} (the terrain has {len(regions)})")
    return float(regions[index].get("z", data.get("surface_z", 0.0)))


def _checked_top(data: Mapping[str, Any], index: int, z_m: Any) -> float:
    """``z_m`` as a float within the schema's bound for region ``index``; EditError naming the field."""
    surface_z = float(data.get("surface_z", 0.0))
    z = finite_float(z_m)
    if z is None:
        raise EditError(f"regions[{index}].z: expected a finite height in metres, got {z_m!r}")
    z = round(z, HEIGHT_DIGITS) + 0.0  # + 0.0: no -0.0 in the file
    low, high = surface_z - MAX_HEIGHT_OFFSET_M, surface_z + MAX_HEIGHT_OFFSET_M
    if not low <= z <= high:
        raise EditError(
            f"regions[{index}].z: {z:+.3f} m is out of range: a top lies within {MAX_HEIGHT_OFFSET_M:g} m of "
            f"surface_z ({surface_z:g}), in [{low:g}, {high:g}] m"
        )
    return z


def set_region_height(data: Mapping[str, Any], index: int, z_m: float) -> TerrainDict:
    """Put region ``index``'s top at world height ``z_m`` (metres); everything else stays as it was.

    A region without ``z`` asked to stay at ``surface_z`` is left without one (nothing changes).
    """
    regions = copy.deepcopy(list(data["regions"]))
    region_top_z(data, index)  # the index exists, or EditError
    z = _checked_top(data, index, z_m)
    region = regions[index]
    if "z" not in region and z == float(data.get("surface_z", 0.0)):
        return validated(data)
    region["z"] = z
    return _with_regions(data, regions)


def _is_cell_rect(region: Mapping[str, Any], size: float = HOLE_SIZE_M) -> bool:
    """Is this region one grid cell: a rect no bigger than ``size`` on either side?"""
    return region["shape"] == "rect" and all(side <= size + _SIZE_TOLERANCE_M for side in region["size"])


def cell_square(data: Mapping[str, Any], xy: Sequence[float]) -> tuple[int, tuple[float, float, float, float]]:
    """(index of the region, (minx, miny, maxx, maxy)) of the grid cell `raise_cell` at ``xy`` acts on.

    The region seen from above at ``xy`` (`contactnet.terrain.edits.region_at`) must be a ``grid``
    (the square is its cell under ``xy``) or a cell-sized ``rect`` (the square is its bounding box);
    anything else raises EditError saying what to do instead.
    """
    _check_xy(xy)
    index = region_at(data, xy)
    where = f"({xy[0]:.3f}, {xy[1]:.3f})"
    if index is None:
        raise EditError(f"no ground at {where}: raise or lower a cell of a grid or a 5 cm square")
    region = data["regions"][index]
    if region["shape"] == "grid":
        cell = _grid_cell_of(region, xy)
        if cell is None or list(cell) in region.get("removed", []):
            raise EditError(f"no grid cell at {where}: click inside a cell")
        (ox, oy), pitch = region["origin"], region["cell"]
        return index, (ox + cell[0] * pitch, oy + cell[1] * pitch, ox + (cell[0] + 1) * pitch,
                       oy + (cell[1] + 1) * pitch)
    if _is_cell_rect(region):
        (cx, cy), (sx, sy) = region["center"], region["size"]
        return index, (cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2)
    raise EditError(
        f"region {index} ({region['shape']}) at {where} is not a grid cell: "
        "select it and set its stone height instead"
    )


def raise_cell(data: Mapping[str, Any], xy: Sequence[float], delta_m: float) -> TerrainDict:
    """Raise (``delta_m`` > 0) or lower the top of the grid cell under ``xy`` by ``delta_m`` metres.

    On a ``grid`` region the cell leaves the grid and is added back, last, as a cell-sized ``rect`` with
    the new ``z``; on a cell-sized ``rect`` only its ``z`` changes (see `cell_square`).
    """
    delta = finite_float(delta_m)
    if delta is None:
        raise EditError(f"expected a finite height step in metres, got {delta_m!r}")
    index, (x0, y0, x1, y1) = cell_square(data, xy)
    regions = copy.deepcopy(list(data["regions"]))
    region = regions[index]
    if region["shape"] != "grid":
        region["z"] = _checked_top(data, index, region_top_z(data, index) + delta)
        return _with_regions(data, regions)
    z = _checked_top(data, len(regions), region_top_z(data, index) + delta)
    (ox, oy), pitch = region["origin"], region["cell"]
    cell = [round((x0 - ox) / pitch), round((y0 - oy) / pitch)]
    removed = [*region.get("removed", []), cell]
    region["removed"] = sorted(removed, key=lambda c: (c[1], c[0]))
    regions.append({
        "shape": "rect",
        "center": [round((x0 + x1) / 2, 9), round((y0 + y1) / 2, 9)],
        "size": [round(x1 - x0, 9), round(y1 - y0, 9)],
        "yaw": 0.0,
        "z": z,
    })
    return _with_regions(data, regions)
