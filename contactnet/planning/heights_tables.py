"""What the compiled walk on a terrain with heights (``contactnet.planning.heights_walk``) reads, made from Python
objects: a terrain's rasters and outlines as arrays (``TerrainTables``, with ``Outlines``), a foothold checker's numbers
(``KernelConstants``), the walk's scratch arrays (``Scratch``), and a planner's set of them (``CompiledHeights``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from contactnet.planning.footholds import FootholdChecker
from contactnet.planning.heights_lookup import BLOCK_BITS, TILE_BITS
from contactnet.planning.heights_walk import RING_POINTS, SLOTS
from contactnet.terrain import Terrain


class Outlines:
    """Polygonal geometries (G,) as arrays: ``ints`` = [G, ring starts (G + 1), coordinate starts (R + 1)] of each
    geometry's rings (every polygon's shell and holes) and ``coords`` (C, 2), every ring closed."""

    def __init__(self, geometries: np.ndarray) -> None:
        geometries = np.asarray(geometries, dtype=object)
        parts, part_geometry = shapely.get_parts(geometries, return_index=True)
        rings, ring_part = shapely.get_rings(parts, return_index=True)
        coords, coord_ring = shapely.get_coordinates(rings, return_index=True)
        ring_starts = np.searchsorted(part_geometry[ring_part], np.arange(len(geometries) + 1))
        coord_starts = np.searchsorted(coord_ring, np.arange(len(rings) + 1))
        self.ints = np.concatenate([[len(geometries)], ring_starts, coord_starts]).astype(np.int64)
        self.coords = np.ascontiguousarray(coords, dtype=float).reshape(-1, 2)


class TerrainTables:
    """One terrain's lookups as arrays, for one safety margin and one checker: the rasters of its top parts
    (``TopParts.locator``), of its safe region and of its tops (``Terrain.height_locator``), the outlines of the parts
    and of the regions those rasters ask about next to an outline, and what is known of each top part's centre (its
    top, the foot ball's room there, its safety: asked once, kept). ``CompiledHeights`` keeps the last terrain's."""

    def __init__(self, terrain: Terrain, margin_m: float, checker: FootholdChecker) -> None:
        self.terrain, self.margin_m, self.checker = terrain, margin_m, checker
        self.parts = parts = terrain.top_parts()
        self.heights = heights = terrain.height_locator()
        safe = terrain.safe_locator(margin_m)
        self.safe_covers = safe.covers_xy
        cover = parts.locator
        # (inv_cell, first col, first row, last col, last row, columns) of the part, safe and top rasters; then
        # (the highest top, TILE_BITS, tiles per side, -, blocks per side, the code of a mixed block): see below
        self.rasters = np.array([
            [cover.inv_cell, cover.first_cell[0], cover.first_cell[1], cover.clamp_hi[0], cover.clamp_hi[1],
             cover.n_cols],
            [safe.inv_cell, safe.first_cell[0], safe.first_cell[1], safe.clamp_hi, safe.clamp_hi, safe.strides[1]],
            [heights.inv_cell, heights.first_cell[0], heights.first_cell[1], heights.clamp_hi, heights.clamp_hi,
             heights.strides[1]]], dtype=float)
        self.safe_codes = safe.codes
        if not safe.codes.size:  # no safe region: one cell, outside
            self.safe_codes, self.rasters[1] = np.zeros(1, dtype=np.uint8), [1.0, 0.0, 0.0, 0.0, 0.0, 1.0]
        self.cover_codes, self.height_codes = cover.codes, heights.codes
        # The upper bounds' codes in the fewest bytes (a byte for up to 254 distinct tops): the outline checks look
        # up about a hundred points each, and a smaller raster keeps more of them in the caches.
        self.upper_codes = heights.upper_codes.astype(np.min_scalar_type(len(heights.code_z)))
        self.code_z = np.array([heights.code_z, heights._code_z_below])  # (2, D + 1): NaN / -inf for no top
        # The upper bounds' raster, coarse: per tile of it (2**TILE_BITS cells square, widened by a cell on each side)
        # its highest code (codes rise with the tops: a lookup whose tile lies below what a check allows needs no
        # cell), and per block (2**BLOCK_BITS cells square) the code of its cells when they all have the same, else
        # ``mixed``: a few kB that answer most lookups, where the cells are a MB.
        side = int(heights.strides[1])
        codes = heights.upper_codes.reshape(side, side)
        mixed = len(heights.code_z)  # (no code)
        dtype = np.result_type(safe.codes.dtype, np.min_scalar_type(mixed))
        tiles = -(-side // (1 << TILE_BITS))
        padded = np.zeros((tiles * (1 << TILE_BITS) + 2, tiles * (1 << TILE_BITS) + 2), dtype=codes.dtype)
        padded[1: side + 1, 1: side + 1] = codes
        rows = np.maximum(np.maximum(padded[:-2], padded[1:-1]), padded[2:])  # each cell and its neighbours
        widened = np.maximum(np.maximum(rows[:, :-2], rows[:, 1:-1]), rows[:, 2:])
        tile_codes = widened.reshape(tiles, 1 << TILE_BITS, tiles, 1 << TILE_BITS).max(axis=(1, 3))
        blocks = -(-side // (1 << BLOCK_BITS))
        cells = np.full((blocks << BLOCK_BITS, blocks << BLOCK_BITS), -1, dtype=np.int64)
        cells[:side, :side] = codes
        cells = cells.reshape(blocks, 1 << BLOCK_BITS, blocks, 1 << BLOCK_BITS)
        lowest, highest = cells.min(axis=(1, 3)), cells.max(axis=(1, 3))
        block_codes = np.where(lowest == highest, highest, mixed)
        finite = heights.code_z[1:]
        highest_z = float(finite.max()) if finite.size else -np.inf
        self.rasters = np.concatenate([self.rasters, [[highest_z, TILE_BITS, tiles, 0.0, blocks, mixed]]])
        part_outlines, region_outlines = Outlines(parts.polygons), Outlines(heights.geometries)
        # The parts: [starts of each BOUNDARY cell's candidates, candidates, outlines], their tops; the regions alike.
        self.part_ints = np.concatenate([[len(cover.starts)], cover.starts, cover.candidates,
                                         part_outlines.ints]).astype(np.int64)
        self.part_coords, self.part_tops = part_outlines.coords, np.ascontiguousarray(parts.tops_z, dtype=float)
        self.region_ints = np.concatenate([[len(heights.starts)], heights.starts, heights.candidates,
                                           region_outlines.ints]).astype(np.int64)
        self.region_coords, self.region_tops = region_outlines.coords, np.ascontiguousarray(heights.tops_z, dtype=float)
        n = len(parts.polygons)
        # Per part (a row each, one cache line): inradius, centre x, y, and at the centre the top, the ball's room and
        # whether it is safe (-1: not asked yet).
        part_values = np.column_stack([parts.inradius_m, parts.centres_xy, np.full((n, 3), -1.0)]).reshape(n, 6)
        self.centres_list = parts.lists[0]
        # Packed for the kernels (fewer arguments, each costing a numba call about 0.1 us): the floats, then the
        # integers, their header first (``terrain_views`` unpacks them), and the rasters' codes in two arrays: the
        # parts' and the tops' (int32); the safe region's, the upper bounds' and their tiles and blocks
        # (``code_views``).
        pieces = [self.rasters, self.code_z, part_values, self.part_coords, self.region_coords, self.part_tops,
                  self.region_tops]
        starts = np.cumsum([0] + [piece.size for piece in pieces])
        self.floats = np.concatenate([piece.ravel() for piece in pieces])
        self.tile_codes, self.block_codes = tile_codes.astype(dtype), block_codes.astype(dtype)
        self.wide_codes = np.concatenate([self.cover_codes, self.height_codes])
        self.narrow_codes = np.concatenate([self.safe_codes.astype(dtype), self.upper_codes.astype(dtype),
                                            self.tile_codes.ravel(), self.block_codes.ravel()])
        header = [*starts[:-1], len(heights.code_z), n, len(self.part_coords), len(self.region_coords),
                  len(self.region_tops), len(self.cover_codes), len(self.safe_codes), len(self.upper_codes)]
        ints_at = len(header) + 2
        self.ints = np.concatenate([header, [ints_at, ints_at + len(self.part_ints)], self.part_ints,
                                    self.region_ints]).astype(np.int64)
        self.part_values = self.floats[starts[2]: starts[3]].reshape(n, 6)  # (a view: filled in as asked)
        self.coarse = self.narrow_codes[len(self.safe_codes) + len(self.upper_codes):]

    def answer_centre(self, part: int) -> None:
        """Fill in what is known of part ``part``'s centre (``FootholdChecker._centres``, ``covers_xy``)."""
        top, ball = self.checker._centres(self.terrain, np.array([part]))
        x, y = self.centres_list[part]
        self.part_values[part, 3:] = top[0], float(ball[0]), float(self.safe_covers(x, y))


