"""Where a click in the 3D view meets the terrain: the ray viser reports, intersected with the tops.

viser 1.1's `scene.on_click` gives a ray (origin and direction, world frame). On a terrain at one
height the click lands where the ray meets that top's plane, as it always did. With several heights
a raised stone hides what is behind it, so the ray is marched from the highest top's plane down to
the lowest one in steps of `RAY_STEP_M` (horizontally) and the first sample below the top under it is
refined by bisection: the point found lies on the top the user sees (or just inside the riser wall
the ray hit). A hole has a floor at surface_z, as for `Terrain.ground_z`: a ray that reaches that plane
over a hole before it meets a top (or meets no top at all) lands there, as on a flat terrain.
"""

from __future__ import annotations

import math

import numpy as np

from contactnet.terrain import Terrain

RAY_STEP_M = 0.002
"""Horizontal distance between the samples of a marched ray (metres): stones are far wider."""
MAX_RAY_SAMPLES = 20_000
BISECTIONS = 30
_BOUNDS_MARGIN_M = 0.05


def ray_to_plane(origin, direction, z: float) -> tuple[float, float] | None:  # noqa: ANN001 - 3-vectors
    """XY where the ray origin + s * direction (s > 0) meets the plane at height z, or None."""
    origin, direction = np.asarray(origin, float), np.asarray(direction, float)
    if not (np.all(np.isfinite(origin)) and np.all(np.isfinite(direction))) or abs(direction[2]) < 1e-9:
        return None
    s = (z - origin[2]) / direction[2]
    if s <= 0:
        return None
    point = origin + s * direction
    return float(point[0]), float(point[1])


def _box_span(origin: np.ndarray, direction: np.ndarray, bounds: tuple[float, ...]) -> tuple[float, float]:
    """The ray parameters (s_in, s_out) between which the ray's xy is inside ``bounds`` (minx, miny, maxx, maxy)."""
    s_in, s_out = -math.inf, math.inf
    for axis, (low, high) in enumerate(((bounds[0], bounds[2]), (bounds[1], bounds[3]))):
        if abs(direction[axis]) < 1e-12:
            if not low <= origin[axis] <= high:
                return math.inf, -math.inf
            continue
        a, b = (low - origin[axis]) / direction[axis], (high - origin[axis]) / direction[axis]
        s_in, s_out = max(s_in, min(a, b)), min(s_out, max(a, b))
    return s_in, s_out


def ray_hit_xy(terrain: Terrain, origin, direction) -> tuple[float, float] | None:  # noqa: ANN001 - 3-vectors
    """XY (world, metres) where the ray meets ``terrain``: the first top (or riser wall) on its way, unless it
    first reaches the plane z = surface_z over a hole (then that point, as when it meets no top at all);
    None for a ray that never comes down to that plane nor meets a top (looking up)."""
    origin, direction = np.asarray(origin, float), np.asarray(direction, float)
    if not (np.all(np.isfinite(origin)) and np.all(np.isfinite(direction))):
        return None
    fallback = ray_to_plane(origin, direction, terrain.surface_z)
    low_z, top_z = terrain.top_z_range()  # (a sloped top's lowest and highest points count)
    if len(terrain.levels) == 1 and not terrain.sloped:  # one height: the plane of that top where there is one
        xy = ray_to_plane(origin, direction, top_z)
        return xy if xy is not None and not math.isnan(float(terrain.height_at(xy))) else fallback
    if direction[2] > -1e-9:
        return fallback
    s_top, s_low = (top_z - origin[2]) / direction[2], (low_z - origin[2]) / direction[2]
    minx, miny, maxx, maxy = terrain.bounds
    m = _BOUNDS_MARGIN_M
    s_in, s_out = _box_span(origin, direction, (minx - m, miny - m, maxx + m, maxy + m))
    s0, s1 = max(s_top, s_in, 0.0), min(s_low, s_out)
    if not s0 < s1:
        return fallback
    horizontal = float(np.hypot(direction[0], direction[1])) * (s1 - s0)
    n = int(min(MAX_RAY_SAMPLES, max(2, math.ceil(horizontal / RAY_STEP_M) + 1)))
    s = np.linspace(s0, s1, n)
    points = origin + s[:, None] * direction

    def below_top(p: np.ndarray) -> np.ndarray:
        return p[..., 2] <= terrain.height_at(p[..., :2].reshape(-1, 2), outside=-math.inf).reshape(p.shape[:-1])

    hit = np.flatnonzero(below_top(points))
    s_hit = math.inf
    if len(hit):
        k = int(hit[0])
        s_hit = float(s[k])
        if k > 0:
            s_above = float(s[k - 1])
            for _ in range(BISECTIONS):
                mid = 0.5 * (s_above + s_hit)
                if below_top(origin + mid * direction):
                    s_hit = mid
                else:
                    s_above = mid
    s_surface = (terrain.surface_z - origin[2]) / direction[2]
    if fallback is not None and s_surface < s_hit and math.isnan(float(terrain.height_at(fallback))):
        return fallback  # a hole reached first: its floor is surface_z, as for `Terrain.ground_z`
    if math.isinf(s_hit):
        return fallback
    point = origin + s_hit * direction
    return float(point[0]), float(point[1])
