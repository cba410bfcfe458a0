"""The segmentation of a height map into steppable tops, as perceptive planners do it (``SegmentConfig``; each
rule's number is a field), for ``contactnet.terrain.importing``:

1. a cell is a **hole** when its height is NaN, or lies more than ``max_drop_m`` (a leg's length) below the map's
   median: a pit the feet cannot reach;
2. **sloped tops** first: a cell is on a plane when its differences to its two neighbours agree along x and along
   y (within half its gradient plus `PLANE_TOLERANCE_M`), its gradient is steeper than ``MIN_SLOPE_DEG``, and its 4
   neighbours are such cells or holes. A 4-connected group of them whose best plane explains it within
   ``max_roughness_m`` (the residuals' standard deviation), grown by its neighbours on that plane (`GROW_RINGS`),
   and wide enough (its outline shrunk by ``max(min_width_m / 2, a cell)`` is not empty) is a *sloped top*: kept
   with its plane when no steeper than the steppable limit (``geometry.MAX_SAFE_SLOPE_RAD``, 21.8 degrees), else
   dropped as *too steep*. A group that fails is left to the rules below (a flat top's cells never pass: its inside
   has no gradient, and where it meets another top its edge cell's two differences disagree);
3. **tops** are the 4-connected groups of the other cells whose neighbours differ by at most ``max_step_m`` (an
   edge higher than that separates two tops);
4. a top is **flat** when its heights spread over at most ``max_spread_m``. A top that is not is dropped as
   *sloped* when its best plane explains it within ``max_roughness_m`` and is steeper than ``MIN_SLOPE_DEG`` (the
   report gives the slope: a plane rule 2 did not keep, too narrow, or steps rather than one plane); otherwise
   (flat tops of nearly the same height side by side, as on ``random_heights``) it is split again with half the
   step, down to ``MIN_STEP_M`` (then *rough*);
5. a top narrower than ``min_width_m`` (its outline shrunk by half of it is empty) is dropped: no foot fits on it.

Each flat top becomes polygons (its cells' union, split where it has holes inside) at its median height; each
sloped top, polygons with its plane (``slope_deg``, ``slope_dir_deg``, and ``z`` the plane's height at each
polygon's area centroid).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np

from contactnet.terrain.geometry import MAX_SAFE_SLOPE_RAD
from contactnet.terrain.schema import TerrainError

#: A top whose best plane is steeper than this is sloped; one that is not flat and not sloped is split with a finer
#: step between neighbours, down to `MIN_STEP_M` (then it is rough).
MIN_SLOPE_DEG = 1.0
MIN_STEP_M = 1e-4
#: A cell is on a plane when its differences to its two neighbours (along x, and along y) agree within half its
#: gradient (per cell) plus this, m: 1 mm lets a millimetre-quantised map's planes through (differences of 1 and 2
#: mm on a 10 degree ramp at 1 cm), while a step between two flat tops (differences 0 and h) never passes above 1.3
#: mm and leaves a strip of 2 cells at most (narrower than a sloped top may be).
PLANE_TOLERANCE_M = 0.001
#: A plane found grows by its neighbouring cells within 3 residuals' standard deviations (at least this, m) of it,
#: this many rings: its own edge cells (a flat top's, half a cell's rise off it, are not).
GROW_TOLERANCE_M = 1e-4
GROW_RINGS = 2

@dataclass(frozen=True)
class SegmentConfig:
    """The segmentation's rules (see the module's docstring), in metres."""

    max_roughness_m: float = 0.005
    max_step_m: float = 0.005
    max_spread_m: float = 0.01
    max_drop_m: float = 0.32
    min_width_m: float = 0.02

    def __post_init__(self) -> None:
        for name in (f.name for f in fields(self)):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise TerrainError(f"{name} must be a finite number >= 0, got {value!r}")


def segment(heights: np.ndarray, resolution_m: float, origin_xy: Sequence[float],
            config: SegmentConfig = SegmentConfig()) -> tuple[list[dict], list[str], int]:
    """The steppable tops of a height map as terrain regions (polygons with their ``z``, sloped ones with their plane
    too), a line per part dropped, and how many tops were kept."""
    return segment_counted(heights, resolution_m, origin_xy, config)[:3]


def segment_counted(heights: np.ndarray, resolution_m: float, origin_xy: Sequence[float],
             config: SegmentConfig) -> tuple[list[dict], list[str], int, int]:
    """`segment`, and how many of the tops kept are sloped."""
    finite = np.isfinite(heights)
    if not finite.any():
        raise TerrainError("the height map has no finite height")
    median = float(np.median(heights[finite]))
    usable = finite & (np.where(finite, heights, median) >= median - config.max_drop_m)
    filled = np.where(usable, heights, np.nan)
    planes = _SlopedTops(heights, filled, resolution_m, origin_xy, config)
    claimed = planes.find()
    segmenter = _Segmenter(heights, np.where(claimed, np.nan, filled), resolution_m, origin_xy, config)
    segmenter.split(usable & ~claimed, config.max_step_m)
    regions, dropped = segmenter.regions + planes.regions, planes.dropped + segmenter.dropped
    if not regions:
        raise TerrainError("no steppable top was found" + (f" ({dropped[0]})" if dropped else ""))
    return regions, dropped, segmenter.kept + planes.kept, planes.kept


class _Rule:
    """What a rule of the segmentation reads (the height map, which cells are filled, the map's grid and the
    config) and what it gives: its regions, its dropped parts' report lines, how many tops it kept."""

    def __init__(self, heights: np.ndarray, filled: np.ndarray, resolution_m: float, origin_xy: Sequence[float],
                 config: SegmentConfig) -> None:
        self.heights, self.filled, self.res, self.origin, self.config = heights, filled, resolution_m, origin_xy, config
        self.regions: list[dict] = []
        self.dropped: list[str] = []
        self.kept = 0


