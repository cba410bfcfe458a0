"""Support polygons, vectorized: the distance of a point to the hull of the stance feet, and the area and
centroid of the hull of four feet (the ranking cost's V_stab, V_cent and V_area), exact without building
a hull. Leading axes broadcast."""

from __future__ import annotations

import itertools

import numpy as np

_PAIRS = np.array([(i, j) for i in range(4) for j in range(i, 4)])  # with i == j: single points
_TRIANGLES = np.array(list(itertools.combinations(range(4), 3)))
_CYCLES = np.array([(0, 1, 2, 3), (0, 1, 3, 2), (0, 2, 1, 3)])  # the 3 cyclic orders of 4 points


def support_distance(point_xy: np.ndarray, feet_xy: np.ndarray, stance: np.ndarray) -> np.ndarray:
    """Distance of points to the convex hull of the stance feet, 0 inside (vectorized).

    ``point_xy`` (..., 2), ``feet_xy`` (..., 4, 2), ``stance`` (..., 4) bool; returns (...). With two
    stance feet the hull is a segment, with one a point; with none the distance is ``inf``.

    Exact without building the hull: outside the hull, the nearest hull point lies on a hull edge, and
    every segment between two stance feet lies inside the hull, so the distance is the minimum over all
    such segments; a point is inside the hull iff it is inside a triangle of three stance feet.
    """
    p = np.asarray(point_xy, dtype=float)
    f = np.asarray(feet_xy, dtype=float)
    s = np.asarray(stance, dtype=bool)
    px, py = p[..., 0, None], p[..., 1, None]  # (..., 1)
    fx, fy = f[..., 0], f[..., 1]  # (..., 4)
    ax, ay, bx, by = fx[..., _PAIRS[:, 0]], fy[..., _PAIRS[:, 0]], fx[..., _PAIRS[:, 1]], fy[..., _PAIRS[:, 1]]
    abx, aby, apx, apy = bx - ax, by - ay, px - ax, py - ay  # (..., 10)
    len2 = abx * abx + aby * aby
    dot = apx * abx + apy * aby
    t = np.clip(np.divide(dot, len2, out=np.zeros_like(dot), where=len2 > 0), 0.0, 1.0)
    seg_dist = np.hypot(apx - t * abx, apy - t * aby)
    valid = s[..., _PAIRS[:, 0]] & s[..., _PAIRS[:, 1]]
    dist = np.min(np.where(valid, seg_dist, np.inf), axis=-1)
    # inside a (non-degenerate) triangle of stance feet -> 0
    x0, y0 = fx[..., _TRIANGLES[:, 0]], fy[..., _TRIANGLES[:, 0]]  # (..., 4)
    x1, y1 = fx[..., _TRIANGLES[:, 1]], fy[..., _TRIANGLES[:, 1]]
    x2, y2 = fx[..., _TRIANGLES[:, 2]], fy[..., _TRIANGLES[:, 2]]
    c0 = (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)
    c1 = (x2 - x1) * (py - y1) - (y2 - y1) * (px - x1)
    c2 = (x0 - x2) * (py - y2) - (y0 - y2) * (px - x2)
    twice_area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
    inside = ((c0 >= 0) & (c1 >= 0) & (c2 >= 0)) | ((c0 <= 0) & (c1 <= 0) & (c2 <= 0))
    tri_valid = s[..., _TRIANGLES].all(axis=-1) & (np.abs(twice_area) > 1e-12)
    return np.where((inside & tri_valid).any(axis=-1), 0.0, dist)


def _polygon_area_centroid(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed area (...) and area centroid (..., 2) of polygons (..., n, 2) (shoelace)."""
    x, y = vertices[..., 0], vertices[..., 1]
    xn, yn = np.roll(x, -1, axis=-1), np.roll(y, -1, axis=-1)
    c = x * yn - xn * y
    area = 0.5 * c.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cx = ((x + xn) * c).sum(axis=-1) / (6.0 * area)
        cy = ((y + yn) * c).sum(axis=-1) / (6.0 * area)
    centroid = np.stack([cx, cy], axis=-1)
    degenerate = np.abs(area) < 1e-12  # collinear: fall back to the mean of the vertices
    centroid = np.where(degenerate[..., None], vertices.mean(axis=-2), centroid)
    return area, centroid


def hull_area_centroid(feet_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area (...) and area centroid (..., 2) of the convex hull of 4 points (..., 4, 2) (vectorized).

    The hull is either a quadrilateral (the 4 points in convex position: then the one cyclic order that
    is not self-intersecting has the largest shoelace area of the three) or a triangle (one point inside
    the others': then that triangle's area is larger than any of the three orders'). So the hull is the
    candidate polygon of largest absolute area among the 3 cyclic orders and the 4 triangles.
    """
    f = np.asarray(feet_xy, dtype=float)
    quads = f[..., _CYCLES, :]  # (..., 3, 4, 2)
    tris = f[..., _TRIANGLES, :]  # (..., 4, 3, 2)
    qa, qc = _polygon_area_centroid(quads)
    ta, tc = _polygon_area_centroid(tris)
    areas = np.abs(np.concatenate([qa, ta], axis=-1))  # (..., 7)
    cents = np.concatenate([qc, tc], axis=-2)  # (..., 7, 2)
    best = np.argmax(areas, axis=-1)
    area = np.take_along_axis(areas, best[..., None], axis=-1)[..., 0]
    centroid = np.take_along_axis(cents, best[..., None, None], axis=-2)[..., 0, :]
    return area, centroid
