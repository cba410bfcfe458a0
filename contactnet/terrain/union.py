"""The steppable union of a terrain's regions, built within the complexity budget in well under a second.

Every coordinate is first snapped to ``UNION_GRID_SIZE_M`` (1 nm) the way GEOS's fixed precision
model rounds it, so that regions meant to abut share their edges exactly and no sub-nanometre crack
opens between them. The snapped pieces are then united without a precision model, as disjoint
subsets: GEOS's snap-rounding overlay took 4.5 s for 10,000 separate stones, this takes 10 ms. A grid
is one piece, traced straight from its cells (``contactnet.terrain.regions``).

What bounds the cost, checked before uniting (``contactnet.terrain.schema`` names the limits):

- outline vertices of all regions together (grids: the corners of their present cells);
- pairs of edges of different regions that cross or touch. Counted in time linear in the outlines:
  edges are cut into pieces no longer than a cell of a square grid laid over the terrain, and only
  edges of different regions sharing a grid cell are tested exactly;
- the mesh the union becomes: faces bounded from its outline vertices and holes.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from contactnet.terrain.regions import (
    cells_geometry,
    grid_cell_edges,
    grid_present,
    outline_corner_count,
    outlines_xy,
)
from contactnet.terrain.schema import (
    CONTACT_CHECK_MAX_CANDIDATES,
    CONTACT_CHECK_MAX_PIECES,
    MAX_EDGE_CONTACTS,
    MAX_MESH_FACES,
    MAX_OUTLINE_VERTICES,
    field_error,
    outline_vertex_count,
)

UNION_GRID_SIZE_M = 1e-9
"""Coordinates are snapped to this grid before regions are united (closes sub-nm cracks)."""
_SNAP_SCALE = 1e9  # 1 / UNION_GRID_SIZE_M, exactly the scale GEOS derives from that grid size
_union_pieces = getattr(shapely, "disjoint_subset_union_all", shapely.union_all)  # shapely >= 2.1
_BIG_PIECE_VERTICES = 2000


def snap(values: Any) -> np.ndarray:
    """``values`` rounded to the UNION_GRID_SIZE_M grid as GEOS rounds (half up: round(v * 1e9) / 1e9)."""
    scaled = np.asarray(values, dtype=float) * _SNAP_SCALE
    whole = np.floor(scaled)
    return (whole + (scaled - whole >= 0.5)) / _SNAP_SCALE


def region_pieces(regions: Sequence[Mapping[str, Any]], source: str) -> np.ndarray:
    """The snapped geometry of each normalized region (an object array aligned with ``regions``; a grid with
    every cell removed gives an empty polygon), or TerrainError when the outlines exceed the budget."""
    is_grid = np.array([r["shape"] == "grid" for r in regions], dtype=bool)
    present = {int(i): grid_present(regions[i]) for i in np.flatnonzero(is_grid)}
    outline = np.array([outline_corner_count(present[i]) if is_grid[i] else outline_vertex_count(r)
                        for i, r in enumerate(regions)], dtype=np.int64)
    running = np.cumsum(outline)
    if running[-1] > MAX_OUTLINE_VERTICES:
        first = int(np.argmax(running > MAX_OUTLINE_VERTICES))
        raise field_error(source, f"regions[{first}]", f"the regions up to here have {running[first]} outline "
                                                       f"vertices; the limit is {MAX_OUTLINE_VERTICES}")
    pieces = np.empty(len(regions), dtype=object)
    for i, cells in present.items():
        edges_x, edges_y = grid_cell_edges(regions[i])
        pieces[i] = cells_geometry(cells, snap(edges_x), snap(edges_y))
    outlined = np.flatnonzero(~is_grid)
    if outlined.size:
        xy, counts = outlines_xy([regions[i] for i in outlined])
        pieces[outlined] = shapely.polygons(shapely.linearrings(snap(xy), indices=np.repeat(
            np.arange(len(counts)), counts)))
        polygons = outlined[[regions[i]["shape"] == "polygon" for i in outlined]]
        invalid = polygons[~shapely.is_valid(pieces[polygons])]
        if invalid.size:  # only a polygon with features below 1 nm gets here: the schema checked the rest
            raise field_error(source, f"regions[{invalid[0]}].vertices", "polygon is not simple at 1e-9 m "
                              f"resolution ({shapely.is_valid_reason(pieces[invalid[0]])})")
    return pieces


def steppable_union(regions: Sequence[Mapping[str, Any]], source: str,
                    pieces: np.ndarray | None = None) -> BaseGeometry:
    """The union of the normalized regions (valid, collinear vertices dropped), or TerrainError naming the
    limit of the complexity budget it would exceed. ``pieces``: the regions' `region_pieces`, when
    the caller has them already."""
    if pieces is None:
        pieces = region_pieces(regions, source)
    is_grid = np.array([r["shape"] == "grid" for r in regions], dtype=bool)
    nonempty = ~shapely.is_empty(pieces)
    pieces, is_grid = pieces[nonempty], is_grid[nonempty]
    if len(pieces) > 1:
        _check_edge_contacts(pieces, source)
        union = shapely.simplify(unite(pieces), 0.0)  # drops exactly collinear vertices only
    elif len(pieces) == 1:  # a grid's trace has no collinear vertices; an outline may
        union = pieces[0] if is_grid[0] else shapely.simplify(pieces[0], 0.0)
    else:
        union = Polygon()
    if not union.is_valid:  # pragma: no cover - defensive; GEOS overlay and the grid trace give valid output
        union = shapely.make_valid(union)
    faces = mesh_face_bound(union)
    if faces > MAX_MESH_FACES:
        raise field_error(source, "regions", f"the steppable surface needs up to {faces} mesh faces "
                                             f"(4 per outline vertex and per hole); the limit is {MAX_MESH_FACES}")
    return union


def unite(pieces: np.ndarray) -> BaseGeometry:
    """The union of the pieces: pieces of similar size together (as disjoint subsets), then those unions and
    the big pieces two at a time, smallest first, each time overlaying only the parts that meet.

    (A cascaded union of everything pairs the big pieces with small ones at every level of its tree: a
    500 x 500 grid under 4,000 stones took 1.6 s that way, one union with the stones' union 0.2 s. And an
    overlay assigns every hole of its result to a shell, so 10,000 stones lying in a grid's 10,000 holes
    cost 0.7 s to overlay with the grid, nothing to keep beside it.)
    """
    sizes = shapely.get_num_coordinates(pieces)
    size_class = np.where(sizes > _BIG_PIECE_VERTICES, -1 - np.arange(len(sizes)), np.log2(sizes).astype(int) // 2)
    queue = []
    for label in np.unique(size_class):
        members = pieces[size_class == label]
        united = members[0] if len(members) == 1 else _union_pieces(members)
        queue.append((int(shapely.get_num_coordinates(united)), len(queue), united))
    heapq.heapify(queue)
    order = len(queue)  # ties go first in, first out: the same terrain always unites the same way
    while len(queue) > 1:
        _, _, first = heapq.heappop(queue)
        _, _, second = heapq.heappop(queue)
        united = _merge(first, second)
        heapq.heappush(queue, (int(shapely.get_num_coordinates(united)), order, united))
        order += 1
    return queue[0][2]


def _merge(first: BaseGeometry, second: BaseGeometry) -> BaseGeometry:
    """The union of two valid (multi)polygons, overlaying only the parts of each that meet the other."""
    parts_first, parts_second = shapely.get_parts(first), shapely.get_parts(second)
    meeting = _meeting(parts_first, parts_second)
    if meeting is None:  # bounding boxes nested many deep: GEOS overlays all of it
        return shapely.union(first, second)
    meets_second, meets_first = meeting
    if not meets_second.any():
        return shapely.multipolygons(np.concatenate([parts_first, parts_second]))
    overlaid = shapely.union(shapely.multipolygons(parts_first[meets_second]),
                             shapely.multipolygons(parts_second[meets_first]))
    kept = np.concatenate([shapely.get_parts(overlaid), parts_first[~meets_second], parts_second[~meets_first]])
    return kept[0] if len(kept) == 1 else shapely.multipolygons(kept)


def _meeting(parts_a: np.ndarray, parts_b: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(which parts of a meet some part of b, which parts of b meet some part of a): touching counts; None
    when the parts' bounding boxes overlap in more pairs than a few per part.

    Two polygons meet when their boundaries meet or one holds a vertex of the other's exterior. Pairs
    with overlapping bounding boxes are tested so, the bigger boundary prepared. (GEOS's own prepared
    test also looks for a point of every ring of the big polygon in the small one: 10,000 holes times
    10,000 stones took seconds.)
    """
    i, j = shapely.STRtree(parts_b).query(parts_a)
    if len(i) > 8 * (len(parts_a) + len(parts_b)):
        return None
    meets_a, meets_b = np.zeros(len(parts_a), dtype=bool), np.zeros(len(parts_b), dtype=bool)
    if len(i) == 0:
        return meets_a, meets_b
    size_a, size_b = shapely.get_num_coordinates(parts_a), shapely.get_num_coordinates(parts_b)
    rings_a, rings_b = shapely.boundary(parts_a), shapely.boundary(parts_b)
    a_bigger = size_a[i] >= size_b[j]
    bigger = np.where(a_bigger, rings_a[i], rings_b[j])
    shapely.prepare(bigger)
    meet = shapely.intersects(bigger, np.where(a_bigger, rings_b[j], rings_a[i]))
    shapely.prepare(parts_a)
    shapely.prepare(parts_b)
    corner_a = shapely.get_coordinates(shapely.get_point(shapely.get_exterior_ring(parts_a), 0))
    corner_b = shapely.get_coordinates(shapely.get_point(shapely.get_exterior_ring(parts_b), 0))
    meet |= shapely.intersects_xy(parts_b[j], corner_a[i, 0], corner_a[i, 1])
    meet |= shapely.intersects_xy(parts_a[i], corner_b[j, 0], corner_b[j, 1])
    meets_a[i[meet]] = True
    meets_b[j[meet]] = True
    return meets_a, meets_b