class _SlopedTops(_Rule):
    """Rule 2 of the segmentation (the module's docstring): the planar patches steeper than `MIN_SLOPE_DEG`, kept
    as sloped tops up to the steppable limit, dropped beyond it. ``find`` returns the cells it decided on."""

    def find(self) -> np.ndarray:
        import shapely

        candidates = _plane_cells(self.filled, self.res)
        claimed = np.zeros(candidates.shape, dtype=bool)
        if not candidates.any():
            return claimed
        ones_x = np.ones((candidates.shape[0], candidates.shape[1] - 1), dtype=bool)
        ones_y = np.ones((candidates.shape[0] - 1, candidates.shape[1]), dtype=bool)
        labels = _components(candidates, ones_x, ones_y)
        # A patch is wide enough when its outline shrunk by this is not empty: a foot fits, and more than the strip
        # of 2 cells a small step between flat tops may leave.
        shrink = 1.01 * max(self.config.min_width_m / 2, self.res)
        for label in range(1, int(labels.max()) + 1):
            cells = labels == label
            if cells.sum() < 9:
                continue
            plane, residual_m = _plane_fit_xy(cells, self.heights[cells], self.res, self.origin)
            if residual_m > self.config.max_roughness_m:
                continue
            cells = self._grown(cells, plane, max(3.0 * residual_m, GROW_TOLERANCE_M), ~claimed & (labels == 0))
            outline = _cells_polygon(cells, self.res, self.origin)
            if outline.buffer(-shrink).is_empty:
                continue
            claimed |= cells
            slope_rad = math.atan(math.hypot(plane[0], plane[1]))
            x, y = _cell_xy(cells, self.res, self.origin)
            where = f"near ({x:.2f}, {y:.2f}) m"
            if slope_rad > MAX_SAFE_SLOPE_RAD:
                self.dropped.append(f"dropped a top {where}: too steep, sloped {math.degrees(slope_rad):.1f} degrees "
                                    f"(> {math.degrees(MAX_SAFE_SLOPE_RAD):.1f}, the steepest safe top), "
                                    f"{cells.sum() * self.res ** 2 * 1e4:.0f} cm^2")
                continue
            self.kept += 1
            slope_deg = round(math.degrees(slope_rad), 6)
            direction_deg = round(math.degrees(math.atan2(plane[1], plane[0])), 6) + 0.0  # no -0.0
            for polygon in _without_holes(outline):
                ring = _ring(polygon)
                centroid = shapely.Polygon(ring).centroid
                z = plane[0] * centroid.x + plane[1] * centroid.y + plane[2]
                self.regions.append({"shape": "polygon", "vertices": ring.tolist(), "z": round(float(z), 6),
                                     "slope_deg": slope_deg, "slope_dir_deg": direction_deg})
        return claimed

    def _grown(self, cells: np.ndarray, plane: tuple[float, float, float], tolerance_m: float,
               free: np.ndarray) -> np.ndarray:
        """``cells`` and, `GROW_RINGS` times, their free 4-neighbours within ``tolerance_m`` of the plane: the plane's
        edge cells the test of `_plane_cells` missed (its differences to a flat top beyond the edge disagree)."""
        rows, cols = cells.shape
        x = self.origin[0] + self.res * np.arange(cols)[None, :]
        y = self.origin[1] + self.res * np.arange(rows)[:, None]
        with np.errstate(invalid="ignore"):
            near = free & (np.abs(self.filled - (plane[0] * x + plane[1] * y + plane[2])) <= tolerance_m)
        for _ in range(GROW_RINGS):
            ring = np.zeros_like(cells)
            ring[1:, :] |= cells[:-1, :]
            ring[:-1, :] |= cells[1:, :]
            ring[:, 1:] |= cells[:, :-1]
            ring[:, :-1] |= cells[:, 1:]
            cells = cells | (ring & near)
        return cells


