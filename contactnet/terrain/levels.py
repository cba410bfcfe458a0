"""The tops of a terrain with heights: which part of the steppable set has its top at which height.

Every region's top is flat, at its ``z`` (default the terrain's ``surface_z``), and where regions
overlap the highest top wins. So the part whose top is at height z (a *level*) is the union of the
regions at z minus the union of the regions above z. A terrain whose regions are all at one height
has one level, the steppable union itself, and never comes here.

The regions at each height are united, and each union is cut only by the parts of higher unions
that meet it (found with an STRtree), so the work grows with how much regions at different heights
overlap, not with the number of heights. Two
limits of the complexity budget (``contactnet.terrain.schema``) bound it: the pairs of parts whose
bounding boxes overlap (``MAX_LEVEL_PAIRS``) and the vertices of the higher parts that cut lower
ones (``MAX_LEVEL_CUT_VERTICES``); the mesh the levels become is bounded by ``MAX_MESH_FACES``.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.errors import GEOSException
from shapely.geometry.base import BaseGeometry

from contactnet.terrain.schema import MAX_LEVEL_CUT_VERTICES, MAX_LEVEL_PAIRS, MAX_MESH_FACES, field_error
from contactnet.terrain.union import UNION_GRID_SIZE_M, mesh_face_bound, unite

Level = tuple[float, BaseGeometry]
"""(z, the part of the steppable set whose top is at z): world metres, a (Multi)Polygon."""
_QUERY_CHUNK = 128  # parts per bounding-box query: at most 128 x parts pairs in memory before the limit bites


def terrain_levels(pieces: np.ndarray, tops_z: np.ndarray, source: str) -> tuple[Level, ...]:
    """The levels of regions at several heights, highest first: ``pieces`` are the regions' snapped
    geometries (``union.region_pieces``), ``tops_z`` their tops. TerrainError beyond the budget."""
    return terrain_levels_keyed(pieces, tops_z, np.zeros(len(pieces), dtype=np.int64), source)[0]


def terrain_levels_keyed(pieces: np.ndarray, tops_z: np.ndarray, plane_ids: np.ndarray,
                         source: str) -> tuple[tuple[Level, ...], np.ndarray]:
    """``terrain_levels`` where regions are grouped by (top z, plane id), not by z alone: a sloped region has its
    own plane id (its level's z is the plane's height at the region's centre), flat ones 0. Where they overlap,
    the level with the higher (z, id) wins. Returns (levels highest first, the plane id of each level)."""
    keep = ~shapely.is_empty(pieces)
    pieces, tops_z = pieces[keep], np.asarray(tops_z, dtype=float)[keep]
    ids = np.asarray(plane_ids, dtype=np.int64)[keep]
    keys = np.unique(np.rec.fromarrays([tops_z, ids], names="z,id"))  # sorted by z, then id
    level_of_piece = np.searchsorted(keys, np.rec.fromarrays([tops_z, ids], names="z,id"))
    heights, level_ids = keys["z"], keys["id"]
    counts = np.bincount(level_of_piece)
    groups = np.split(pieces[np.argsort(level_of_piece, kind="stable")], np.cumsum(counts)[:-1])
    united = np.array([group[0] if len(group) == 1 else unite(group) for group in groups], dtype=object)
    parts, level = shapely.get_parts(united, return_index=True)
    lower, higher = _overlapping_pairs(parts, level, source)
    shapely.prepare(parts)
    size = shapely.get_num_coordinates(parts)
    big_first = size[lower] >= size[higher]  # a prepared big part answers fast; a small one would scan the big one
    meet = shapely.intersects(np.where(big_first, parts[lower], parts[higher]),
                              np.where(big_first, parts[higher], parts[lower]))
    cut = np.unique(level[lower[meet]] * len(parts) + higher[meet])  # (lower level, higher part), each once
    cut_level, cut_by = cut // len(parts), cut % len(parts)
    cut_vertices = int(size[cut_by].sum())
    if cut_vertices > MAX_LEVEL_CUT_VERTICES:
        raise field_error(source, "regions", f"regions at different heights overlap in too much detail (the "
                                             f"higher ones cut the lower ones with {cut_vertices} vertices); "
                                             f"the limit is {MAX_LEVEL_CUT_VERTICES}")
    visible = united.copy()
    if cut.size:
        levels_cut, first = np.unique(cut_level, return_index=True)
        covers = np.array([parts[group[0]] if len(group) == 1 else unite(parts[group])
                           for group in np.split(cut_by, first[1:])], dtype=object)
        visible[levels_cut] = _difference(united[levels_cut], covers)
    shown, shown_level = shapely.get_parts(visible, return_index=True)
    polygonal = (shapely.get_type_id(shown) == 3) & (shapely.area(shown) > 0.0)
    shown, shown_level = shown[polygonal], shown_level[polygonal]
    faces = mesh_face_bound(shown)
    if faces > MAX_MESH_FACES:
        raise field_error(source, "regions", f"the tops at {len(heights)} heights need up to {faces} mesh faces "
                                             f"(4 per outline vertex and per hole); the limit is {MAX_MESH_FACES}")
    order = np.argsort(-shown_level, kind="stable")  # highest first
    shown, shown_level = shown[order], shown_level[order]
    starts = np.flatnonzero(np.r_[True, shown_level[1:] != shown_level[:-1]])
    levels = tuple((float(heights[shown_level[i]]), group[0] if len(group) == 1 else shapely.multipolygons(group))
                   for i, group in zip(starts, np.split(shown, starts[1:]), strict=True))
    return levels, np.asarray(level_ids[shown_level[starts]] if len(starts) else [], dtype=np.int64)


def eroded_levels(levels: tuple[Level, ...], margin_m: float) -> BaseGeometry:
    """The safe set of a terrain with several levels: every level shrunk by ``margin_m`` on its own (so a
    point next to a riser is unsafe on both sides of it), united.

    Shrunk polygon by polygon (GEOS shrinks a MultiPolygon by uniting its parts' results: 15 s for 3,500
    parts): the polygons of a level touch at most at points, so a disk inside their union lies inside one
    of them, and the shrunk polygons are apart. They are then one MultiPolygon, united only if not valid.
    """
    parts = shapely.get_parts(np.array([geometry for _, geometry in levels], dtype=object))
    eroded = shapely.get_parts(shapely.buffer(parts, -margin_m, quad_segs=16))
    eroded = eroded[~shapely.is_empty(eroded)]
    if not len(eroded):
        return shapely.Polygon()
    safe = eroded[0] if len(eroded) == 1 else shapely.multipolygons(eroded)
    return safe if shapely.is_valid(safe) else unite(eroded)


def _overlapping_pairs(parts: np.ndarray, level: np.ndarray, source: str) -> tuple[np.ndarray, np.ndarray]:
    """(lower, higher): indices of the parts at different levels whose bounding boxes overlap, the first at the
    lower level. TerrainError once more than ``MAX_LEVEL_PAIRS`` pairs of parts (any levels) overlap so."""
    tree = shapely.STRtree(parts)
    lower, higher = [], []
    pairs = 0
    for start in range(0, len(parts), _QUERY_CHUNK):
        first, second = tree.query(parts[start: start + _QUERY_CHUNK])
        first += start
        pairs += int(np.count_nonzero(first < second))
        if pairs > MAX_LEVEL_PAIRS:
            raise field_error(source, "regions", f"regions at different heights: more than {MAX_LEVEL_PAIRS} pairs "
                                                 f"of their parts lie across each other (bounding boxes)")
        up = level[first] < level[second]
        lower.append(first[up])
        higher.append(second[up])
    return np.concatenate(lower), np.concatenate(higher)


def _difference(parts: np.ndarray, covers: np.ndarray) -> np.ndarray:
    """``parts - covers`` element by element; with snap-rounding at the union's grid when GEOS's floating
    overlay fails on nearly coincident edges."""
    try:
        return shapely.difference(parts, covers)
    except GEOSException:  # pragma: no cover - robustness fallback
        return shapely.difference(parts, covers, grid_size=UNION_GRID_SIZE_M)
