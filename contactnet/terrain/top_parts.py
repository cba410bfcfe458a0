"""The tops of a terrain with heights as separate pieces, each with the point of it farthest from its edges.

A *top part* is one polygon of one level (``contactnet.terrain.levels``): a connected piece of the steppable
set whose top is flat at one height, e.g. one square of ``random_heights`` or one stair tread. Its *centre* is
its pole of inaccessibility (``shapely.maximum_inscribed_circle``) and its *inradius* the distance from there
to its edges: the largest disk that fits on it. A foot is safest at the centre of a small top
(``FootholdChecker.centred`` moves candidates there).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import shapely

from contactnet.terrain.levels import Level
from contactnet.terrain.locate import CoverLocator

INSCRIBED_TOLERANCE_M = 0.001


@dataclass(frozen=True)
class TopParts:
    """The top parts of a terrain: polygons (P,), their tops z (P,), centres (P, 2) and inradii (P,), metres.

    On a terrain with sloped tops a part's top is a plane: ``tops_z`` is its height at ``anchors_xy`` and
    ``gradients_xy`` its slope (dz/dx, dz/dy); ``rank`` orders the parts where they meet (the part of the level
    listed first wins: ``tops_z`` itself without slopes)."""

    polygons: np.ndarray
    tops_z: np.ndarray
    centres_xy: np.ndarray
    inradius_m: np.ndarray
    tree: shapely.STRtree
    gradients_xy: np.ndarray | None = None  # (P, 2), None when every top is flat
    anchors_xy: np.ndarray | None = None  # (P, 2)
    rank: np.ndarray | None = None  # (P,), None: tops_z

    @classmethod
    def of(cls, levels: tuple[Level, ...], planes: np.ndarray | None = None) -> TopParts:
        """The parts of ``levels`` (highest first); ``planes`` (L, 4) per level (gx, gy, anchor x, anchor y) when
        some tops are sloped, None when every top is flat."""
        polygons, level = shapely.get_parts(np.array([g for _, g in levels], dtype=object), return_index=True)
        tops = np.array([z for z, _ in levels], dtype=float)[level]
        circles = shapely.maximum_inscribed_circle(polygons, tolerance=INSCRIBED_TOLERANCE_M)  # centre -> edge
        centres = shapely.get_coordinates(shapely.get_point(circles, 0)).reshape(-1, 2)
        inradius = shapely.length(circles)
        shapely.prepare(polygons)
        if planes is None:
            return cls(polygons, tops, centres, np.asarray(inradius, dtype=float), shapely.STRtree(polygons))
        planes = np.asarray(planes, dtype=float)[level]
        rank = (len(levels) - level).astype(float)  # the levels come highest first
        return cls(polygons, tops, centres, np.asarray(inradius, dtype=float), shapely.STRtree(polygons),
                   planes[:, :2].copy(), planes[:, 2:].copy(), rank)

    def heights(self, points_xy: np.ndarray, outside: float = np.nan) -> np.ndarray:
        """(N,) world z of the top under each point (N, 2) (its plane's height there), ``outside`` where none."""
        points = np.asarray(points_xy, dtype=float).reshape(-1, 2)
        part = self.part_at(points)
        result = np.full(len(points), float(outside))
        on = (part >= 0).nonzero()[0]
        if on.size:
            which = part[on]
            z = self.tops_z[which]
            if self.gradients_xy is not None:
                offset = points[on] - self.anchors_xy[which]
                gradient = self.gradients_xy[which]
                z = z + gradient[:, 0] * offset[:, 0] + gradient[:, 1] * offset[:, 1]
            result[on] = z
        return result

    @functools.cached_property
    def locator(self) -> CoverLocator:
        """``part_at`` from a raster (``contactnet.terrain.locate.CoverLocator``), built on first use: a cell
        lookup per point, the parts themselves only next to their outlines; ``locator.index_xy(x, y)`` for one
        point."""
        return CoverLocator.build(self.polygons, self._order, self.part_at_exact)

    @property
    def _order(self) -> np.ndarray:
        return self.tops_z if self.rank is None else self.rank

    @functools.cached_property
    def lists(self) -> tuple[list[list[float]], list[float]]:
        """The centres [[x, y], ...] and the inradii as Python lists (for walks in Python floats)."""
        return self.centres_xy.tolist(), self.inradius_m.tolist()

    def part_at(self, points_xy: np.ndarray) -> np.ndarray:
        """(N,) int: the part under each point (N, 2), the highest where parts meet; -1 over holes. The same as
        ``part_at_exact``, from the raster (``locator``)."""
        points = np.asarray(points_xy, dtype=float).reshape(-1, 2)
        if not len(self.polygons):
            return np.full(len(points), -1, dtype=np.intp)
        return self.locator.indices(points)

    def part_at_exact(self, points_xy: np.ndarray) -> np.ndarray:
        """``part_at`` from the polygons themselves (an STRtree query and point-in-polygon tests)."""
        points = np.asarray(points_xy, dtype=float).reshape(-1, 2)
        result = np.full(len(points), -1, dtype=np.intp)
        finite = np.isfinite(points).all(axis=1).nonzero()[0]
        if not finite.size:
            return result
        point, part = self.tree.query(shapely.points(points[finite]), predicate="intersects")
        order = self._order
        best = np.full(len(finite), -np.inf)
        np.maximum.at(best, point, order[part])
        top = order[part] == best[point]
        result[finite[point[top]]] = part[top]
        return result


__all__ = ["TopParts"]
