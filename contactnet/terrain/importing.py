"""Terrain from a height map or a mesh: what a perception stack hands a planner, segmented into steppable tops.

``import_terrain(SOURCE)`` reads

- a **height map**: ``.npy`` (a 2-D float array, metres) or a 16-bit (or 8-bit) ``.png`` (pixel value times
  ``z_scale`` metres). ``map[i, j]`` is the height at x = origin_x + j * resolution, y = origin_y + i * resolution
  (row i along y, column j along x); NaN is a hole;
- a **mesh**: ``.stl``, ``.obj``, ``.ply`` (through trimesh), in metres, z up; it is sampled into a height map at
  ``resolution`` (default `MESH_RESOLUTION_M`; the highest upward-facing surface over each cell's centre; no
  surface: a hole).

and segments the map into steppable tops (``contactnet.terrain.segmentation``: its rules, ``SegmentConfig``). The
start is the widest point of the ground within `END_STRIP_M` of its first x, the goal the one of its last
(``--start``, ``--goal-x`` say otherwise); the nominal ground (``surface_z``, what heights over a hole are measured
from) is the start's top.
`ImportReport` says what was kept and dropped; ``contactnet terrain render`` draws the result.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from contactnet.terrain.geometry import Terrain
from contactnet.terrain.schema import TerrainError
from contactnet.terrain.segmentation import SegmentConfig, segment, segment_counted

#: The file endings `import_terrain` reads.
HEIGHT_MAP_SUFFIXES = (".npy", ".png")
MESH_SUFFIXES = (".stl", ".obj", ".ply")


@dataclass(frozen=True)
class ImportReport:
    """What an import kept: tops (count, area), and what it dropped, each a line."""

    cells: tuple[int, int]
    resolution_m: float
    tops: int
    steppable_m2: float
    dropped: tuple[str, ...] = field(default_factory=tuple)
    sloped: int = 0  # how many of the tops are sloped

    def lines(self) -> list[str]:
        rows, cols = self.cells
        sloped = f" ({self.sloped} sloped)" if self.sloped else ""
        return [f"{rows} x {cols} cells of {100 * self.resolution_m:g} cm: {self.tops} top(s){sloped}, "
                f"{self.steppable_m2:.3f} m^2 steppable", *self.dropped]


def read_height_map(path: Path, z_scale: float = 1.0) -> np.ndarray:
    """The height map (rows along y, columns along x) of a ``.npy`` or ``.png`` file, in metres."""
    if path.suffix == ".npy":
        try:  # the header first: a map too large to segment is refused before it is read
            with open(path, "rb") as file:
                version = np.lib.format.read_magic(file)
                read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                               else np.lib.format.read_array_header_2_0)
                shape, _, _ = read_header(file)
            _check_size(path, shape)
            heights = np.load(path, allow_pickle=False)
        except TerrainError:
            raise
        except (OSError, ValueError) as exc:
            raise TerrainError(f"{path}: not a numpy array file ({str(exc).splitlines()[0]})") from None
    else:
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(path) as image:
                _check_size(path, (image.height, image.width))
                heights = np.asarray(image)
        except TerrainError:
            raise
        except (OSError, UnidentifiedImageError, Image.DecompressionBombError) as exc:
            raise TerrainError(f"{path}: not a PNG image ({str(exc).splitlines()[0]})") from None
        if heights.ndim == 3:
            raise TerrainError(f"{path}: a colour image; a height map is one channel (8 or 16 bit grey)")
    if heights.ndim != 2 or min(heights.shape) < 2:
        raise TerrainError(f"{path}: a height map is a 2-D array of at least 2 x 2, got shape {heights.shape}")
    if not np.issubdtype(heights.dtype, np.number):
        raise TerrainError(f"{path}: a height map holds numbers, got {heights.dtype}")
    return heights.astype(float) * z_scale


#: A mesh's default sampling step, m: the raised stones meshed and sampled at 5 mm (outlines of 5 mm stairs) made
#: both gaits fall at a stone's edge, at 2 and 3 mm both cross as on the original (docs/terrain-files.md).
MESH_RESOLUTION_M = 0.002
#: The largest mesh file read, bytes.
MAX_MESH_BYTES = 200_000_000
#: The most cells a mesh is sampled into (a larger mesh needs a coarser --resolution).
MAX_MESH_CELLS = 4_000_000


#: The most cells a height map may have (4096 x 4096).
MAX_MAP_CELLS = 4096 * 4096


def _check_size(path: Path, shape: tuple) -> None:
    if len(shape) >= 2 and int(np.prod(shape, dtype=np.int64)) > MAX_MAP_CELLS:
        raise TerrainError(f"{path}: a height map of {' x '.join(map(str, shape))} cells; at most {MAX_MAP_CELLS} "
                           "(4096 x 4096): downsample it")


def mesh_height_map(path: Path, resolution_m: float) -> tuple[np.ndarray, tuple[float, float]]:
    """A mesh sampled into a height map at ``resolution_m``: the highest upward-facing triangle over each cell
    centre (NaN where there is none); returns the map and its origin (x, y), the first cell's centre, half a cell
    inside the mesh's bounds (so that the cells tile them)."""
    import trimesh

    if path.stat().st_size > MAX_MESH_BYTES:
        raise TerrainError(f"{path}: {path.stat().st_size / 1e6:.0f} MB; a terrain mesh is at most "
                           f"{MAX_MESH_BYTES / 1e6:.0f} MB (decimate it)")
    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:  # noqa: BLE001 - trimesh raises many kinds for a bad file
        raise TerrainError(f"{path}: not a mesh trimesh can read ({type(exc).__name__}: {exc})") from None
    if len(mesh.faces) == 0:
        raise TerrainError(f"{path}: the mesh has no faces")
    lower, upper = mesh.bounds
    origin = (float(lower[0]) + resolution_m / 2, float(lower[1]) + resolution_m / 2)  # the first cell's centre
    cols = max(1, int(math.ceil((upper[0] - lower[0]) / resolution_m - 1e-9)))
    rows = max(1, int(math.ceil((upper[1] - lower[1]) / resolution_m - 1e-9)))
    if rows * cols > MAX_MESH_CELLS:
        coarser = math.sqrt((upper[0] - lower[0]) * (upper[1] - lower[1]) / MAX_MESH_CELLS)
        raise TerrainError(f"{path}: {rows} x {cols} cells at {resolution_m} m, more than {MAX_MESH_CELLS}: give "
                           f"--resolution {coarser:.3f} or more")
    heights = np.full((rows, cols), np.nan)
    triangles = mesh.triangles[mesh.face_normals[:, 2] > 1e-6]  # facing up
    for tri in triangles:
        (x0, y0, _), (x1, y1, _), (x2, y2, _) = tri
        j0 = max(0, int(math.ceil((min(x0, x1, x2) - origin[0]) / resolution_m - 1e-9)))
        j1 = min(cols - 1, int(math.floor((max(x0, x1, x2) - origin[0]) / resolution_m + 1e-9)))
        i0 = max(0, int(math.ceil((min(y0, y1, y2) - origin[1]) / resolution_m - 1e-9)))
        i1 = min(rows - 1, int(math.floor((max(y0, y1, y2) - origin[1]) / resolution_m + 1e-9)))
        if j1 < j0 or i1 < i0:
            continue
        xs = origin[0] + resolution_m * np.arange(j0, j1 + 1)
        ys = origin[1] + resolution_m * np.arange(i0, i1 + 1)
        px, py = np.meshgrid(xs, ys)
        det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
        if abs(det) < 1e-15:
            continue
        a = ((y1 - y2) * (px - x2) + (x2 - x1) * (py - y2)) / det
        b = ((y2 - y0) * (px - x2) + (x0 - x2) * (py - y2)) / det
        c = 1.0 - a - b
        inside = (a >= -1e-9) & (b >= -1e-9) & (c >= -1e-9)
        z = a * tri[0, 2] + b * tri[1, 2] + c * tri[2, 2]
        block = heights[i0:i1 + 1, j0:j1 + 1]
        higher = inside & ~(z <= block)  # NaN compares False: any surface beats none
        block[higher] = z[higher]
    return heights, origin