def _plane_cells(filled: np.ndarray, resolution_m: float) -> np.ndarray:
    """The cells on a plane steeper than `MIN_SLOPE_DEG` (rule 2 of the module's docstring): along x and along y, the
    differences to the two neighbours agree within half the cell's gradient plus `PLANE_TOLERANCE_M` (one
    difference, at a hole or the map's edge, agrees with itself), and so do the cell's 4 neighbours (or they are
    holes)."""
    def differences(axis: int) -> tuple[np.ndarray, np.ndarray]:
        step = np.diff(filled, axis=axis)
        pad = [(0, 0), (0, 0)]
        pad[axis] = (1, 0)
        backward = np.pad(step, pad, constant_values=np.nan)
        pad[axis] = (0, 1)
        forward = np.pad(step, pad, constant_values=np.nan)
        mean = np.where(np.isnan(backward), forward, np.where(np.isnan(forward), backward, 0.5 * (backward + forward)))
        bend = np.abs(forward - backward)
        return np.nan_to_num(mean), np.nan_to_num(bend)

    gx, bend_x = differences(1)
    gy, bend_y = differences(0)
    gradient = np.hypot(gx, gy)
    tolerance = 0.5 * gradient + PLANE_TOLERANCE_M
    candidates = (np.isfinite(filled) & (gradient >= resolution_m * math.tan(math.radians(MIN_SLOPE_DEG)))
                  & (bend_x <= tolerance) & (bend_y <= tolerance))
    # Eroded by the cells that are neither on a plane nor holes: a flat top's edge cell next to a ramp (differences
    # 0 and half a cell's rise) may pass the test above; its flat neighbour does not, so it is left out.
    ok = np.pad(candidates | ~np.isfinite(filled), 1, constant_values=True)
    return candidates & ok[:-2, 1:-1] & ok[2:, 1:-1] & ok[1:-1, :-2] & ok[1:-1, 2:]


def _plane_fit_xy(cells: np.ndarray, values: np.ndarray, resolution_m: float,
                  origin_xy: Sequence[float]) -> tuple[tuple[float, float, float], float]:
    """The best plane z = a x + b y + c (world frame) through a patch's heights, and the residuals' standard
    deviation (m)."""
    i, j = np.nonzero(cells)
    x, y = origin_xy[0] + resolution_m * j, origin_xy[1] + resolution_m * i
    x_mean, y_mean = float(x.mean()), float(y.mean())
    design = np.column_stack([x - x_mean, y - y_mean, np.ones(len(i))])
    (a, b, c), *_ = np.linalg.lstsq(design, values, rcond=None)
    residual = values - design @ np.array([a, b, c])
    return (float(a), float(b), float(c - a * x_mean - b * y_mean)), float(residual.std())


