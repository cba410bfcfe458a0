"""Choosing a step from a ranking, shared by the oracle, ContactNet and the fixed gait: the step itself
(``PlannedStep``), the walk down a ranking to the first action whose landing points are safe
(``first_safe_step``; ``OneLevelWalk`` and ``HeightsWalk``, the same choice found faster on a terrain with one
level and with the height checks), stepping in place when there is none, and what a viewer is shown of the
ranking (``CandidateRanking``)."""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely

from contactnet.motion.gait import GaitSpec
from contactnet.planning import heights_walk, safe_walk
from contactnet.planning.heights_tables import CompiledHeights
from contactnet.terrain import Terrain


@dataclass(frozen=True)
class PlannedStep:
    """One step: the legs that swing and where each lands (world XY), plus how it was chosen."""

    legs: tuple[int, ...]
    footholds_xy_world: np.ndarray  # (len(legs), 2)
    action_index: int | None = None  # index in the gait's action set, when the planner uses it
    rank: int | None = None  # position of the chosen action in the planner's ranking (0 = best)
    discarded: int = 0  # candidates ranked better but rejected as unsafe
    safe: bool = True  # False when the planner knowingly steps where the terrain is unsafe
    captured: bool = False  # its candidates were shifted towards the capture point after a push (contactnet.planning.capture)

    @classmethod
    def ranked(cls, legs: tuple[int, ...], footholds_xy_world: np.ndarray, action_index: int,
               rank: int) -> PlannedStep:
        """``PlannedStep(legs, footholds_xy_world, action_index, rank, discarded=rank)``, built for the planners'
        hot path: a frozen dataclass's ``__init__`` sets each field through ``object.__setattr__`` (1.5 us a
        step, against 0.6 here); the instance is the same (``tests/test_planner_fast.py``)."""
        step = object.__new__(cls)
        step.__dict__.update(legs=legs, footholds_xy_world=footholds_xy_world, action_index=action_index, rank=rank,
                             discarded=rank, safe=True, captured=False)
        return step


#: The landing margin of the ranking planners and the oracle by default, in foot radii (half the ball: 8 mm on Solo12).
LANDING_MARGIN_RADII = 0.5
SAFETY_CHUNK = 8  # the best actions checked on their own before the whole candidate grid ...
WHOLE_GRID_MAX_POINTS = 48  # ... unless the grid is this small (trot: 36 cells): then the grid at once

#: A further test of landing points besides ``terrain.is_safe``: ``(legs (M,), landing_xy_world (M, 2)) ->
#: usable (M,) bool`` (the height checks of ``contactnet.planning.footholds`` on terrain with heights).
LandingCheck = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _usable(terrain: Terrain, margin_m: float, legs: np.ndarray | None, xy: np.ndarray,
            check: LandingCheck | None) -> np.ndarray:
    """(M,) bool: landing points ``xy`` (M, 2) of ``legs`` (M,) that are safe and pass ``check``."""
    safe = terrain.is_safe(xy, margin_m)
    if check is not None and safe.any():
        where = safe.nonzero()[0]
        safe[where] = check(legs[where], xy[where])
    return safe


