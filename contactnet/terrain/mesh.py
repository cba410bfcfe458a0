"""The terrain as a triangle mesh: its tops extruded into closed prisms (simulation, 3D view).

Each polygon of each level (holes allowed) becomes a watertight prism from its top down: the top is
an earcut triangulation (tile by tile for polygons with thousands of holes, where earcut's hole
bridging grows as vertices x holes), the side walls stand on that triangulation's own border edges, and vertices
where a polygon touches itself are split per triangle fan, so every edge stays manifold.
``split_mesh`` cuts a mesh into chunks a simulator takes as collision shapes.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

from contactnet.terrain.schema import finite_float

if TYPE_CHECKING:
    import trimesh

_HOLES_PER_TILE = 1000


def extruded_mesh(pieces: Iterable[tuple[Polygon, float] | tuple[Polygon, float, tuple[float, ...]]],
                  thickness: float = 0.4, base_z: float | None = None) -> trimesh.Trimesh:
    """One mesh of closed prisms, one per ``(polygon, top_z)`` (a flat top) or ``(polygon, top_z, (gx, gy, ax,
    ay))`` (a sloped top: ``top_z + gx (x - ax) + gy (y - ay)`` at each vertex).

    Each prism reaches down to ``base_z - thickness`` (metres), or with ``base_z`` None to its own
    ``top_z - thickness`` (its lowest corner's on a sloped top). ``Terrain.mesh`` passes the polygons of its
    levels with their tops. Pieces that touch at a single point keep separate vertices there, so edges stay
    manifold.
    """
    import trimesh

    thickness = _positive_thickness(thickness)
    vertices: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    offset = 0
    for polygon, top_z, *plane in pieces:
        if polygon.is_empty or polygon.area <= 0.0:
            continue
        gx, gy, ax, ay = plane[0] if plane else (0.0, 0.0, 0.0, 0.0)
        lowest = top_z
        if gx or gy:
            xy = np.asarray(polygon.exterior.coords)
            lowest = float((top_z + gx * (xy[:, 0] - ax) + gy * (xy[:, 1] - ay)).min())
        bottom_z = (lowest if base_z is None else base_z) - thickness
        prism_xyz, prism_faces = _extrude(polygon, bottom_z, top_z, (gx, gy, ax, ay))
        vertices.append(prism_xyz)
        faces.append(prism_faces + offset)
        offset += len(prism_xyz)
    return trimesh.Trimesh(vertices=np.concatenate(vertices), faces=np.concatenate(faces), process=False)


def split_mesh(vertices: np.ndarray, faces: np.ndarray, max_faces: int,
               max_vertices: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The triangles of a mesh in spatially compact chunks of at most ``max_faces`` faces and ``max_vertices``
    vertices each: [(vertices (V_i, 3), faces (F_i, 3) indexing them)], together exactly the mesh's faces.

    Chunks are halved at the median face centre along their longer horizontal side until they fit
    (a simulator takes a mesh of limited size per collision shape; PyBullet about 174,000 faces).
    One chunk, the mesh itself, when it fits.
    """
    vertices, faces = np.asarray(vertices, dtype=float), np.asarray(faces, dtype=np.int64)
    if len(faces) <= max_faces and len(vertices) <= max_vertices:
        return [(vertices, faces)]
    centres_xy = vertices[faces, :2].mean(axis=1)
    pending, chunks = [np.arange(len(faces))], []
    while pending:
        members = pending.pop()
        used, local = np.unique(faces[members], return_inverse=True)
        if len(members) <= max(max_faces, 1) and len(used) <= max_vertices or len(members) <= 1:
            chunks.append((vertices[used], local.reshape(-1, 3)))
            continue
        xy = centres_xy[members]
        axis = int(np.argmax(xy.max(axis=0) - xy.min(axis=0)))
        order = members[np.argsort(xy[:, axis], kind="stable")]
        half = len(order) // 2
        pending += [order[half:], order[:half]]
    return chunks


def _positive_thickness(thickness: float) -> float:
    value = finite_float(thickness)
    if value is None or value <= 0.0:
        raise ValueError(f"thickness must be a finite number > 0 (metres), got {thickness!r}")
    return value


def _earcut(vertices_xy: np.ndarray, ring_ends: Sequence[int]) -> np.ndarray:
    """Triangles (T, 3) of indices into vertices_xy, all counter-clockwise.

    ``ring_ends`` are the cumulative end indices of the rings (exterior first, then holes).
    """
    import mapbox_earcut

    triangles = mapbox_earcut.triangulate_float64(
        np.ascontiguousarray(vertices_xy, dtype=np.float64), np.asarray(ring_ends, dtype=np.uint32)
    ).reshape(-1, 3).astype(np.int64)
    a, b, c = (vertices_xy[triangles[:, i]] for i in range(3))
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    triangles[cross < 0] = triangles[cross < 0][:, ::-1]
    return triangles


def _border_edges(triangles: np.ndarray) -> np.ndarray:
    """Directed edges (E, 2) used by exactly one triangle (u -> v with the surface on the left)."""
    directed = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    stride = int(directed.max(initial=0)) + 1
    key = np.minimum(directed[:, 0], directed[:, 1]) * stride + np.maximum(directed[:, 0], directed[:, 1])
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    return directed[counts[inverse] == 1]


def _triangulate(polygon: Polygon) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (V, 2), counter-clockwise triangles (T, 3)) covering a polygon with holes.

    earcut joins every hole to the outline by a bridge it searches for along the outline, about
    vertices x holes of work (0.8 s for a 500 x 500 grid with 16,000 holes); a polygon with many holes
    is cut into tiles, triangulated tile by tile, and the tiles' vertices merged where they coincide.
    """
    holes = len(polygon.interiors)
    if holes <= 2 * _HOLES_PER_TILE:
        return _earcut_polygon(polygon)
    side = math.ceil(math.sqrt(holes / _HOLES_PER_TILE))
    minx, miny, maxx, maxy = polygon.bounds
    edges_x, edges_y = np.linspace(minx, maxx, side + 1), np.linspace(miny, maxy, side + 1)
    x0, y0 = np.meshgrid(edges_x[:-1], edges_y[:-1])
    x1, y1 = np.meshgrid(edges_x[1:], edges_y[1:])
    tiles = shapely.get_parts(shapely.intersection(polygon, shapely.box(x0.ravel(), y0.ravel(), x1.ravel(),
                                                                        y1.ravel())))
    tiles = tiles[(shapely.get_type_id(tiles) == 3) & (shapely.area(tiles) > 0.0)]
    vertices, triangles, offset = [], [], 0
    for tile in tiles:
        tile_xy, tile_triangles = _earcut_polygon(tile)
        vertices.append(tile_xy)
        triangles.append(tile_triangles + offset)
        offset += len(tile_xy)
    all_xy = np.concatenate(vertices)
    _, first, merged = np.unique(all_xy[:, 0] + 1j * all_xy[:, 1], return_index=True, return_inverse=True)
    return all_xy[first], merged[np.concatenate(triangles)]


def _earcut_polygon(polygon: Polygon) -> tuple[np.ndarray, np.ndarray]:
    """(ring vertices (V, 2): exterior, then holes; earcut's counter-clockwise triangles (T, 3))."""
    polygon = orient(polygon, sign=1.0)
    rings = [np.asarray(polygon.exterior.coords)[:-1]] + [np.asarray(r.coords)[:-1] for r in polygon.interiors]
    ring_xy = np.concatenate(rings)
    return ring_xy, _earcut(ring_xy, np.cumsum([len(r) for r in rings]).tolist())


def _split_pinched_vertices(triangles: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Give each fan of triangles around a pinch vertex its own copy of that vertex.

    Where two parts of a polygon touch at one point (earcut merges coincident points), the vertex
    is shared by separate fans; copying it per fan keeps every edge of the prism manifold.
    Returns (triangles, original vertex index of every vertex (V',)).
    """
    triangles = triangles.copy()
    original = list(range(n_vertices))
    out_degree = np.bincount(_border_edges(triangles)[:, 0], minlength=n_vertices)
    pinched = np.flatnonzero(out_degree > 1)
    corners = np.flatnonzero(np.isin(triangles.ravel(), pinched))  # each pinch vertex's triangles, found at once
    at_vertex = triangles.ravel()[corners]
    order = np.argsort(at_vertex, kind="stable")
    at_vertex, at_triangle = at_vertex[order], corners[order] // 3
    cuts = np.flatnonzero(np.diff(at_vertex)) + 1
    groups = zip(at_vertex[np.r_[0, cuts]], np.split(at_triangle, cuts), strict=True) if len(at_vertex) else ()
    for vertex, incident in groups:
        fan_of = {int(t): int(t) for t in incident}

        def root(t: int, fan_of: dict[int, int] = fan_of) -> int:
            while fan_of[t] != t:
                t = fan_of[t]
            return t

        by_edge: dict[int, list[int]] = {}  # other end of an edge at `vertex` -> triangles using it
        for t in fan_of:
            for other in triangles[t]:
                if other != vertex:
                    by_edge.setdefault(int(other), []).append(t)
        for sharing in by_edge.values():
            for t in sharing[1:]:
                fan_of[root(t)] = root(sharing[0])
        fans: dict[int, list[int]] = {}
        for t in fan_of:
            fans.setdefault(root(t), []).append(t)
        for members in list(fans.values())[1:]:
            copy_index = len(original)
            original.append(int(vertex))
            for t in members:
                triangles[t][triangles[t] == vertex] = copy_index
    return triangles, np.asarray(original, dtype=np.int64)


def _extrude(polygon: Polygon, bottom_z: float, top_z: float,
             plane: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """A closed prism over one polygon (holes allowed): (vertices (V, 3), faces (F, 3)), outward normals.

    The top is an earcut triangulation; side walls are built on the triangulation's own boundary
    edges (edges used by one triangle), so the prism is closed even where earcut drops or merges
    vertices; vertices where the polygon touches itself are split per triangle fan.
    """
    ring_xy, triangles = _triangulate(polygon)
    top, original = _split_pinched_vertices(triangles, len(ring_xy))
    border = _border_edges(top)  # u -> v with the solid on the left; outward is to the right
    n = len(original)
    vertex_xy = ring_xy[original]
    gx, gy, ax, ay = plane
    top_heights = np.full(n, top_z) if not (gx or gy) else top_z + gx * (vertex_xy[:, 0] - ax) + gy * (
        vertex_xy[:, 1] - ay)
    vertices = np.concatenate([np.column_stack([vertex_xy, top_heights]),
                               np.column_stack([vertex_xy, np.full(n, bottom_z)])])
    u, v = border[:, 0], border[:, 1]
    sides = np.concatenate([np.column_stack([v, u, u + n]), np.column_stack([v, u + n, v + n])])
    faces = np.concatenate([top, top[:, ::-1] + n, sides])
    used = np.unique(faces)
    remap = np.full(2 * n, -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return vertices[used], remap[faces]