class _Segmenter(_Rule):
    """The recursion of `segment`: a group of cells is split into tops at a step; a top that is flat is kept (or
    dropped as narrow); one that is not is dropped as sloped when one plane explains it, else split again with half
    the step. What a split leaves over (cells of no kept top) is one line: sloped, or narrow and rough pieces."""

    def _where(self, cells: np.ndarray) -> str:
        x, y = _cell_xy(cells, self.res, self.origin)
        return f"near ({x:.2f}, {y:.2f}) m"

    def split(self, group: np.ndarray, step_m: float) -> np.ndarray:
        """Keep the tops of ``group`` at ``step_m``; returns the cells kept."""
        with np.errstate(invalid="ignore"):
            join_x = np.abs(np.diff(self.filled, axis=1)) <= step_m  # cells j and j+1 of a row: one top
            join_y = np.abs(np.diff(self.filled, axis=0)) <= step_m
        from scipy.ndimage import find_objects

        labels = _components(group, join_x, join_y)
        kept = np.zeros(group.shape, dtype=bool)
        narrow = np.zeros(group.shape, dtype=bool)
        narrow_tops = 0
        # a top with less area than a foot's disc holds no such disc (too narrow whatever its heights): told without
        # building its outline; each top is looked at in its bounding box (a rough map breaks into 10^5 of them)
        disc_cells = math.pi * (self.config.min_width_m / 2) ** 2 / self.res ** 2
        for label, box in enumerate(find_objects(labels), start=1):
            if box is None:
                continue
            local = labels[box] == label
            values = self.heights[box][local]
            if self.config.min_width_m > 0 and local.sum() < disc_cells:
                wide = False
            elif float(values.max() - values.min()) <= self.config.max_spread_m:
                wide = self._flat_top(local, box, values)
            else:  # a rough top: split finer, on the whole map's arrays
                cells = np.zeros(group.shape, dtype=bool)
                cells[box] = local
                kept |= self._rough_top(cells, step_m)
                continue
            if not wide:
                narrow[box] |= local
                narrow_tops += 1
            else:
                kept[box] |= local
        if narrow_tops:  # one line for them all (a rough patch breaks into many one-cell tops)
            self.dropped.append(f"dropped {narrow_tops} top(s) narrower than {100 * self.config.min_width_m:g} cm, "
                                f"{narrow.sum() * self.res ** 2 * 1e4:.0f} cm^2 {self._where(narrow)}")
        return kept

    def _flat_top(self, local: np.ndarray, box: tuple[slice, slice], values: np.ndarray) -> bool:
        """A flat top, its cells ``local`` in the map's block ``box`` (``values`` their heights): kept as a region at
        their median height (True), or not when it is too narrow for a foot (False)."""
        config = self.config
        outline = _cells_polygon(local, self.res, self.origin, box)
        if config.min_width_m > 0 and outline.buffer(-config.min_width_m / 2).is_empty:
            return False
        z = float(np.median(values))
        self.kept += 1
        for polygon in _without_holes(outline):
            self.regions.append({"shape": "polygon", "vertices": _ring(polygon).tolist(), "z": round(z, 6)})
        return True

    def _rough_top(self, cells: np.ndarray, step_m: float) -> np.ndarray:
        """The cells kept of a group whose heights spread over more than a flat top's: none if one plane explains it
        (sloped: dropped) or the split is already at its finest, else its tops at half the step."""
        spread = float(np.ptp(self.heights[cells]))
        if self._sloped(cells) or step_m <= MIN_STEP_M:
            if step_m <= MIN_STEP_M:
                self.dropped.append(f"dropped a rough part {self._where(cells)}: heights over {100 * spread:.1f} cm")
            return np.zeros_like(cells)
        before = len(self.dropped)
        kept = self.split(cells, step_m / 2)
        left = cells & ~kept
        if left.any():  # one line for what the finer split left over, instead of one per piece
            del self.dropped[before:]
            if not self._sloped(left):
                self.dropped.append(f"dropped {left.sum() * self.res ** 2 * 1e4:.0f} cm^2 {self._where(left)}: not a "
                                    f"flat top (narrow or rough pieces, heights over "
                                    f"{100 * float(np.ptp(self.heights[left])):.1f} cm)")
        return kept

    def _sloped(self, cells: np.ndarray) -> bool:
        """Whether one plane steeper than `MIN_SLOPE_DEG` explains these cells (then they are dropped as sloped)."""
        values = self.heights[cells]
        slope_deg, residual_m = _plane_fit(cells, values, self.res)
        if residual_m > self.config.max_roughness_m or slope_deg < MIN_SLOPE_DEG:
            return False
        self.dropped.append(f"dropped a top {self._where(cells)}: sloped {slope_deg:.1f} degrees, its heights spread "
                            f"over {100 * float(np.ptp(values)):.1f} cm, not a sloped top (narrower than "
                            f"{100 * max(self.config.min_width_m, 2 * self.res):g} cm, or steps, not one plane)")
        return True


def _plane_fit(cells: np.ndarray, values: np.ndarray, resolution_m: float) -> tuple[float, float]:
    """The slope (degrees) of the best plane through a top's heights and the residuals' standard deviation (m)."""
    i, j = np.nonzero(cells)
    design = np.column_stack([j * resolution_m, i * resolution_m, np.ones(len(i))])
    coef, *_ = np.linalg.lstsq(design, values, rcond=None)
    residual = values - design @ coef
    return float(np.degrees(np.arctan(np.hypot(coef[0], coef[1])))), float(residual.std())