def first_safe_step(
    gait: GaitSpec,
    order: np.ndarray,
    cell_xy_world: np.ndarray,
    foot_pos_world: np.ndarray,
    terrain: Terrain,
    margin_m: float,
    check: LandingCheck | None = None,
) -> PlannedStep:
    """Walk down ``order`` (action indices, best first) to the first action whose swinging legs all land on
    safe ground (``terrain.is_safe`` with ``margin_m``, and ``check`` when given). ``cell_xy_world`` (4,
    cells_per_leg, 2) is every leg's candidate grid; an action lands its legs on the cells ``gait.action_cells``
    names.

    The terrain is queried for all 4 x cells_per_leg cells at once, then every action is looked up in
    ranking order, so the cost does not depend on how deep into the ranking the holes push the choice.
    A large grid (walk: 100 cells, 1 leg per action) first tries the landing points of the best
    ``SAFETY_CHUNK`` actions on their own (the usual case: one of them is safe); a small one (trot: 36
    cells, 2 legs per action) is cheaper to query whole than to try a chunk first.

    ``rank`` is the chosen action's position in ``order`` and ``discarded`` how many better-ranked actions
    were unsafe (the same number). No safe action in ``order``: step in place (see ``OraclePlanner``).
    """
    order = np.asarray(order)
    cells_xy = np.asarray(cell_xy_world, dtype=float)
    action_legs, action_cells = gait.action_cells
    whole_grid = cells_xy.shape[0] * cells_xy.shape[1] <= WHOLE_GRID_MAX_POINTS
    safe = np.zeros(0, dtype=bool)
    if not whole_grid:
        head = order[:SAFETY_CHUNK]
        landing = cells_xy[action_legs[head], action_cells[head]]
        safe = _usable(terrain, margin_m, action_legs[head].ravel(), landing.reshape(-1, 2), check)
        safe = safe.reshape(landing.shape[:2]).all(axis=1)
    if not safe.any() and (whole_grid or len(order) > SAFETY_CHUNK):
        grid_legs = None if check is None else np.repeat(np.arange(cells_xy.shape[0]), cells_xy.shape[1])
        cell_safe = _usable(terrain, margin_m, grid_legs, cells_xy.reshape(-1, 2), check).astype(np.float32)
        safe = (gait.action_cell_incidence @ cell_safe == gait.legs_per_step)[order]
    rank = int(safe.argmax()) if len(safe) else 0
    if not len(safe) or not safe[rank]:
        return step_in_place(gait, order, foot_pos_world, terrain)
    index = int(order[rank])
    return PlannedStep(legs=gait.swing_groups[index // gait.actions_per_group],
                       footholds_xy_world=cells_xy[action_legs[index], action_cells[index]], action_index=index,
                       rank=rank, discarded=rank)


def cell_grid(gait: GaitSpec, footholds_xy_world: np.ndarray) -> np.ndarray:
    """(4, cells_per_leg, 2) every leg's candidate cells, from (N_a, 4, 2) feet after each action (the
    ranking cost's ``footholds_xy_world``). An action lands its legs on ``grid[gait.action_cells]``."""
    legs, cells = gait.action_cells
    grid = np.full((4, gait.cells_per_leg, 2), np.nan)
    grid[legs, cells] = np.asarray(footholds_xy_world)[np.arange(gait.n_actions)[:, None], legs]
    return grid


def step_in_place(gait: GaitSpec, order: np.ndarray, foot_pos_world: np.ndarray, terrain: Terrain,
                  margin_m: float = 0.0) -> PlannedStep:
    """No safe candidate: lift a group of legs and put them back where they are (``put_back``: a foot close to its top's
    edge a little further in). Groups are tried in the order their best action appears in
    ``order``; the first whose feet stand on safe ground is used (``safe=True``), else the first group with
    ``safe=False``."""
    group_of = np.asarray(order) // gait.actions_per_group
    first_seen = np.unique(group_of, return_index=True)[1]
    groups = group_of[np.sort(first_seen)].tolist()  # in the order their best action appears
    feet_xy = np.asarray(foot_pos_world, dtype=float)[:, 0:2]
    for group in groups:
        legs = gait.swing_groups[group]
        if terrain.is_safe(feet_xy[list(legs)], 0.0).all():
            return PlannedStep(legs=legs, footholds_xy_world=put_back(terrain, feet_xy[list(legs)], margin_m),
                               discarded=len(order))
    legs = gait.swing_groups[groups[0]]
    return PlannedStep(legs=legs, footholds_xy_world=feet_xy[list(legs)].copy(), discarded=len(order), safe=False)


def put_back(terrain: Terrain, feet_xy: np.ndarray, margin_m: float) -> np.ndarray:
    """(k, 2) where a step in place lands feet standing at ``feet_xy`` (k, 2) world: where they stand, except a foot
    closer than twice ``margin_m`` to the edge of its top, which lands at the nearest point twice the margin in, else
    at the nearest point the margin in (the least every chosen landing keeps), whichever is at most twice the margin
    away on a top of the same height. A foot stepping in place again and again drifts by up to a centimetre a step
    (its landing and its roll while the body moves) and, next to an edge, slides off it: put back where it stands,
    or just the margin in, it did on the field with 200 squares removed (docs/results.md)."""
    feet = np.array(feet_xy, dtype=float).reshape(-1, 2)
    if margin_m <= 0.0:
        return feet
    near_edge = ~terrain.is_safe(feet, 2.0 * margin_m) & terrain.is_safe(feet, 0.0)
    for i in np.flatnonzero(near_edge).tolist():
        foot = shapely.Point(feet[i])
        for depth in (2.0 * margin_m, margin_m):
            region = terrain.safe_region(depth)
            if region.is_empty:
                continue
            nearest = shapely.shortest_line(foot, region).coords[1]
            if (math.dist(nearest, feet[i]) <= 2.0 * margin_m
                    and terrain.height_at(np.array([nearest]))[0] == terrain.height_at(feet[i:i + 1])[0]):
                feet[i] = nearest
                break
    return feet


class CandidateRanking:
    """What a ranking planner saw for the step it executes now, for viewers: every candidate cell of every
    leg (world XY), whether it is safe, its best rank among the actions that use it, and the chosen
    cells. Built lazily (``cells()``): planning itself never pays for it. ``order`` is the ranking (action indices,
    best first) and ``cell_xy_world`` the (4, cells_per_leg, 2) grid of ``first_safe_step``; either may be given
    as a function that makes it (called once, when needed)."""

    def __init__(self, gait: GaitSpec, order: np.ndarray | Callable[[], np.ndarray],
                 cell_xy_world: np.ndarray | Callable[[], np.ndarray], terrain: Terrain, margin_m: float,
                 chosen_action: int | None, check: LandingCheck | None = None) -> None:
        self.check = check  # the planner's further test of landing points (heights), None on flat ground
        self.gait = gait
        self._order = order
        self._grid = cell_xy_world
        self.terrain = terrain
        self.margin_m = float(margin_m)
        self.chosen_action = chosen_action
        self._cells: tuple | None = None

    def cells(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[int, ...]]:
        """(xy_world (C, 2), safe (C,), leg (C,), rank (C,), chosen cell indices), C = 4 x cells per leg.
        Cells no ranked action uses get rank len(order)."""
        if self._cells is None:
            gait, order = self.gait, self.order
            n_cells = gait.cells_per_leg
            rank = np.full((4, n_cells), len(order), dtype=int)
            chosen: list[int] = []
            action_legs, action_cells = gait.action_cells
            for position, index in enumerate(order):
                for leg, cell in zip(action_legs[index], action_cells[index], strict=True):
                    if rank[leg, cell] == len(order):
                        rank[leg, cell] = position
                    if index == self.chosen_action:
                        chosen.append(leg * n_cells + cell)
            used = rank < len(order)
            xy_used = np.asarray(self.cell_xy_world, dtype=float)[used]
            leg_ids = np.repeat(np.arange(4), n_cells).reshape(4, n_cells)[used]
            flat_index = np.cumsum(used.ravel()) - 1
            chosen_used = tuple(int(flat_index[c]) for c in chosen)
            safe = _usable(self.terrain, self.margin_m, leg_ids, xy_used, self.check)
            self._cells = (xy_used, safe, leg_ids, rank[used], chosen_used)
        return self._cells

    @property
    def order(self) -> np.ndarray:
        """The ranking: action indices, best first."""
        if callable(self._order):
            self._order = self._order()
        return np.asarray(self._order)

    @property
    def cell_xy_world(self) -> np.ndarray:
        """(4, cells_per_leg, 2) every leg's candidate cells, see ``first_safe_step``."""
        if callable(self._grid):
            self._grid = self._grid()
        return self._grid

    @property
    def xy_world(self) -> np.ndarray:
        return self.cells()[0]

    @property
    def safe(self) -> np.ndarray:
        return self.cells()[1]

    @property
    def leg(self) -> np.ndarray:
        return self.cells()[2]

    @property
    def rank(self) -> np.ndarray:
        return self.cells()[3]

    @property
    def chosen(self) -> tuple[int, ...]:
        return self.cells()[4]


@dataclass(frozen=True)
class ActionCells:
    """A gait's actions as lists of grid cells, for walks down a ranking: ``flat[a]`` the cells action ``a`` lands
    its legs on (``leg * cells_per_leg + cell``, in the order of ``gait.action_cells``), ``group[a]`` its swinging
    legs (``gait.swing_groups``); ``flat_array`` (N_a, legs per step) the same as an array, ``leg_cell`` per grid
    cell its (leg, cell of the leg's grid), also as an array (cells, 2) (``leg_cell_array``)."""

    cells_per_leg: int
    legs_per_step: int
    flat: list[list[int]]
    group: list[tuple[int, ...]]
    flat_array: np.ndarray
    leg_cell: list[tuple[int, int]]
    leg_cell_array: np.ndarray

    @classmethod
    def of(cls, gait: GaitSpec) -> ActionCells:
        legs, cells = gait.action_cells
        flat = np.ascontiguousarray(legs * gait.cells_per_leg + cells, dtype=np.int64)
        group = [gait.swing_groups[a // gait.actions_per_group] for a in range(gait.n_actions)]
        leg_cell = [divmod(cell, gait.cells_per_leg) for cell in range(4 * gait.cells_per_leg)]
        return cls(gait.cells_per_leg, gait.legs_per_step, flat.tolist(), group, flat, leg_cell,
                   np.array(leg_cell, dtype=np.int64).reshape(-1, 2))


def one_level_grid(base_xy: list[float], hips_world: np.ndarray, offsets_world: np.ndarray) -> Callable[[], np.ndarray]:
    """A function making a step's (4, cells_per_leg, 2) candidate grid on one level (``first_safe_step``'s): the
    base XY ``base_xy`` plus each leg's hip reference ``hips_world`` (4, 2), plus each cell offset ``offsets_world``
    (cells_per_leg, 2), world, added in that order."""
    base = np.array(base_xy)
    return lambda: (base + hips_world)[:, None, :] + offsets_world[None]


class OneLevelWalk:
    """``first_safe_step`` for the steps of one plan on a terrain with one level (usable = safe), found faster: the
    compiled walk of ``contactnet.planning.safe_walk`` (no sort: the cheapest action not ruled out is tried, an unsafe cell
    rules out every action using it; each grid cell looked up once in the safe region's raster), with shapely asked
    here about the rare cells near an outline. The same choice as ``first_safe_step`` and the same floats: a landing point is (base + hip
    reference) + cell offset, added in that order as there. ``bases`` are the base XY of the plan's steps. With room
    for the foot's roll (``first_safe_with_room``, ``contactnet.planning.roll``) the point that far on is looked up
    in the same raster, no other region built."""

    def __init__(self, actions: ActionCells, terrain: Terrain, margin_m: float, hips_world: np.ndarray,
                 offsets_world: np.ndarray, bases: list[list[float]]) -> None:
        self.action_flat, self.flat_lists = actions.flat_array, actions.flat
        self.leg_cell, self.leg_cell_array = actions.leg_cell, actions.leg_cell_array
        self.terrain, self.locator = terrain, terrain.safe_locator(margin_m)
        self.hips_world, self.offsets_world, self.bases = hips_world, offsets_world, bases
        self.hips, self.offsets = hips_world.tolist(), offsets_world.tolist()

    def grid(self, step: int) -> Callable[[], np.ndarray]:
        """A function making step ``step``'s (4, cells_per_leg, 2) candidate grid (``one_level_grid``)."""
        return one_level_grid(self.bases[step], self.hips_world, self.offsets_world)

    def first_safe(self, step: int, costs: np.ndarray,
                   span: tuple[int, int] | None = None) -> tuple[int, int, list[list[float]]] | None:
        """(rank, action, its landing points [[x, y], ...]) of the first action of the stable ascending order of
        ``costs`` whose landing points are all safe, None if there is none. ``span`` (first, stop): only the
        actions ``first..stop - 1`` are ranked (default all)."""
        return self._walk(step, costs, span, None)

    def first_safe_with_room(self, step: int, costs: np.ndarray, span: tuple[int, int] | None,
                             ahead_xy: tuple[float, float],
                             per_group: int) -> tuple[int, int, list[list[float]]] | None:
        """``first_safe``'s answer with room for the foot's roll (``contactnet.planning.roll``): if a landing point
        of the first safe action lacks the room ``ahead_xy`` (world, metres), the first action of its swing group
        (``per_group`` actions each) in ``span`` whose landing points have it, with its rank in ``span``; else the
        first safe action. The same answer as ``first_safe`` followed by a walk over that group that asks every landing
        point for the room, in one compiled call (``safe_walk.first_safe_with_room``)."""
        return self._walk(step, costs, span, (float(ahead_xy[0]), float(ahead_xy[1]), per_group))

    def _walk(self, step: int, costs: np.ndarray, span: tuple[int, int] | None,
              room: tuple[float, float, int] | None) -> tuple[int, int, list[list[float]]] | None:
        """``first_safe`` (``room`` None) or ``first_safe_with_room`` (``room``: ahead x, y and actions per group)."""
        base_x, base_y = self.bases[step]
        first, stop = span or (0, len(costs))
        locator = self.locator
        outline = locator.outline
        if locator.codes.size == 0:  # no safe region at all
            return None
        cells = len(self.leg_cell)
        known = np.zeros(cells if room is None else 2 * cells, dtype=np.int8)
        hips, offsets = self.hips, self.offsets
        while True:
            if room is None:
                status, rank, index = safe_walk.first_safe(
                    costs, first, stop, self.action_flat, self.leg_cell_array, self.hips_world, self.offsets_world,
                    base_x, base_y, locator.raster, locator.codes, outline.entries, outline.row_first, known)
            else:
                status, rank, index = safe_walk.first_safe_with_room(
                    costs, first, stop, room[2], self.action_flat, self.leg_cell_array, self.hips_world,
                    self.offsets_world, base_x, base_y, locator.raster, locator.codes, outline.entries,
                    outline.row_first, known[:cells], known[cells:], room[0], room[1])
            if status != safe_walk.ASK:
                break
            # a point on an outline: shapely answers (PointLocator.covers_xy); a cell past ``cells`` is asked with
            # the room ahead of it
            leg, cell = self.leg_cell[index % cells]
            x, y = (base_x + hips[leg][0]) + offsets[cell][0], (base_y + hips[leg][1]) + offsets[cell][1]
            safe = locator.covers_xy(x, y) and (index < cells or locator.covers_xy(x + room[0], y + room[1]))
            known[index] = safe_walk.SAFE if safe else safe_walk.UNSAFE
        if status == safe_walk.NONE:
            return None
        points = []
        for flat in self.flat_lists[index]:
            leg, cell = self.leg_cell[flat]
            points.append([(base_x + hips[leg][0]) + offsets[cell][0], (base_y + hips[leg][1]) + offsets[cell][1]])
        return rank, index, points


def _legs_of(bits: int) -> np.ndarray:
    """(4,) bool, read-only: the legs whose bit is set in ``bits``."""
    legs = np.array([bits & 1, bits & 2, bits & 4, bits & 8], dtype=bool)
    legs.flags.writeable = False
    return legs


#: The cornered legs (4,) bool (read-only) of each bit mask, None for none (``HeightsWalk.cornered``).
_CORNERED = (None, *(_legs_of(bits) for bits in range(1, 16)))


class HeightsWalk:
    """``first_safe_step`` with the height checks (``contactnet.planning.footholds``) as its ``check``, for the steps of
    a plan on a terrain with tops at several heights, found faster: the compiled walk of
    ``contactnet.planning.heights_walk`` (no sort: the first action of the ranking not ruled out is tried; each grid
    cell placed, moved to the centre of a small top as ``FootholdChecker.centred`` does, and tested for safety and
    ``FootholdChecker.usable``'s checks at most once), with the questions it leaves here answered: a point where
    only shapely can answer (``TopParts.locator.index_xy``, ``PointLocator.covers_xy``, ``HeightLocator.height_xy``,
    ``Terrain.height_at`` of the ring around the foot ball), a top part's centre (``FootholdChecker._centres``), and
    a landing or a stance whose check lies too close to its limit for the compiled floats (``FootholdChecker.usable``
    and ``stance_clear`` themselves). The same choice as ``first_safe_step``, and the same floats: a landing point
    is (base + hip reference) + cell offset as there, or the top's centre.

    One walk serves a planner's plans on one terrain: ``start`` begins a plan (and reads the tops under the feet),
    ``first_usable`` walks a step, ``took`` says which action the step took. The plan's state lives in one array
    (``plan``). ``hip_xy_base`` (4, 2) are the hips (flexion joints) in the base frame; a step's hips at touchdown
    are its hip base + the hips turned into the world + the commanded velocity x ``touchdown_s``. On the first step
    the legs whose stance would corner them with the hips ``lookahead_s`` of motion further
    (``FootholdChecker.stance_clear``) are ``cornered``, and the actions landing one of them at least
    ``min_progress_m`` ahead of its foot along the heading go first."""

    def __init__(self, actions: ActionCells, terrain: Terrain, margin_m: float, compiled: CompiledHeights,
                 hip_xy_base: np.ndarray, touchdown_s: float, lookahead_s: float = 0.0,
                 min_progress_m: float = 0.0) -> None:
        self.actions, self.terrain, self.margin_m, self.compiled = actions, terrain, margin_m, compiled
        self.checker, self.hip_xy_base = compiled.checker, hip_xy_base
        self.touchdown_s, self.lookahead_s = touchdown_s, lookahead_s
        self.tables, self.constants = compiled.tables(terrain), compiled.constants
        self._scratch = compiled.scratch(4 * actions.cells_per_leg, len(actions.flat))
        self._constants = [min_progress_m, terrain.surface_z, touchdown_s, lookahead_s]
        self._legs_per_step = actions.legs_per_step
        self.plan = np.zeros(0)
        self.cornered: np.ndarray | None = None  # (4,) bool after step 0's walk, None when no leg is cornered
        self._moved = -1  # the action the last step took
        self._urgent: np.ndarray | None = None  # step 0's urgent actions when its walk found none usable

    def start(self, hips_world: np.ndarray, offsets_world: np.ndarray, bases: list[list[float]], yaw_rad: float,
              hip_bases: list[list[float]], cmd_world: list[float], feet: list[list[float]],
              forward_xy: tuple[float, float]) -> list[float]:
        """Begin a plan; the tops under the feet (``Terrain.ground_z``). ``hips_world`` (4, 2) and ``offsets_world``
        (cells_per_leg, 2): the hip references and the cell offsets in the world frame; ``bases``: each step's base
        for the candidate grid, ``hip_bases`` for the hips; ``cmd_world`` the commanded velocity; ``feet`` where
        the feet stand; ``forward_xy`` the heading's cosine and sine (numpy's)."""
        # (the kernels read arrays as C-contiguous: ``heights_lookup.borrow``)
        hips_world, offsets_world = np.ascontiguousarray(hips_world, float), np.ascontiguousarray(offsets_world, float)
        self.hips_world, self.offsets_world, self.bases, self.yaw_rad = hips_world, offsets_world, bases, yaw_rad
        self.hip_bases, self.cmd_world, self.forward_xy = hip_bases, cmd_world, forward_xy
        self.cornered, self._moved = None, -1
        plan = self.plan
        if plan.size != 30 + 4 * len(bases):
            plan = self.plan = np.zeros(30 + 4 * len(bases))
            plan[:heights_walk.PER_PLAN] = self._constants
            self._pack = struct.Struct(f"{plan.size - heights_walk.PER_PLAN}d").pack_into  # (3x numpy's list copy)
            self._plan_bytes = memoryview(plan).cast("B")
        nan = math.nan
        self._pack(self._plan_bytes, 8 * heights_walk.PER_PLAN, math.cos(yaw_rad), math.sin(yaw_rad), *forward_xy,
                   *cmd_world, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, *feet[0], *feet[1], *feet[2], *feet[3], nan, nan,
                   nan, nan, *sum(bases, []), *sum(hip_bases, []))
        scratch, tables = self._scratch, self.tables
        self._arguments = (self.actions.flat_array, hips_world, offsets_world, plan, scratch.flags, scratch.values,
                           tables.floats, tables.ints, tables.wide_codes, tables.narrow_codes, self.constants.floats)
        while True:
            leg = heights_walk.prepare(plan, *self._arguments[6:])
            if leg < 0:
                return plan[heights_walk.TOPS: heights_walk.TOPS + 4].tolist()
            z = tables.heights.height_xy(*plan[heights_walk.FEET + 2 * leg: heights_walk.FEET + 2 * leg + 2].tolist())
            plan[heights_walk.TOPS + leg] = self.terrain.surface_z if z != z else z

    def took(self, action: int | None) -> None:
        """The last step took ``action`` (its landing points as ``first_usable`` found them), None for one that
        moved no foot (standing, or a step in place)."""
        self._moved = -1 if action is None else action

    def feet_xy(self) -> np.ndarray:
        """(4, 2) where the feet stand now."""
        return self.plan[heights_walk.FEET: heights_walk.FEET + 8].reshape(4, 2).copy()

    def tops(self) -> np.ndarray:
        """(4,) the tops under the feet now."""
        return self.plan[heights_walk.TOPS: heights_walk.TOPS + 4].copy()

    def hips_at(self, step: int, after_s: float | None = None) -> Callable[[], np.ndarray]:
        """A function making the (4, 2) hips at step ``step``'s touchdown (or ``after_s`` after its start), numpy's
        arithmetic, from the plan now."""
        c, s = self.forward_xy
        hip_xy_base, hip_base, cmd_world = self.hip_xy_base, self.hip_bases[step], self.cmd_world
        touchdown_s = self.touchdown_s

        def make() -> np.ndarray:
            hips_base = hip_xy_base @ np.array([[c, -s], [s, c]]).T
            if after_s is None:
                return np.array(hip_base) + (hips_base + np.array(cmd_world) * touchdown_s)
            return np.array(hip_base) + hips_base + np.array(cmd_world) * after_s

        return make

    def check(self, step: int) -> LandingCheck:
        """The height checks of landing points from the state now, as step ``step`` makes them
        (``FootholdChecker.usable``; for views: the state is read now, the rest when the check is first called)."""
        plan, hips_at, checker, terrain, yaw_rad = self.plan.copy(), self.hips_at(step), self.checker, self.terrain, \
            self.yaw_rad

        def usable(legs: np.ndarray, landing_xy: np.ndarray) -> np.ndarray:
            feet = plan[heights_walk.FEET: heights_walk.FEET + 8].reshape(4, 2)
            tops = plan[heights_walk.TOPS: heights_walk.TOPS + 4]
            return checker.usable(terrain, legs, landing_xy, feet[legs], hips_at()[legs], tops, yaw_rad)

        return usable

    def grid(self, step: int) -> Callable[[], np.ndarray]:
        """A function making step ``step``'s (4, cells_per_leg, 2) candidate grid, small tops' cells centred
        (``FootholdChecker.centred``'s points)."""
        small_inradius, parts = self.checker.checks.small_top_inradius_m, self.tables.parts
        (base_x, base_y), hips_world, offsets_world = self.bases[step], self.hips_world, self.offsets_world

        def make() -> np.ndarray:
            x = (base_x + hips_world[:, 0])[:, None] + offsets_world[:, 0]  # (4, cells per leg)
            y = (base_y + hips_world[:, 1])[:, None] + offsets_world[:, 1]
            grid = np.empty(x.shape + (2,))
            grid[..., 0], grid[..., 1] = x, y
            points = grid.reshape(-1, 2)
            part = parts.locator.indices_of(np.array([x.ravel(), y.ravel()]))
            small = (part >= 0) & (parts.inradius_m[part] <= small_inradius)
            points[small] = parts.centres_xy[part[small]]
            return grid
        return make

    def first_usable(self, step: int, costs: np.ndarray,
                     span: tuple[int, int]) -> tuple[int, int, list[list[float]], list[float]] | None:
        """(rank, action, its landing points, the tops under them) of the first action of the ranking (``costs``
        of the actions ``span`` = (first, stop) in stable ascending order; on step 0 with a cornered leg the actions
        moving it forward first: ``urgent``) whose landing points are all safe and usable from the state now (see
        ``FootholdChecker.usable``); None if there is none."""
        first, stop = span
        fresh, moved = (2 if step == 0 else 1), self._moved
        costs = np.ascontiguousarray(costs)
        while True:
            status, rank, action, kind, index, x0, y0, z0, x1, y1, z1 = heights_walk.walk_step(
                costs, first, stop, step, fresh, moved, *self._arguments)
            if status != heights_walk.ASK:
                break
            fresh, moved = 0, -1
            if kind == heights_walk.STANCE:  # numpy's checks decide
                clear = self.checker.stance_clear(self.terrain, self.feet_xy(), self.tops(),
                                                  self.hips_at(0, self.lookahead_s)(), self.yaw_rad)
                self._scratch.cornered[:] = ~clear
                fresh = 1
            else:
                self._answer(step, kind, index)
        self._moved = -1
        if step == 0:  # kind: the cornered legs, a bit each
            self.cornered = _CORNERED[kind]
            self._urgent = None
        if status == heights_walk.NONE:
            if step == 0 and kind:  # every action's urgency is known (none usable): its ranking needs them
                self._urgent = self._scratch.urgent[first:stop] == 2
            return None
        if self._legs_per_step == 1:
            return rank, action, [[x0, y0]], [z0]
        if self._legs_per_step == 2:
            return rank, action, [[x0, y0], [x1, y1]], [z0, z1]
        item = self._scratch.points.item  # (x, y, part, top) per landing point
        flats = self.actions.flat[action]
        return rank, action, [[item(flat, 0), item(flat, 1)] for flat in flats], [item(flat, 3) for flat in flats]

    def urgent(self, span: tuple[int, int], grid: Callable[[], np.ndarray]) -> Callable[[], np.ndarray]:
        """A function making step 0's urgent actions (bool per action of ``span``), which its ranking puts first:
        those landing a cornered leg at least the least progress ahead (numpy's arithmetic on the walk's numbers,
        read now; ``grid``: ``grid(0)``). Call after step 0's walk, with a leg cornered."""
        plan, cornered, (forward_x, forward_y), flat = self.plan.copy(), self.cornered, self.forward_xy, \
            self.actions.flat_array[span[0]: span[1]]
        known = self._urgent  # the walk's, when it found nothing

        def make() -> np.ndarray:
            if known is not None:
                return known
            cells = grid()  # (4, cells_per_leg, 2)
            feet = plan[heights_walk.FEET: heights_walk.FEET + 8].reshape(4, 2)
            progress = ((cells[:, :, 0] - feet[:, 0, None]) * forward_x
                        + (cells[:, :, 1] - feet[:, 1, None]) * forward_y)
            promote = ((progress >= plan[heights_walk.MIN_PROGRESS]) & cornered[:, None]).ravel()
            return np.logical_or.reduce(promote[flat], axis=1)

        return make

    def _answer(self, step: int, kind: int, index: int) -> None:
        """Answer the compiled walk's question ``kind`` about grid cell (or, for ``CENTRE``, top part) ``index``."""
        tables = self.tables
        if kind == heights_walk.CENTRE:
            tables.answer_centre(index)
            return
        scratch = self._scratch
        points, answers, answered = scratch.points, scratch.answers, scratch.answered
        x, y = points[index, 0].item(), points[index, 1].item()
        if kind == heights_walk.PART:
            value = tables.parts.locator.index_xy(x, y)
        elif kind == heights_walk.SAFE:
            value = tables.safe_covers(x, y)
        elif kind == heights_walk.TOP:
            value = tables.heights.height_xy(x, y)
        elif kind == heights_walk.RING:
            ring = slice(heights_walk.RING, heights_walk.RING + heights_walk.RING_POINTS)
            answers[index, ring] = self.terrain.height_at(points[index, :2] + self.constants.ring, outside=-np.inf)
            answered[index, ring] = 1
            return
        else:  # UNSURE: numpy's checks decide
            legs = np.array([index // self.actions.cells_per_leg])
            at_centre = scratch.cell_state[heights_walk.CENTRED, index: index + 1] != 0
            value = self.checker.usable(self.terrain, legs, points[index: index + 1, :2], self.feet_xy()[legs],
                                        self.hips_at(step)()[legs], self.tops(), self.yaw_rad,
                                        part=points[index: index + 1, 2].astype(np.intp), at_centre=at_centre)[0]
        answers[index, kind] = float(value)
        answered[index, kind] = 1


def urgent_first(order: np.ndarray, urgent: np.ndarray | None, first: int = 0) -> np.ndarray:
    """``order`` (action indices from ``first``) with the ``urgent`` ones (bool per action of the span) first, each
    part in its own order (``HeightsWalk``'s ranking with a cornered leg)."""
    if urgent is None:
        return order
    mask = urgent[order - first]
    return np.concatenate([order[mask], order[~mask]])
