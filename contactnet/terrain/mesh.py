"""The terrain as a triangle mesh: the steppable union extruded into closed prisms (simulation, 3D view).

Each polygon of the union (holes allowed) becomes a watertight prism: the top is an earcut
triangulation, the side walls stand on that triangulation's own border edges, and vertices where a
polygon touches itself are split per triangle fan, so every edge stays manifold.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

from contactnet.terrain.schema import finite_float

if TYPE_CHECKING:
    import trimesh


def extruded_mesh(pieces: Iterable[tuple[Polygon, float]], thickness: float = 0.4) -> trimesh.Trimesh:
    """One closed mesh of flat-topped pieces: each ``(polygon, top_z)`` extruded down by ``thickness``.

    ``Terrain.mesh`` passes the steppable union's parts with their tops. Pieces that touch at a single
    point keep separate vertices there, so edges stay manifold.
    """
    import trimesh

    thickness = _positive_thickness(thickness)
    vertices: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    offset = 0
    for polygon, top_z in pieces:
        if polygon.is_empty or polygon.area <= 0.0:
            continue
        prism_xyz, prism_faces = _extrude(polygon, top_z - thickness, top_z)
        vertices.append(prism_xyz)
        faces.append(prism_faces + offset)
        offset += len(prism_xyz)
    return trimesh.Trimesh(vertices=np.concatenate(vertices), faces=np.concatenate(faces), process=False)


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
    _, inverse, counts = np.unique(np.sort(directed, axis=1), axis=0, return_inverse=True, return_counts=True)
    return directed[counts[inverse.ravel()] == 1]


def _split_pinched_vertices(triangles: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Give each fan of triangles around a pinch vertex its own copy of that vertex.

    Where two parts of a polygon touch at one point (earcut merges coincident points), the vertex
    is shared by separate fans; copying it per fan keeps every edge of the prism manifold.
    Returns (triangles, original vertex index of every vertex (V',)).
    """
    triangles = triangles.copy()
    original = list(range(n_vertices))
    out_degree = np.bincount(_border_edges(triangles)[:, 0], minlength=n_vertices)
    for vertex in np.flatnonzero(out_degree > 1):
        fan_of = {int(t): int(t) for t in np.flatnonzero((triangles == vertex).any(axis=1))}

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


def _extrude(polygon: Polygon, bottom_z: float, top_z: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed prism over one polygon (holes allowed): (vertices (V, 3), faces (F, 3)), outward normals.

    The top is an earcut triangulation; side walls are built on the triangulation's own boundary
    edges (edges used by one triangle), so the prism is closed even where earcut drops or merges
    vertices; vertices where the polygon touches itself are split per triangle fan.
    """
    polygon = orient(polygon, sign=1.0)
    rings = [np.asarray(polygon.exterior.coords)[:-1]] + [np.asarray(r.coords)[:-1] for r in polygon.interiors]
    ring_xy = np.concatenate(rings)
    top, original = _split_pinched_vertices(_earcut(ring_xy, np.cumsum([len(r) for r in rings]).tolist()),
                                            len(ring_xy))
    border = _border_edges(top)  # u -> v with the solid on the left; outward is to the right
    n = len(original)
    vertex_xy = ring_xy[original]
    vertices = np.concatenate([np.column_stack([vertex_xy, np.full(n, top_z)]),
                               np.column_stack([vertex_xy, np.full(n, bottom_z)])])
    u, v = border[:, 0], border[:, 1]
    sides = np.concatenate([np.column_stack([v, u, u + n]), np.column_stack([v, u + n, v + n])])
    faces = np.concatenate([top, top[:, ::-1] + n, sides])
    used = np.unique(faces)
    remap = np.full(2 * n, -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return vertices[used], remap[faces]