def mesh_face_bound(geometry: BaseGeometry) -> int:
    """The faces of ``extruded_mesh`` over the polygons of ``geometry``, counted from their outlines.

    A polygon with V vertices and H holes has a top and a bottom of V + 2H - 2 triangles each and
    walls of 2 V, so 4 V + 4 H - 4 faces: an upper bound, fewer where holes touch each other at a
    point. (A polygon with thousands of holes is triangulated in tiles, which adds a few triangles
    along the tiles' seams: 270,036 faces for the 500 x 500 grid with 20,000 cells removed, bounded
    by 339,580 here.)
    """
    parts = shapely.get_parts(geometry)
    parts = parts[(shapely.get_type_id(parts) == 3) & ~shapely.is_empty(parts)]
    holes = shapely.get_num_interior_rings(parts)
    vertices = shapely.get_num_coordinates(parts) - holes - 1
    return int(np.sum(4 * vertices + 4 * holes - 4))


def _check_edge_contacts(pieces: Sequence[BaseGeometry], source: str) -> int:
    """Pairs of edges of different pieces that cross or touch; TerrainError beyond the budget's limits."""
    parts, part_piece = shapely.get_parts(np.asarray(pieces, dtype=object), return_index=True)
    rings, ring_part = shapely.get_rings(parts, return_index=True)
    xy, ring_of = shapely.get_coordinates(rings, return_index=True)
    same_ring = ring_of[1:] == ring_of[:-1]
    start, end = xy[:-1][same_ring], xy[1:][same_ring]
    owner = part_piece[ring_part[ring_of[:-1][same_ring]]]
    n_edges = len(owner)
    low, high = np.minimum(start, end), np.maximum(start, end)
    origin = low.min(axis=0)
    size = high.max(axis=0) - origin
    if size.max() <= 0.0:
        return 0
    size = np.maximum(size, size.max() / n_edges)  # a line of regions still gets a grid of n_edges cells
    cell = math.sqrt(size[0] * size[1] / n_edges)  # about one edge per cell
    # Pieces of edges no longer than a cell (in x and in y): each lies in at most 2 x 2 cells.
    count = np.maximum(1, np.ceil((high - low).max(axis=1) / cell)).astype(np.int64)
    n_pieces = int(count.sum())
    if n_pieces > CONTACT_CHECK_MAX_PIECES:
        raise field_error(source, "regions", f"the outlines are too long for their detail to check where regions "
                                             f"cross ({n_pieces} pieces of {cell:.3g} m); the limit is "
                                             f"{CONTACT_CHECK_MAX_PIECES}")
    edge = np.repeat(np.arange(n_edges), count)
    step = (np.arange(n_pieces) - np.repeat(np.cumsum(count) - count, count)) / count[edge]
    delta = (end - start)[edge]
    piece_a = start[edge] + delta * step[:, None]
    piece_b = start[edge] + delta * (step + 1.0 / count[edge])[:, None]
    first_cell = np.floor((np.minimum(piece_a, piece_b) - origin) / cell).astype(np.int64)
    last_cell = np.floor((np.maximum(piece_a, piece_b) - origin) / cell).astype(np.int64)
    columns = int(size[0] / cell) + 3
    keys = []
    for d_col in (0, 1):
        for d_row in (0, 1):
            use = (first_cell[:, 0] + d_col <= last_cell[:, 0]) & (first_cell[:, 1] + d_row <= last_cell[:, 1])
            keys.append(((first_cell[use, 1] + d_row) * columns + first_cell[use, 0] + d_col) * n_edges + edge[use])
    incidence = np.unique(np.concatenate(keys))  # (cell, edge) sorted, each once
    bucket, edge = incidence // n_edges, incidence % n_edges
    # Within a cell, each edge pairs with the edges of pieces listed after its own piece's (edges are
    # numbered piece by piece, so within a cell they are sorted by piece too).
    group = bucket * len(pieces) + owner[edge]
    partners = np.searchsorted(bucket, bucket, side="right") - np.searchsorted(group, group, side="right")
    n_candidates = int(partners.sum())
    if n_candidates > CONTACT_CHECK_MAX_CANDIDATES:
        raise field_error(source, "regions", f"edges of different regions lie close together in {n_candidates} "
                                             f"pairs; the limit is {CONTACT_CHECK_MAX_CANDIDATES}")
    group_end = np.searchsorted(group, group, side="right")
    first = np.repeat(edge, partners)
    second = edge[np.repeat(group_end - np.cumsum(partners) + partners, partners) + np.arange(n_candidates)]
    pair = np.unique(np.minimum(first, second) * n_edges + np.maximum(first, second))
    first, second = pair // n_edges, pair % n_edges
    contacts = int(np.count_nonzero(_segments_touch(start[first], end[first], start[second], end[second])))
    if contacts > MAX_EDGE_CONTACTS:
        raise field_error(source, "regions", f"edges of different regions cross or touch in {contacts} pairs; "
                                             f"the limit is {MAX_EDGE_CONTACTS}")
    return contacts


def _segments_touch(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Whether segments p1-p2 and q1-q2 (arrays (N, 2)) cross or touch (floating-point orientation tests)."""

    def turn(origin: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.sign((a[:, 0] - origin[:, 0]) * (b[:, 1] - origin[:, 1])
                       - (a[:, 1] - origin[:, 1]) * (b[:, 0] - origin[:, 0]))

    straddle = (turn(q1, q2, p1) * turn(q1, q2, p2) <= 0) & (turn(p1, p2, q1) * turn(p1, p2, q2) <= 0)
    boxes = (np.minimum(p1, p2) <= np.maximum(q1, q2)).all(axis=1) & (np.minimum(q1, q2) <= np.maximum(p1, p2)).all(
        axis=1)
    return straddle & boxes
