"""Exact lookups compiled with numba for the walk of ``contactnet.planning.heights_walk``: on a terrain with
heights, the top part under a point (``part_at``, as ``TopParts.part_at``), the top under it (``height_at``, as
``Terrain.height_at``), the upper bound of the tops (``upper_at``, as ``Terrain.height_bound``) with its tiles
(``tile_at``) and its neighbour cells (``upper_near``), from the arrays of a
``contactnet.planning.heights_tables.TerrainTables``; in a ranking, the next action in the stable ascending order of
the costs without sorting them (``order_keys``, ``next_action``, ``heap_after``).

The rasters of ``contactnet.terrain.locate`` answer a point from its cell, except in a cell next to an outline, where
they ask shapely about the regions that cell touches. Compiled, those regions are asked here: a point in a polygon as
GEOS locates it (``covers``: ``RayCrossingCounter``, a horizontal ray's crossings, a point on a segment or a vertex
covered), each segment's side decided by the orientation's sign with Shewchuk's error bound. When the bound cannot
decide (the point within rounding of a segment's line) or two parts with the same top cover the point
(``CoverLocator.index_xy`` asks its exact answer then), the lookup answers ``UNDECIDED`` and the walk asks the
caller, who asks shapely. So every answer is shapely's (``tests/test_heights_walk.py``).

numba caches a compiled function by the file it is defined in: the walk's kernels, which inline these, are
recompiled only when ``heights_walk.py`` changes. ``heights_walk.LOOKUP_SOURCE`` records this file's hash, and a test
fails until it is updated with it, so a change here is also a change there.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

#: ``upper_near``: the walk's floats of a point may differ from numpy's by less than this (metres, see
#: ``heights_walk``).
EPS_M = 1e-6
#: ``part_at`` / ``covers``: the compiled lookup cannot decide (shapely must).
UNDECIDED = -3
#: The upper bounds' raster's tiles (their highest code, widened by a cell: an upper bound for pruning) and blocks
#: (their code when uniform), 2**TILE_BITS and 2**BLOCK_BITS cells square (``TerrainTables``).
TILE_BITS, BLOCK_BITS = 4, 2
_CCW_BOUND = (3.0 + 16.0 * 2.0**-53) * 2.0**-53  # Shewchuk's ccwerrboundA


@intrinsic
def _void_pointer(typingctx, address):  # noqa: ANN001, ANN202 - numba's intrinsic protocol
    """The integer ``address`` as a void pointer (for ``borrow``)."""
    def codegen(context, builder, signature, args):  # noqa: ANN001, ANN202
        return builder.inttoptr(args[0], cgutils.voidptr_t)
    return types.voidptr(address), codegen


@numba.njit(cache=True, nogil=True, inline="always")
def borrow(array: np.ndarray) -> np.ndarray:
    """``array``'s data as an array that does not own it (no reference count): the kernels pass such views to their
    helpers, where each owned array argument costs two atomic reference-count updates per call (most of the time of
    the walk's inner calls). Only while ``array`` itself is alive, i.e. within the call that received it, and for a
    C-contiguous ``array`` (the callers pass no other)."""
    return numba.carray(_void_pointer(array.ctypes.data), array.shape, array.dtype)


@numba.njit(cache=True, nogil=True, inline="always")
def _orientation(x1: float, y1: float, x2: float, y2: float, x: float, y: float) -> int:
    """The sign of the orientation of (p1, p2, p): 1 counterclockwise (p left of p1 -> p2), -1 clockwise, 0
    collinear, exactly; 2 when rounding leaves it open."""
    left = (x1 - x) * (y2 - y)
    right = (y1 - y) * (x2 - x)
    det = left - right
    if (left > 0.0 and right <= 0.0) or (left < 0.0 and right >= 0.0) or (left == 0.0 and right == 0.0):
        return 1 if det > 0.0 else (-1 if det < 0.0 else 0)  # no cancellation: the sign is exact
    bound = _CCW_BOUND * (abs(left) + abs(right))
    if det > bound:
        return 1
    if -det > bound:
        return -1
    return 2


@numba.njit(cache=True, nogil=True)
def covers(ints: np.ndarray, coords: np.ndarray, geometry: int, x: float, y: float) -> int:
    """1 if geometry ``geometry`` of ``Outlines`` covers (x, y) (its boundary included), 0 if not, UNDECIDED."""
    n = ints[0]
    crossings = 0
    for ring in range(ints[1 + geometry], ints[2 + geometry]):
        start, stop = ints[2 + n + ring], ints[3 + n + ring]
        for i in range(start, stop - 1):
            x1, y1, x2, y2 = coords[i, 0], coords[i, 1], coords[i + 1, 0], coords[i + 1, 1]
            if x1 < x and x2 < x:
                continue
            if x == x2 and y == y2:
                return 1
            if y1 == y and y2 == y:
                if min(x1, x2) <= x <= max(x1, x2):
                    return 1
                continue
            if (y1 > y and y2 <= y) or (y2 > y and y1 <= y):
                sign = _orientation(x1, y1, x2, y2, x, y)
                if sign == 0:
                    return 1
                if sign == 2:
                    return UNDECIDED
                if y2 < y1:
                    sign = -sign
                if sign > 0:
                    crossings += 1
    return crossings & 1


@numba.njit(cache=True, nogil=True, inline="always")
def terrain_views(floats: np.ndarray, ints: np.ndarray) -> tuple:
    """``TerrainTables.floats`` and ``ints`` unpacked (not owning their data, see ``borrow``): (rasters, code_z,
    part_values, part_coords, region_coords, part_tops, region_tops, part_ints, region_ints)."""
    floats, ints = borrow(floats), borrow(ints)
    return (floats[ints[0]: ints[1]].reshape((4, 6)), floats[ints[1]: ints[2]].reshape((2, ints[7])),
            floats[ints[2]: ints[3]].reshape((ints[8], 6)), floats[ints[3]: ints[4]].reshape((ints[9], 2)),
            floats[ints[4]: ints[5]].reshape((ints[10], 2)), floats[ints[5]: ints[6]],
            floats[ints[6]: ints[6] + ints[11]], ints[ints[15]: ints[16]], ints[ints[16]:])


@numba.njit(cache=True, nogil=True, inline="always")
def code_views(ints: np.ndarray, wide_codes: np.ndarray, narrow_codes: np.ndarray) -> tuple:
    """``TerrainTables.wide_codes`` and ``narrow_codes`` unpacked (not owning their data, see ``borrow``): the codes of
    the parts', the safe region's, the tops' and the upper bounds' rasters, and the upper bounds' ``coarse`` codes."""
    wide, narrow = borrow(wide_codes), borrow(narrow_codes)
    cover, safe, upper = ints[12], ints[13], ints[14]
    return wide[:cover], narrow[:safe], wide[cover:], narrow[safe: safe + upper], narrow[safe + upper:]


@numba.njit(cache=True, nogil=True, inline="always")
def raster_cell(x: float, y: float, rasters: np.ndarray, which: int) -> int:
    """The index of (x, y)'s cell in raster ``which`` of ``TerrainTables.rasters``: the arithmetic of
    ``contactnet.terrain.locate``'s lookups."""
    col = x * rasters[which, 0] - rasters[which, 1]
    row = y * rasters[which, 0] - rasters[which, 2]
    if not col > 0.0:  # also NaN
        col = 0.0
    elif col > rasters[which, 3]:
        col = rasters[which, 3]
    if not row > 0.0:
        row = 0.0
    elif row > rasters[which, 4]:
        row = rasters[which, 4]
    return int(col) + int(row) * int(rasters[which, 5])


@numba.njit(cache=True, nogil=True)
def part_at(x: float, y: float, rasters: np.ndarray, cover_codes: np.ndarray, part_ints: np.ndarray,
            part_coords: np.ndarray, part_tops: np.ndarray) -> int:
    """``TopParts.part_at`` of one point (``CoverLocator.index_xy``): the part, -1 for none, or UNDECIDED."""
    code = cover_codes[raster_cell(x, y, rasters, 0)]
    if code >= -1:
        return code
    boundary = -2 - code
    offset = 1 + part_ints[0]  # the candidates, after the starts
    outlines = part_ints[offset + part_ints[part_ints[0]]:]
    best, best_z, tie = -1, -math.inf, False
    for j in range(part_ints[1 + boundary], part_ints[2 + boundary]):
        part = part_ints[offset + j]
        inside = covers(outlines, part_coords, part, x, y)
        if inside == UNDECIDED:
            return UNDECIDED
        if inside:
            if part_tops[part] > best_z:
                best, best_z, tie = part, part_tops[part], False
            elif part_tops[part] == best_z:
                tie = True
    return UNDECIDED if tie else best


@numba.njit(cache=True, nogil=True)
def height_at(x: float, y: float, rasters: np.ndarray, height_codes: np.ndarray, code_z: np.ndarray,
              region_ints: np.ndarray, region_coords: np.ndarray, region_tops: np.ndarray) -> tuple[float, bool]:
    """(``Terrain.height_at`` of one point, NaN for no top; decided): ``HeightLocator.height_xy``."""
    code = height_codes[raster_cell(x, y, rasters, 2)]
    if code >= 0:
        return code_z[0, code], True
    boundary = -2 - code
    offset = 1 + region_ints[0]
    outlines = region_ints[offset + region_ints[region_ints[0]]:]
    best = -math.inf
    for j in range(region_ints[1 + boundary], region_ints[2 + boundary]):
        region = region_ints[offset + j]
        inside = covers(outlines, region_coords, region, x, y)
        if inside == UNDECIDED:
            return math.nan, False
        if inside and region_tops[region] > best:
            best = region_tops[region]
    return (best if best > -math.inf else math.nan), True


@numba.njit(cache=True, nogil=True, inline="always")
def _block(col: int, row: int, rasters: np.ndarray, coarse: np.ndarray) -> int:
    """The code of cell (col, row)'s block of the upper bounds' raster (2**BLOCK_BITS cells square): its cells' code
    when they all have the same, else ``rasters[3, 5]`` (mixed)."""
    tiles, blocks = int(rasters[3, 2]), int(rasters[3, 4])
    return coarse[tiles * tiles + (row >> BLOCK_BITS) * blocks + (col >> BLOCK_BITS)]


@numba.njit(cache=True, nogil=True, inline="always")
def upper_at(x: float, y: float, rasters: np.ndarray, upper_codes: np.ndarray, code_z: np.ndarray,
             coarse: np.ndarray) -> float:
    """``HeightLocator.upper_heights_of`` (outside: -inf) of one point (its block's code when uniform)."""
    cell = raster_cell(x, y, rasters, 2)
    side = int(rasters[2, 5])
    code = _block(cell % side, cell // side, rasters, coarse)
    if code == rasters[3, 5]:
        code = upper_codes[cell]
    return code_z[1, code]


@numba.njit(cache=True, nogil=True, inline="always")
def tile_at(x: float, y: float, rasters: np.ndarray, coarse: np.ndarray, code_z: np.ndarray) -> float:
    """An upper bound of ``upper_at`` of (x, y) and of the cells next to its cell: its tile's."""
    cell = raster_cell(x, y, rasters, 2)
    side, tiles = int(rasters[2, 5]), int(rasters[3, 2])
    return code_z[1, coarse[((cell // side) >> TILE_BITS) * tiles + ((cell % side) >> TILE_BITS)]]


@numba.njit(cache=True, nogil=True, inline="always")
def _clamped(value: float, hi: float) -> int:
    if not value > 0.0:
        return 0
    if value > hi:
        return int(hi)
    return int(value)


@numba.njit(cache=True, nogil=True, inline="always")
def upper_near(x: float, y: float, allowed: float, rasters: np.ndarray, upper_codes: np.ndarray,
               code_z: np.ndarray, coarse: np.ndarray) -> tuple[float, float]:
    """(lowest, highest) upper bound of the top (``HeightLocator.upper_heights_of``, -inf for none) over the raster
    cells within ``EPS_M`` of (x, y): the same unless the point numpy computes may fall in another cell. (-inf, an
    upper bound) when the cells' tile lies ``EPS_M`` below ``allowed``. The raster is read from its tiles and blocks
    (``TerrainTables``, a few kB) where they tell, from its cells (a MB) only next to an outline."""
    col = x * rasters[2, 0] - rasters[2, 1]
    row = y * rasters[2, 0] - rasters[2, 2]
    col_i, row_i = _clamped(col, rasters[2, 3]), _clamped(row, rasters[2, 4])
    tiles = int(rasters[3, 2])
    tile = code_z[1, coarse[(row_i >> TILE_BITS) * tiles + (col_i >> TILE_BITS)]]
    if tile - allowed <= -EPS_M:
        return -math.inf, tile
    reach = EPS_M * rasters[2, 0]
    c0, c1 = _clamped(col - reach, rasters[2, 3]), _clamped(col + reach, rasters[2, 3])
    r0, r1 = _clamped(row - reach, rasters[2, 4]), _clamped(row + reach, rasters[2, 4])
    block = _block(col_i, row_i, rasters, coarse)
    if (block != rasters[3, 5] and c0 >> BLOCK_BITS == c1 >> BLOCK_BITS
            and r0 >> BLOCK_BITS == r1 >> BLOCK_BITS):  # every cell near the point in one uniform block
        z = code_z[1, block]
        return z, z
    side = int(rasters[2, 5])
    z = code_z[1, upper_codes[col_i + row_i * side]]
    low, high = z, z
    if c0 != c1 or r0 != r1:
        for c in (c0, c1):
            for r in (r0, r1):
                other = code_z[1, upper_codes[c + r * side]]
                low, high = min(low, other), max(high, other)
    return low, high


@numba.njit(cache=True, nogil=True, inline="always")
def order_keys(costs: np.ndarray, first: int, stop: int, values: np.ndarray) -> np.ndarray:
    """Integer keys of ``costs[first:stop]`` in the ascending order of the costs with NaN last: a float's bits made to
    sort as integers, -0 as +0, NaN above everything. ``values``: room for them."""
    values = values[: stop - first]
    for a in range(first, stop):
        value = costs[a]
        values[a - first] = 0.0 if value == 0.0 else value  # (-0 -> +0; NaN stays NaN)
    keys = values.view(np.uint64)
    for i in range(keys.shape[0]):
        if values[i] != values[i]:
            keys[i] = 0xFFFFFFFFFFFFFFFF
        elif keys[i] >> 63:
            keys[i] = ~keys[i]
        else:
            keys[i] |= 0x8000000000000000
    return keys


@numba.njit(cache=True, nogil=True, inline="always")
def _before(a: int, b: int, keys: np.ndarray, first: int) -> bool:
    """Whether action ``a`` comes before ``b``: the ascending order of their keys (``order_keys``), ties by index."""
    key_a, key_b = keys[a - first], keys[b - first]
    return key_a < key_b or (key_a == key_b and a < b)


@numba.njit(cache=True, nogil=True, inline="always")
def sift_down(heap: np.ndarray, i: int, n: int, keys: np.ndarray, first: int) -> None:
    """Restore the order of the binary heap ``heap[:n]`` (the first action at the root) below ``i``."""
    item = heap[i]
    while True:
        child = 2 * i + 1
        if child >= n:
            break
        if child + 1 < n and _before(heap[child + 1], heap[child], keys, first):
            child += 1
        if not _before(heap[child], item, keys, first):
            break
        heap[i] = heap[child]
        i = child
    heap[i] = item


@numba.njit(cache=True, nogil=True, inline="always")
def next_action(keys: np.ndarray, first: int, stop: int, urgent: np.ndarray, skip: int, last: int) -> int:
    """The action of ``first..stop - 1`` that comes next after action ``last`` (-1: the first) in the stable
    ascending order of their costs (``keys``), leaving out those with ``urgent`` equal to ``skip``; -1 for none. A
    pass over the actions: the walk usually needs only the first few."""
    best, best_key, last_key = -1, keys[0], keys[0]
    if last >= 0:
        last_key = keys[last - first]
    for a in range(first, stop):
        if urgent[a] == skip:
            continue
        key = keys[a - first]
        if last >= 0 and (key < last_key or (key == last_key and a <= last)):
            continue
        if best < 0 or key < best_key:  # (of equal keys the first met, the lower index, stays)
            best, best_key = a, key
    return best


@numba.njit(cache=True, nogil=True, inline="always")
def heap_after(heap: np.ndarray, keys: np.ndarray, first: int, stop: int, urgent: np.ndarray, skip: int,
                last: int) -> int:
    """``heap`` made a binary heap of the actions of ``first..stop - 1`` after action ``last`` (as ``next_action``
    orders and leaves out), the first at its root: its size. Made in linear time, it gives each next action in
    logarithmic time, for the rare walk deep into a ranking."""
    last_key, n = keys[last - first], 0
    for a in range(first, stop):
        key = keys[a - first]
        if urgent[a] != skip and (key > last_key or (key == last_key and a > last)):
            heap[n] = a
            n += 1
    for i in range(n // 2 - 1, -1, -1):
        sift_down(heap, i, n, keys, first)
    return n


__all__ = ["BLOCK_BITS", "EPS_M", "TILE_BITS", "UNDECIDED", "borrow", "code_views", "covers", "heap_after", "height_at",
           "next_action", "order_keys", "part_at", "raster_cell", "sift_down", "terrain_views", "tile_at", "upper_at",
           "upper_near"]
