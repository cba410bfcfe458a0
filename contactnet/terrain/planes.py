"""Sloped tops: the plane a region's top may carry, as the terrain file gives it.

A region with ``"slope_deg"`` (0 to ``MAX_SLOPE_DEG``) has a sloped top: a plane rising by tan(slope_deg) per metre
along ``"slope_dir_deg"`` (the world-frame direction of steepest ascent, degrees from +x toward +y, default 0), whose
height at the region's centre (``region_center``) is the region's ``z``. Its normalized form keeps both keys (files
without them load and write back unchanged). Where a sloped top overlaps another region, the top with the higher
``z`` wins over the whole overlap (a sloped one over a flat one of the same ``z``, then the later region): regions are
ordered by their ``z``, as flat tops are, not compared point by point. Each point of a top stays within
``MAX_HEIGHT_OFFSET_M`` of the terrain's ``surface_z`` (checked at the corners of the region's bounds).

Safe footholds on slopes (``MAX_SAFE_SLOPE_RAD``, from the friction the controller plans with) are the geometry's
business (``contactnet.terrain.geometry``); this module only reads and checks the fields.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any

from shapely.geometry import Polygon

MAX_SLOPE_DEG = 60.0
"""Steepest accepted sloped top (degrees from the horizontal). Steeper than ``geometry.MAX_SAFE_SLOPE_RAD`` is
accepted (a simulated chute) but never a safe foothold."""
SLOPE_KEYS = ("slope_deg", "slope_dir_deg")


def _finite(value: Any, low: float, high: float) -> float | None:
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        return None
    try:
        number = float(value)
    except (OverflowError, TypeError, ValueError):
        return None
    return number if math.isfinite(number) and low <= number <= high else None


def parse_slope(raw: Mapping[str, Any], region: dict[str, Any], surface_z: float,
                bounds: tuple[float, float, float, float], max_offset_m: float) -> tuple[Any, ...] | None:
    """Read ``raw``'s slope into the normalized ``region`` (its other fields already read; ``bounds`` its axis-aligned
    bounds). Returns None, or the first problem as (key, message[, the value given]) for the caller's one-line error."""
    if "slope_deg" not in raw and "slope_dir_deg" not in raw:
        return None
    if "slope_deg" not in raw:
        return "slope_dir_deg", "given without slope_deg (the slope in degrees)"
    slope = _finite(raw["slope_deg"], 0.0, MAX_SLOPE_DEG)
    if slope is None:
        return "slope_deg", f"expected a slope in [0, {MAX_SLOPE_DEG:g}] degrees", raw["slope_deg"]
    direction = _finite(raw.get("slope_dir_deg", 0.0), -360.0, 360.0)
    if direction is None:
        return ("slope_dir_deg", "expected a direction of steepest ascent in [-360, 360] degrees (0 is +x, 90 is +y)",
                raw["slope_dir_deg"])
    region["slope_deg"], region["slope_dir_deg"] = slope, direction
    gradient_x, gradient_y = slope_gradient(region)
    center_x, center_y = region_center(region)
    top_z = region.get("z", surface_z)
    minx, miny, maxx, maxy = bounds
    rises = [gradient_x * (x - center_x) + gradient_y * (y - center_y) for x in (minx, maxx) for y in (miny, maxy)]
    low, high = top_z + min(rises), top_z + max(rises)
    if low < surface_z - max_offset_m or high > surface_z + max_offset_m:
        return "slope_deg", (f"the sloped top spans z {low:.4g}..{high:.4g} m over the region; it must stay within "
                             f"{max_offset_m:g} m of surface_z ({surface_z:g})")
    return None


def slope_gradient(region: Mapping[str, Any]) -> tuple[float, float]:
    """(dz/dx, dz/dy) of a normalized region's top (0, 0 when flat): tan(slope_deg) along slope_dir_deg."""
    slope = region.get("slope_deg", 0.0)
    if not slope:
        return 0.0, 0.0
    rise = math.tan(math.radians(slope))
    direction = math.radians(region.get("slope_dir_deg", 0.0))
    return rise * math.cos(direction), rise * math.sin(direction)


def region_center(region: Mapping[str, Any]) -> tuple[float, float]:
    """The point of a normalized region where its top is at ``z``: ``center`` (rect, circle, star), the area
    centroid of the vertices (polygon), the middle of the cols x rows rectangle (grid)."""
    shape = region["shape"]
    if shape == "grid":
        (ox, oy), cell = region["origin"], region["cell"]
        return ox + 0.5 * cell * region["cols"], oy + 0.5 * cell * region["rows"]
    if shape == "polygon":
        centroid = Polygon(region["vertices"]).centroid
        return float(centroid.x), float(centroid.y)
    return float(region["center"][0]), float(region["center"][1])


__all__ = ["MAX_SLOPE_DEG", "SLOPE_KEYS", "parse_slope", "region_center", "slope_gradient"]