def _components(cells: np.ndarray, join_x: np.ndarray, join_y: np.ndarray) -> np.ndarray:
    """Labels (1..N) of the 4-connected groups of ``cells`` joined where ``join_x`` / ``join_y`` say; 0 elsewhere."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rows, cols = cells.shape
    index = np.arange(rows * cols).reshape(rows, cols)
    ex = cells[:, :-1] & cells[:, 1:] & join_x
    ey = cells[:-1, :] & cells[1:, :] & join_y
    a = np.concatenate([index[:, :-1][ex], index[:-1, :][ey]])
    b = np.concatenate([index[:, 1:][ex], index[1:, :][ey]])
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(rows * cols, rows * cols))
    _, component = connected_components(graph, directed=False)
    component = component.reshape(rows, cols)
    labels = np.zeros((rows, cols), dtype=int)
    _, first = np.unique(component[cells], return_inverse=True)
    labels[cells] = first + 1
    return labels


def _cell_xy(cells: np.ndarray, resolution_m: float, origin_xy: Sequence[float]) -> tuple[float, float]:
    i, j = np.nonzero(cells)
    return origin_xy[0] + resolution_m * float(j.mean()), origin_xy[1] + resolution_m * float(i.mean())


def _cells_polygon(cells: np.ndarray, resolution_m: float, origin_xy: Sequence[float],  # noqa: ANN202
                   box: tuple[slice, slice] | None = None):
    """The union of a top's cells (each cell a square of ``resolution_m`` centred on its sample), as runs along x
    merged by shapely, collinear vertices removed. ``box``: ``cells`` is that block of the map (rows, columns)."""
    import shapely

    rows, cols = cells.shape
    row0, col0 = (0, 0) if box is None else (box[0].start, box[1].start)
    # Cell edges computed once each, so that neighbouring cells share them exactly (no sliver between rows); the same
    # floats whether or not the cells come as a block of the map.
    x_edges = origin_xy[0] + resolution_m * (np.arange(col0, col0 + cols + 1) - 0.5)
    y_edges = origin_xy[1] + resolution_m * (np.arange(row0, row0 + rows + 1) - 0.5)
    boxes = []
    for i in range(rows):
        row = cells[i]
        if not row.any():
            continue
        edges = np.diff(np.concatenate([[0], row.astype(np.int8), [0]]))
        starts, stops = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
        boxes += [shapely.box(x_edges[j0], y_edges[i], x_edges[j1], y_edges[i + 1])
                  for j0, j1 in zip(starts, stops, strict=True)]
    union = shapely.union_all(boxes)
    # An opening of 1 um parts cells that touch at a corner only (a ring that touches itself is not simple).
    opened = union.buffer(-1e-6, join_style="mitre").buffer(1e-6, join_style="mitre")
    return shapely.simplify(opened, 0.0)


def _ring(polygon) -> np.ndarray:  # noqa: ANN001 - a shapely Polygon
    """A region's vertices (k, 2): the polygon's exterior (on the nanometre grid: ``_without_holes``)."""
    return np.asarray(polygon.exterior.coords)[:-1].round(9)


def _without_holes(geometry) -> list:  # noqa: ANN001 - a shapely (Multi)Polygon
    """The polygons of ``geometry`` with every hole cut open: each holed polygon split in two along a line through
    a hole, until none has one (the terrain's polygons have no holes; their union is the same set)."""
    import shapely
    from shapely.ops import split

    out, pending = [], list(shapely.get_parts(geometry))
    while pending:
        polygon = pending.pop()
        if polygon.is_empty or polygon.area <= 0:
            continue
        if not polygon.interiors:
            # on the terrain's nanometre grid (its files and its check): a cut through a hole can leave two edges a
            # fraction of a nanometre apart, which the grid makes touch; snapped, such a polygon comes apart (or
            # gets a hole) and goes round again
            snapped = shapely.set_precision(polygon, 1e-9)
            parts = list(shapely.get_parts(snapped))
            if len(parts) == 1 and parts[0].geom_type == "Polygon" and not parts[0].interiors:
                out.append(parts[0])
            else:
                pending += [part for part in parts if part.geom_type == "Polygon"]
            continue
        hole_x = shapely.Polygon(polygon.interiors[0]).centroid.x
        _, y0, _, y1 = polygon.bounds
        cut = shapely.LineString([(hole_x, y0 - 1.0), (hole_x, y1 + 1.0)])
        pending += [p for p in split(polygon, cut).geoms if p.area > 0]
    return out


__all__ = ["GROW_RINGS", "GROW_TOLERANCE_M", "MIN_SLOPE_DEG", "MIN_STEP_M", "PLANE_TOLERANCE_M", "SegmentConfig", "segment",
           "segment_counted"]