@dataclass(frozen=True)
class KernelConstants:
    """A ``FootholdChecker``'s numbers as arrays for the kernels: ``legs`` (12, 4) per leg, ``scalars``, ``samples``
    (4, S) along a leg's outline (share of the shank's extent and of the hip's offset, the knee housing's reach, the
    clearance) and ``vectors``: the outline's lines (the axis and a line to each side), the fractions along the swing,
    the offsets beside a leaning foot, the ring around the foot ball (x, y pairs). The rows of ``legs`` and the
    entries of ``scalars`` are in the order of ``heights_walk``'s names for them (``_KNEE_SIDE``..., ``_FOOT_R``...)."""

    legs: np.ndarray
    scalars: np.ndarray
    samples: np.ndarray
    vectors: np.ndarray
    ring: np.ndarray  # (RING_POINTS, 2), as in ``vectors``
    floats: np.ndarray  # all of it in one array for the kernels: [len(scalars), scalars, legs, samples, vectors]

    @classmethod
    def of(cls, checker: FootholdChecker) -> KernelConstants:
        geo, checks, k = checker.legs, checker.checks, checker._k
        legs = np.array([geo.knee_side, geo.hip_above_foot_m, geo.plane_left_m, geo.shank_m,
                         checker._squared_difference, k.hip_offset_z, k.hip_offset_x, k.slope_weight,
                         k.late.astype(float), k.knee_direction, geo.hip_pos_base[:, 0], geo.hip_pos_base[:, 1]],
                        dtype=float)
        if len(checker._ring) != RING_POINTS:
            raise ValueError(f"the foot ball's ring has {len(checker._ring)} points, the kernel {RING_POINTS}")
        scalars = np.array([geo.foot_radius_m, float(k.front_to_hind), float(k.pitch_share), float(k.com_height),
                            float(k.reach), checks.max_lean_m, checks.shin_lever_margin_m, checks.min_shin_lever_m,
                            float(k.tiny), checks.stance_travel_m, checks.max_step_m, checks.ball_tolerance_m,
                            checks.small_top_inradius_m, checks.fallback_shin_elevation_rad,
                            float(checker._known_knees), len(checker._lines), len(checker._path_fractions),
                            len(checker._side_offsets), len(checker._clearance_m)])
        samples = np.array([checker._share[0], checker._share[1], checker._knee_reach, checker._clearance_m])
        vectors = np.concatenate([checker._lines, checker._path_fractions, checker._side_offsets,
                                  checker._ring.ravel()])
        floats = np.concatenate([[len(scalars)], scalars, legs.ravel(), samples.ravel(), vectors])
        return cls(np.ascontiguousarray(legs), scalars, np.ascontiguousarray(samples), vectors,
                   np.ascontiguousarray(checker._ring), floats)