def import_terrain(source: str | Path, resolution_m: float | None = None, z_scale: float = 1.0,
                   origin_xy: Sequence[float] = (0.0, 0.0), start_xy: Sequence[float] | None = None,
                   goal_x: float | None = None, config: SegmentConfig = SegmentConfig(),
                   name: str | None = None) -> tuple[Terrain, ImportReport]:
    """A terrain from a height map or a mesh (see the module's docstring), and what the import kept and dropped.
    ``resolution_m``: metres per pixel of a height map (default 0.01), the sampling step of a mesh (default
    `MESH_RESOLUTION_M`)."""
    path = Path(source)
    suffix = path.suffix.lower()
    if suffix not in HEIGHT_MAP_SUFFIXES + MESH_SUFFIXES:
        raise TerrainError(f"{path}: import reads {', '.join(HEIGHT_MAP_SUFFIXES + MESH_SUFFIXES)}")
    if not path.is_file():
        raise TerrainError(f"{path}: no such file")
    if resolution_m is not None and not (math.isfinite(resolution_m) and resolution_m > 0):
        raise TerrainError(f"--resolution must be a positive number of metres, got {resolution_m!r}")
    if suffix in MESH_SUFFIXES:
        heights, origin = mesh_height_map(path, resolution_m or MESH_RESOLUTION_M)
        resolution_m = resolution_m or MESH_RESOLUTION_M
        origin_xy = origin
    else:
        resolution_m = resolution_m or 0.01
        heights = read_height_map(path, z_scale)
    regions, dropped, kept, sloped = segment_counted(heights, resolution_m, origin_xy, config)
    tops = _tops_by_x(regions)
    start = tuple(start_xy) if start_xy is not None else _end_point(tops, first=True)
    goal = float(goal_x) if goal_x is not None else _end_point(tops, first=False)[0]
    if goal <= start[0]:
        raise TerrainError(f"{path}: the goal (x {goal:.2f} m) is not ahead of the start (x {start[0]:.2f} m): give "
                           "--start X,Y and --goal-x X")
    # The nominal ground, which heights over a hole are measured from (Terrain.ground_z): the start's top.
    probe = Terrain(name="probe", start_xy=start, goal_x=goal, regions=regions)
    surface_z = float(probe.height_at(np.array([start]), outside=float(np.median([r["z"] for r in regions])))[0])
    terrain = Terrain(name=name or path.stem, start_xy=start, goal_x=goal, regions=regions, surface_z=surface_z,
                      description=f"imported from {path.name}", source=str(path))
    report = ImportReport(heights.shape, resolution_m, kept, float(terrain.steppable.area), tuple(dropped), sloped)
    return terrain, report


