"""Terrain geometry: the validated `Terrain`, its steppable union and fast exact point queries on it.

A terrain is the union of 2D *regions* (rectangles, circles, stars, polygons and grids of square
cells; their shapes are in ``contactnet.terrain.regions``, their union, built within the complexity
budget, in ``contactnet.terrain.union``) whose tops are steppable; everything else is a hole with
nothing to stand on. Each region's top is flat, at its ``z`` (default the terrain's ``surface_z``);
where regions overlap the highest top wins. ``surface_z`` is also the nominal ground level, the
height to measure from where there is no top (`Terrain.ground_z`).

The tops at one height form a *level* (`Terrain.levels`, built in ``contactnet.terrain.levels``);
a terrain whose regions are all at one height has one level, the steppable union itself, and takes
the same code paths as before heights existed.

The hot path is `Terrain.is_safe`, vectorized over many candidate footholds; `Terrain.height_at`
uses the same machinery. Both answer from a raster built once (per margin) and ask shapely only for
points next to an outline, so they are exact with respect to shapely (``contactnet.terrain.locate``).
The mesh and the top view live in ``contactnet.terrain.mesh`` and ``contactnet.terrain.render``;
`Terrain` delegates to them.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from contactnet.terrain import render as _render
from contactnet.terrain.frozen import freeze_region, thaw
from contactnet.terrain.levels import Level, eroded_levels, terrain_levels_keyed
from contactnet.terrain.locate import HeightLocator, PointLocator
from contactnet.terrain.mesh import extruded_mesh
from contactnet.terrain.planes import region_center, slope_gradient
from contactnet.terrain.regions import region_geometry
from contactnet.terrain.schema import (
    CIRCLE_MAX_ERROR_M,
    CIRCLE_MIN_SEGMENTS,
    MAX_FILE_BYTES,
    check_top_level,
    field_error,
    finite_float,
    loads_terrain_json,
    parse_fields,
    read_terrain_json,
    show,
    write_terrain_json,
)
from contactnet.terrain.top_parts import TopParts
from contactnet.terrain.union import UNION_GRID_SIZE_M, region_pieces, steppable_union

__all__ = ["CIRCLE_MAX_ERROR_M", "CIRCLE_MIN_SEGMENTS", "MAX_SAFE_SLOPE_RAD", "UNION_GRID_SIZE_M", "Terrain",
           "region_geometry", "safe_slope_rad", "validate_terrain_bytes"]

if TYPE_CHECKING:
    import trimesh
    from matplotlib.axes import Axes

_SAFE_CACHE_MAX = 16

SLOPE_FRICTION_MU = 0.6
"""The friction coefficient a sloped top's safety is judged with: what the controller and the optimizer plan with
(``ControllerGains.mu``; the simulated feet have 0.9)."""
SLOPE_FRICTION_SHARE = 2.0 / 3.0
"""The share of that friction a foot may spend holding itself on the slope; the rest is left for the walk's own
horizontal forces."""


def safe_slope_rad(friction_mu: float = SLOPE_FRICTION_MU, share: float = SLOPE_FRICTION_SHARE) -> float:
    """The steepest safe top: a foot resting on a slope theta pushes along it tan(theta) times what it pushes into
    it, so it holds while ``tan(theta) <= friction_mu * share``."""
    return math.atan(friction_mu * share)


MAX_SAFE_SLOPE_RAD = safe_slope_rad()
"""Tops steeper than this (21.8 degrees: atan(0.6 x 2 / 3)) are never safe (`Terrain.is_safe`)."""


# ---------------------------------------------------------------------------------------------
# Terrain
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Terrain:
    """An immutable, validated terrain: steppable regions with flat tops (each at its ``z``, default ``surface_z``).

    Construct with `from_dict`, `load` or a generator (``contactnet.terrain.scenes``);
    the constructor itself also validates everything (raising `TerrainError`), using the
    file's field names (``start`` for ``start_xy``) in messages. Two terrains are equal when their
    ``to_dict()`` are. ``surface_z`` is the file's field: the nominal ground level and the default
    top of a region; ask `height_at` for the top under a point and `ground_z` for the
    height to measure from. ``levels`` are the tops, highest first: (z, the part of the steppable set
    whose top is at z), one level (the steppable set) when every region is at the same height.
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
    levels: tuple[Level, ...] = field(init=False, repr=False)
    level_planes: np.ndarray = field(init=False, repr=False)  # (L, 4): per level gradient (gx, gy), anchor (x, y)
    sloped: bool = field(init=False, repr=False)
    _locators: dict[float, PointLocator] = field(init=False, repr=False)
    _heights: list[Any] = field(init=False, repr=False)  # [] or, with several levels, [pieces, tops z, locator?]
    _top_parts: TopParts | None = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        src = self.source
        setattr_ = object.__setattr__
        start_xy, goal_x, surface_z, parsed = parse_fields(
            self.name, self.description, self.start_xy, self.goal_x, self.surface_z, self.regions, src)
        setattr_(self, "start_xy", start_xy)
        setattr_(self, "goal_x", goal_x)
        setattr_(self, "surface_z", surface_z)
        setattr_(self, "regions", tuple(map(freeze_region, parsed)))
        pieces = region_pieces(parsed, src)
        steppable = steppable_union(parsed, src, pieces)  # within the complexity budget, or TerrainError
        shapely.prepare(steppable)
        setattr_(self, "steppable", steppable)
        setattr_(self, "bounds", tuple(float(v) for v in steppable.bounds))
        setattr_(self, "_locators", {})
        tops_z = np.array([region.get("z", surface_z) for region in parsed], dtype=float)
        plane_ids = np.array([i + 1 if region.get("slope_deg", 0.0) else 0 for i, region in enumerate(parsed)],
                             dtype=np.int64)
        setattr_(self, "sloped", bool(plane_ids.any()))
        if np.all(tops_z == tops_z[0]) and not self.sloped:
            setattr_(self, "levels", ((float(tops_z[0]), steppable),))
            setattr_(self, "_heights", [])
            planes = np.zeros((1, 4))
        else:  # several heights or sloped tops: the levels within the budget, or TerrainError
            levels, level_ids = terrain_levels_keyed(pieces, tops_z, plane_ids, src)
            setattr_(self, "levels", levels)
            setattr_(self, "_heights", [pieces, tops_z])
            planes = np.zeros((len(levels), 4))
            for row, plane_id in enumerate(level_ids.tolist()):
                if plane_id:
                    planes[row] = (*slope_gradient(parsed[plane_id - 1]), *region_center(parsed[plane_id - 1]))
        planes.flags.writeable = False
        setattr_(self, "level_planes", planes)
        if not shapely.intersects_xy(steppable, start_xy[0], start_xy[1]):
            raise field_error(src, "start", f"{show(start_xy.tolist())} is not on steppable ground")
        if self.goal_x <= start_xy[0]:
            raise field_error(src, "goal_x",
                              f"must be beyond the start x ({start_xy[0]:g}), got {self.goal_x:g}")

    # -- construction and files -----------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>") -> Terrain:
        """Validate a terrain dict (the JSON file's content); errors name ``source`` and the field."""
        check_top_level(data, source)
        return cls(name=data["name"], start_xy=data["start"], goal_x=data["goal_x"], regions=data["regions"],
                   surface_z=data.get("surface_z", 0.0), description=data.get("description", ""),
                   source=source)

    @classmethod
    def from_json(cls, content: bytes | str, source: str = "<json>", max_bytes: int = MAX_FILE_BYTES) -> Terrain:
        """Read a terrain JSON document (e.g. an upload's bytes) with the terrain JSON limits and validate it.

        Every problem, from bytes that are not JSON to a terrain over the complexity budget, raises a
        one-line TerrainError naming ``source``. Pure (no files, no globals) and safe to run in a worker
        thread; any terrain it accepts takes well under a second.
        """
        return cls.from_dict(loads_terrain_json(content, source, max_bytes), source=source)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Terrain:
        """Read and validate a terrain JSON file; every problem raises TerrainError naming ``path``."""
        return cls.from_dict(read_terrain_json(path), source=str(path))

    @property
    def has_heights(self) -> bool:
        """Whether the tops are at more than one height or sloped: the terrain the height checks, the swings over
        tops and the adapted touchdown are for. A terrain of one level (every top flat at one height) takes the
        flat-ground path everywhere."""
        return len(self.levels) > 1 or self.sloped

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict; ``Terrain.from_dict(t.to_dict()) == t``."""
        data: dict[str, Any] = {"name": self.name}
        if self.description:
            data["description"] = self.description
        data.update(start=[float(v) for v in self.start_xy], goal_x=self.goal_x, surface_z=self.surface_z,
                    regions=[thaw(r) for r in self.regions])
        return data

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write pretty JSON (2-space indent) atomically: a temp file in the same directory, then replace."""
        write_terrain_json(self.to_dict(), path)

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
        """Which points are safe footholds: on a top no steeper than ``MAX_SAFE_SLOPE_RAD``, at least ``margin``
        (metres) from that top's edges.

        With one level that is the steppable set shrunk by ``margin``; with several, each level shrunk
        on its own (a riser is an edge of the level on either side, so points next to it are unsafe on
        both sides); margin 0 is the steppable set either way. ``points_xy`` is an (N, 2) array-like of
        world-frame x, y in metres; a single (2,) point is accepted and gives a result of shape (1,).
        Returns a bool array (N,). Points on the boundary count as safe (shapely ``covers``); non-finite
        points are unsafe. The shrunk geometry and its lookup raster are built on the first call with a
        new margin and cached on the terrain.
        """
        points, _ = _as_points(points_xy)
        return self._locator(margin).covers(points)

    def safe_locator(self, margin: float = 0.0) -> PointLocator:
        """The point locator behind `is_safe` with ``margin`` (cached): its ``covers_xy`` answers for one
        point given as two floats, without numpy arrays (the planner's walk down a ranking)."""
        return self._locator(margin)

    def level_slope_rad(self) -> np.ndarray:
        """(L,) the slope of each level's top (radians from the horizontal; 0 for flat tops)."""
        return np.arctan(np.hypot(self.level_planes[:, 0], self.level_planes[:, 1]))

    def level_height(self, index: int, points_xy: Any) -> np.ndarray:
        """World z (N,) of the ``index``-th level's top plane at points (N, 2), whether they lie on it or not."""
        points = np.asarray(points_xy, dtype=float).reshape(-1, 2)
        gx, gy, ax, ay = self.level_planes[index].tolist()
        z = self.levels[index][0]
        if gx == 0.0 and gy == 0.0:
            return np.full(len(points), z)
        return z + gx * (points[:, 0] - ax) + gy * (points[:, 1] - ay)

    def top_z_range(self) -> tuple[float, float]:
        """(lowest, highest) world z of any top (cached): the levels' heights, a sloped one's at its outline."""
        cached = self.__dict__.get("_z_range")
        if cached is None:
            values = []
            for index, (z, geometry) in enumerate(self.levels):
                if self.sloped and self.level_planes[index, :2].any():
                    values.extend(self.level_height(index, shapely.get_coordinates(geometry)).tolist())
                else:
                    values.append(z)
            cached = (min(values), max(values))
            object.__setattr__(self, "_z_range", cached)
        return cached

    def gradient_at(self, points_xy: Any) -> np.ndarray:
        """(N, 2) the slope (dz/dx, dz/dy) of the top under each point (N, 2); 0 on flat tops and where there is
        none."""
        points, _ = _as_points(points_xy)
        gradient = np.zeros((len(points), 2))
        if self.sloped:
            parts = self.top_parts()
            part = parts.part_at(points)
            on = part >= 0
            gradient[on] = parts.gradients_xy[part[on]]
        return gradient

    def normal_at(self, points_xy: Any) -> np.ndarray:
        """World-frame unit normals (N, 3) of the top under each point (N, 2) ((3,) for one (2,) point): the
        plane's normal on a sloped top, +z on a flat one and where there is no top."""
        points, single = _as_points(points_xy)
        gradient = self.gradient_at(points)
        scale = 1.0 / np.sqrt(1.0 + (gradient * gradient).sum(axis=1))
        normals = np.column_stack([-gradient * scale[:, None], scale])
        return normals.reshape(3) if single else normals

    def height_at(self, points_xy: Any, outside: float = np.nan) -> np.ndarray:
        """World z (metres) of the highest top covering each point, ``outside`` where there is none.

        ``points_xy`` is an (N, 2) array-like of world-frame x, y in metres, giving a float array (N,),
        or a single (2,) point, giving a float array of shape (). A point has a top when a region
        covers it (its boundary included, like `is_safe` with margin 0); the top is the highest
        ``z`` of the regions covering it (on a riser, the upper one). Over holes, off the terrain and
        for non-finite points the result is ``outside`` (NaN by default). With one level this is the
        same cached raster as `is_safe`; with several, a raster of the tops built on the first
        call (``contactnet.terrain.locate.HeightLocator``).
        """
        points, single = _as_points(points_xy)
        if self.sloped:
            heights = self.top_parts().heights(points, float(outside))
        elif self._heights:
            heights = self._height_locator().heights(points, float(outside))
        else:
            heights = np.where(self._locator(0.0).covers(points), self.levels[0][0], float(outside))
        return heights.reshape(()) if single else heights

    def height_bound(self, points_xy: Any, outside: float = np.nan) -> np.ndarray:
        """An upper bound of `height_at` for obstacle checks, from a raster lookup alone (a few
        microseconds for hundreds of points): exact away from the tops' outlines; within a raster cell of one
        (at most a few mm) the highest top near the point. Same shapes as `height_at`."""
        if not self._heights or self.sloped:  # exact with one level and with sloped tops
            return self.height_at(points_xy, outside)
        points, single = _as_points(points_xy)
        heights = self._height_locator().upper_heights(points, float(outside))
        return heights.reshape(()) if single else heights

    def height_locator(self) -> HeightLocator | None:
        """The raster behind `height_at` and `height_bound` with several levels (built on first use,
        cached), None with one level; its ``upper_heights_of`` takes points coordinate first."""
        return self._height_locator() if self._heights and not self.sloped else None

    def ground_z(self, points_xy: Any) -> np.ndarray:
        """World z (metres) to measure heights from: the top where steppable, else ``surface_z``.

        Over a hole (or off the terrain) there is no top, and the reference is the nominal ground
        level ``surface_z``: a foot or a base above a hole is as high as above the ground next to
        it, it is not "below the ground" nor infinitely high. Use it for fall detection (base height
        above the ground), the ends of swing trajectories and CoM height references; use
        `height_at` to know whether there is a top at all. Same shapes as `height_at`.
        """
        return self.height_at(points_xy, outside=self.surface_z)

    def top_parts(self) -> TopParts:
        """The top parts (``contactnet.terrain.top_parts``): each connected piece of each level, with its centre
        and inradius. Built on the first call and cached."""
        if self._top_parts is None:  # a race builds it twice, harmlessly
            object.__setattr__(self, "_top_parts", TopParts.of(self.levels, self.level_planes if self.sloped else None))
        return self._top_parts

    def _height_locator(self) -> HeightLocator:
        if len(self._heights) == 2:  # built once; a race builds it twice, harmlessly
            pieces, tops_z = self._heights
            self._heights.append(HeightLocator.build(pieces, tops_z))
        return self._heights[2]

    def _locator(self, margin: float) -> PointLocator:
        locator = self._locators.get(margin) if type(margin) is float else None
        if locator is not None:
            return locator
        key = finite_float(margin)
        if key is None or key < 0.0:
            raise ValueError(f"margin must be a finite number >= 0 (metres), got {margin!r}")
        locator = self._locators.get(key)
        if locator is None:
            steep = self.level_slope_rad() > MAX_SAFE_SLOPE_RAD
            levels = tuple(level for level, too_steep in zip(self.levels, steep.tolist(), strict=True) if not too_steep)
            if key == 0.0 and not steep.any():
                geometry = self.steppable
            elif key == 0.0:
                geometry = shapely.union_all([g for _, g in levels]) if levels else shapely.Polygon()
            elif len(self.levels) == 1:
                geometry = shapely.buffer(self.steppable, -key, quad_segs=16)
            else:
                geometry = eroded_levels(levels, key) if levels else shapely.Polygon()
            locator = PointLocator.build(geometry)
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
        if self.sloped:
            low, high = self.top_z_range()
            steepest = float(np.degrees(self.level_slope_rad().max()))
            lines.insert(3, f"  tops       {len(self.levels)} levels, z from {low:.4g} to {high:.4g} m, sloped up to "
                            f"{steepest:.4g} degrees")
        elif len(self.levels) > 1:
            lines.insert(3, f"  tops       {len(self.levels)} heights, z from {self.levels[-1][0]:g} to "
                            f"{self.levels[0][0]:g} m")
        return "\n".join(lines)

    # -- geometry for simulation and display (contactnet.terrain.mesh, contactnet.terrain.render) ---
    def mesh(self, thickness: float = 0.4) -> trimesh.Trimesh:
        """The tops as one mesh of closed prisms, each polygon of each level from its top down to
        ``min(surface_z, lowest top) - thickness`` (metres).

        Each prism is watertight; pieces that touch at a single point keep separate vertices there, so
        edges stay manifold. Prisms of neighbouring levels share the wall below the lower top (two
        faces back to back), so the mesh is watertight as a whole only with one level.
        """
        base_z = min(self.surface_z, self.top_z_range()[0])
        pieces = [(polygon, top_z, tuple(plane)) for (top_z, geometry), plane in zip(self.levels, self.level_planes.tolist(),
                                                                                strict=True)
                  for polygon in shapely.get_parts(geometry)]
        return extruded_mesh(pieces, thickness, base_z=base_z)

    def render(self, ax: Axes | None = None, show_start: bool = True,
               feet_xy_start: Sequence[Sequence[float]] | np.ndarray | None = None) -> Axes:
        """Top view: steppable area filled (coloured by height with several levels), holes white, start, goal line.

        ``feet_xy_start`` (N, 2), world-frame x, y in metres: feet to mark (e.g. a robot's nominal
        stance at the start, given by the caller); None marks none.
        """
        return _render.render(self, ax=ax, show_start=show_start, feet_xy_start=feet_xy_start)

    def render_png(self, path: str | os.PathLike[str], dpi: int = 120,
                   feet_xy_start: Sequence[Sequence[float]] | np.ndarray | None = None) -> Path:
        """Render the top view to a PNG with the Agg backend (no display, no pyplot state)."""
        return _render.render_png(self, path, dpi=dpi, feet_xy_start=feet_xy_start)


def validate_terrain_bytes(content: bytes | str, source: str = "upload", max_bytes: int = MAX_FILE_BYTES) -> Terrain:
    """The validated Terrain of a JSON document's bytes, or a one-line TerrainError naming ``source``.

    The same as `Terrain.from_json`: read with the terrain JSON limits (size, depth, values,
    number length, duplicate keys), validated within the complexity budget. Thread-safe.
    """
    return Terrain.from_json(content, source=source, max_bytes=max_bytes)


def _as_points(points_xy: Any) -> tuple[np.ndarray, bool]:
    """(points (N, 2) float64, whether a single (2,) point was given); ValueError for other shapes."""
    points = np.asarray(points_xy, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        if points.shape != (2,):
            raise ValueError(f"points_xy must have shape (N, 2) or (2,), got {points.shape}")
        return points.reshape(1, 2), True
    return points, False