class Scratch:
    """``walk_step``'s ``flags`` (int8: per grid cell its state and which answers it has, per action whether it is
    urgent, the cornered legs and four zeros) and ``values`` (per grid cell its point, top part and top, and the
    answers; room for the walk's work) for ``cells`` grid cells and ``n_actions`` actions, with views of their
    parts."""

    def __init__(self, cells: int, n_actions: int) -> None:
        self.size = (cells, n_actions)
        state_end = 4 * cells + cells * SLOTS
        self.flags = np.zeros(state_end + n_actions + 8, dtype=np.int8)
        self.values = np.zeros(4 * cells + cells * SLOTS + 8 + 2 * n_actions)
        self.cell_state = self.flags[: 4 * cells].reshape(4, cells)
        self.answered = self.flags[4 * cells: state_end].reshape(cells, SLOTS)
        self.urgent = self.flags[state_end: state_end + n_actions]
        self.cornered = self.flags[state_end + n_actions: state_end + n_actions + 4]
        self.points = self.values[: 4 * cells].reshape(cells, 4)
        self.answers = self.values[4 * cells: 4 * cells + cells * SLOTS].reshape(cells, SLOTS)


class CompiledHeights:
    """The compiled height checks of one planner (its checker and safety margin): ``tables(terrain)`` (the last
    terrain's, rebuilt when the terrain is another object), the constants the kernels read (``KernelConstants``)
    and the walk's scratch arrays (``scratch``)."""

    def __init__(self, checker: FootholdChecker, margin_m: float) -> None:
        self.checker, self.margin_m = checker, margin_m
        self.constants = KernelConstants.of(checker)
        self._tables: TerrainTables | None = None
        self._scratch: Scratch | None = None

    def scratch(self, cells: int, n_actions: int) -> Scratch:
        """The walk's scratch arrays for ``cells`` grid cells and ``n_actions`` actions, made once and reused."""
        scratch = self._scratch
        if scratch is None or scratch.size != (cells, n_actions):
            scratch = self._scratch = Scratch(cells, n_actions)
        return scratch

    def tables(self, terrain: Terrain) -> TerrainTables:
        """The arrays of ``terrain`` (``TerrainTables``), kept while the planner plans on that terrain object."""
        tables = self._tables
        if tables is None or tables.terrain is not terrain:
            tables = self._tables = TerrainTables(terrain, self.margin_m, self.checker)
        return tables


__all__ = ["CompiledHeights", "KernelConstants", "Outlines", "Scratch", "TerrainTables"]