#: The start and the goal lie on the steppable ground within this distance of its first and last x, m.
END_STRIP_M = 0.5


def _tops_by_x(regions: list[dict]) -> list:
    import shapely

    polygons = [shapely.Polygon(r["vertices"]) for r in regions]
    merged = list(shapely.get_parts(shapely.union_all(polygons)))
    return sorted(merged, key=lambda p: p.bounds[0])


def _end_point(tops: list, first: bool) -> tuple[float, float]:
    """The widest point (centre of the largest inscribed circle) of the steppable ground within `END_STRIP_M` of its
    first x (``first``) or its last x."""
    import shapely

    ground = shapely.union_all(tops)
    x0, y0, x1, y1 = ground.bounds
    strip = shapely.box(x0, y0, x0 + END_STRIP_M, y1) if first else shapely.box(x1 - END_STRIP_M, y0, x1, y1)
    parts = [part for part in shapely.get_parts(ground.intersection(strip)) if part.geom_type == "Polygon"]
    widest = max(parts, key=lambda part: shapely.maximum_inscribed_circle(part).length)
    centre = shapely.maximum_inscribed_circle(widest).coords[0]
    return float(centre[0]), float(centre[1])


__all__ = ["HEIGHT_MAP_SUFFIXES", "MESH_SUFFIXES", "ImportReport", "SegmentConfig", "import_terrain",
           "mesh_height_map", "read_height_map", "segment"]
