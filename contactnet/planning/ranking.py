"""Choosing a step from a ranking, shared by the oracle, ContactNet and the fixed gait: the step itself
(``PlannedStep``), the walk down a ranking to the first action whose landing points are safe
(``first_safe_step``; ``OneLevelWalk`` and ``HeightsWalk``, the same choice found faster on a terrain with one
level and with the height checks), stepping in place when there is none, and what a viewer is shown of the
ranking (``CandidateRanking``)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from contactnet.motion.gait import GaitSpec
from contactnet.planning import safe_walk
from contactnet.planning.footholds import FootholdChecker
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


def step_in_place(gait: GaitSpec, order: np.ndarray, foot_pos_world: np.ndarray, terrain: Terrain) -> PlannedStep:
    """No safe candidate: lift a group of legs and put them back where they are. Groups are tried in the
    order their best action appears in ``order``; the first whose feet stand on safe ground is used
    (``safe=True``), else the first group with ``safe=False``."""
    groups = list(dict.fromkeys(int(a) // gait.actions_per_group for a in np.asarray(order)))
    feet_xy = np.asarray(foot_pos_world, dtype=float)[:, 0:2]
    for group in groups:
        legs = gait.swing_groups[group]
        if terrain.is_safe(feet_xy[list(legs)], 0.0).all():
            return PlannedStep(legs=legs, footholds_xy_world=feet_xy[list(legs)].copy(), discarded=len(order))
    legs = gait.swing_groups[groups[0]]
    return PlannedStep(legs=legs, footholds_xy_world=feet_xy[list(legs)].copy(), discarded=len(order), safe=False)


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


class OneLevelWalk:
    """``first_safe_step`` for the steps of one plan on a terrain with one level (usable = safe), found faster: the
    compiled walk of ``contactnet.planning.safe_walk`` (no sort: the cheapest action not ruled out is tried, an unsafe cell
    rules out every action using it; each grid cell looked up once in the safe region's raster), with shapely asked
    here about the rare cells near an outline. The same choice as ``first_safe_step`` and the same floats: a landing point is (base + hip
    reference) + cell offset, added in that order as there. ``bases`` are the base XY of the plan's steps."""

    def __init__(self, actions: ActionCells, terrain: Terrain, margin_m: float, hips_world: np.ndarray,
                 offsets_world: np.ndarray, bases: list[list[float]]) -> None:
        self.action_flat, self.flat_lists = actions.flat_array, actions.flat
        self.leg_cell, self.leg_cell_array = actions.leg_cell, actions.leg_cell_array
        self.locator = terrain.safe_locator(margin_m)
        self.hips_world, self.offsets_world, self.bases = hips_world, offsets_world, bases
        self.hips, self.offsets = hips_world.tolist(), offsets_world.tolist()

    def grid(self, step: int) -> Callable[[], np.ndarray]:
        """A function making step ``step``'s (4, cells_per_leg, 2) candidate grid (``first_safe_step``'s)."""
        base_xy = np.array(self.bases[step])
        return lambda: (base_xy + self.hips_world)[:, None, :] + self.offsets_world[None]

    def first_safe(self, step: int, costs: np.ndarray,
                   span: tuple[int, int] | None = None) -> tuple[int, int, list[list[float]]] | None:
        """(rank, action, its landing points [[x, y], ...]) of the first action of the stable ascending order of
        ``costs`` whose landing points are all safe, None if there is none. ``span`` (first, stop): only the
        actions ``first..stop - 1`` are ranked (default all)."""
        base_x, base_y = self.bases[step]
        first, stop = span or (0, len(costs))
        locator = self.locator
        if locator.codes.size == 0:  # no safe region at all
            return None
        known = np.zeros(len(self.leg_cell), dtype=np.int8)
        hips, offsets = self.hips, self.offsets
        while True:
            status, rank, index = safe_walk.first_safe(
                costs, first, stop, self.action_flat, self.leg_cell_array, self.hips_world, self.offsets_world,
                base_x, base_y, locator.raster, locator.codes, known)
            if status != safe_walk.ASK:
                break
            leg, cell = self.leg_cell[index]  # a cell near an outline: shapely answers (PointLocator.covers_xy)
            x, y = (base_x + hips[leg][0]) + offsets[cell][0], (base_y + hips[leg][1]) + offsets[cell][1]
            known[index] = safe_walk.SAFE if locator.covers_xy(x, y) else safe_walk.UNSAFE
        if status == safe_walk.NONE:
            return None
        points = []
        for flat in self.flat_lists[index]:
            leg, cell = self.leg_cell[flat]
            points.append([(base_x + hips[leg][0]) + offsets[cell][0], (base_y + hips[leg][1]) + offsets[cell][1]])
        return rank, index, points


#: ``HeightsWalk``: the first batch of landing points whose height checks are run together is this many per leg of a
#: step (8 on the walk's grid, 16 on the trot's); the next is all the rest.
FIRST_BATCH_POINTS = 8
_PENDING = object()  # a landing point whose height checks are asked in the current batch


class HeightsWalk:
    """``first_safe_step`` with the height checks (``contactnet.planning.footholds``) as its ``check``, for the steps of
    one plan on a terrain with tops at several heights, found faster.

    Down the ranking, each landing point is placed (the candidate grid's cell, moved to the centre of a small
    top: ``FootholdChecker.centred``, with ``TopParts.locator.index_xy``) and tested for safety one at a time
    in Python floats (``PointLocator.covers_xy``); the safe ones whose height checks are not known yet are
    gathered, ``FIRST_BATCH_POINTS`` per leg of a step (then all the rest), and checked together in one call of
    ``FootholdChecker.usable`` (which costs about the same for one point as for a hundred). The walk stops at
    the first action whose points are all safe and usable, as ``first_safe_step`` does. The same choice and the
    same floats: a landing point is (base + hip reference) + cell offset as there, or the top's centre."""

    def __init__(self, actions: ActionCells, terrain: Terrain, margin_m: float, checker: FootholdChecker,
                 hips_world: np.ndarray, offsets_world: np.ndarray, bases: list[list[float]], yaw_rad: float) -> None:
        self.actions, self.terrain, self.margin_m, self.checker = actions, terrain, margin_m, checker
        self.hips_world, self.offsets_world, self.bases, self.yaw_rad = hips_world, offsets_world, bases, yaw_rad
        self.hips, self.offsets = hips_world.tolist(), offsets_world.tolist()
        self.parts = terrain.top_parts()
        self.part_at = self.parts.locator.index_xy
        self.centres, self.inradius = self.parts.lists
        self.small_inradius = checker.checks.small_top_inradius_m
        self.covers = terrain.safe_locator(margin_m).covers_xy

    def grid(self, step: int) -> Callable[[], np.ndarray]:
        """A function making step ``step``'s (4, cells_per_leg, 2) candidate grid, small tops' cells centred
        (``FootholdChecker.centred``'s points)."""
        def make() -> np.ndarray:
            base_x, base_y = self.bases[step]
            x = (base_x + self.hips_world[:, 0])[:, None] + self.offsets_world[:, 0]  # (4, cells per leg)
            y = (base_y + self.hips_world[:, 1])[:, None] + self.offsets_world[:, 1]
            grid = np.empty(x.shape + (2,))
            grid[..., 0], grid[..., 1] = x, y
            points = grid.reshape(-1, 2)
            part = self.parts.locator.indices_of(np.array([x.ravel(), y.ravel()]))
            small = (part >= 0) & (self.parts.inradius_m[part] <= self.small_inradius)
            points[small] = self.parts.centres_xy[part[small]]
            return grid
        return make

    def first_usable(self, step: int, ranking: np.ndarray, feet_xy: np.ndarray, tops_z: np.ndarray,
                     hips_xy_world: np.ndarray) -> tuple[int, int, list[list[float]]] | None:
        """(rank, action, its landing points) of the first action of ``ranking`` whose landing points are all
        safe and usable from the state ``feet_xy`` (4, 2), ``tops_z`` (4,), hips at touchdown ``hips_xy_world``
        (4, 2) (see ``FootholdChecker.usable``), None if there is none."""
        n_cells = self.actions.cells_per_leg
        place: list = [None] * (4 * n_cells)  # per grid cell: (x, y, part, at centre) if safe, else False
        usable: list = [None] * (4 * n_cells)  # per grid cell: its height checks (or _PENDING)
        flat_lists, order = self.actions.flat, ranking.tolist()
        start, limit = 0, FIRST_BATCH_POINTS * self.actions.legs_per_step
        while True:
            pending: list[int] = []
            for rank in range(start, len(order)):
                action = order[rank]
                flats, known = flat_lists[action], True
                for flat in flats:
                    spot = place[flat]
                    if spot is None:
                        spot = place[flat] = self._place(step, flat)
                    if spot is False or usable[flat] is False:
                        break
                    known = known and usable[flat] is True
                else:
                    if known:  # safe and usable: the choice, unless a point before awaits its checks
                        if not pending:
                            return rank, action, [place[flat][:2] for flat in flats]
                        break
                    for flat in flats:
                        if usable[flat] is None:
                            usable[flat] = _PENDING
                            pending.append(flat)
                    if len(pending) >= limit:
                        break
                    continue
                if not pending:
                    start = rank + 1  # every action before is unusable
            if not pending:
                return None
            legs = np.array(pending) // n_cells
            spots = [place[flat] for flat in pending]
            result = self.checker.usable(
                self.terrain, legs, np.array([spot[:2] for spot in spots]), feet_xy[legs], hips_xy_world[legs],
                tops_z, self.yaw_rad, part=np.array([spot[2] for spot in spots]),
                at_centre=np.array([spot[3] for spot in spots])).tolist()
            for flat, ok in zip(pending, result, strict=True):
                usable[flat] = ok
            limit = len(place)

    def _place(self, step: int, flat: int) -> list | bool:
        """Grid cell ``flat`` of step ``step``: [x, y, top part, moved to its centre] if safe there, else False."""
        leg, cell = divmod(flat, self.actions.cells_per_leg)
        base_x, base_y = self.bases[step]
        x = (base_x + self.hips[leg][0]) + self.offsets[cell][0]
        y = (base_y + self.hips[leg][1]) + self.offsets[cell][1]
        part = self.part_at(x, y)
        at_centre = part >= 0 and self.inradius[part] <= self.small_inradius
        if at_centre:
            x, y = self.centres[part]
        return [x, y, part, at_centre] if self.covers(x, y) else False
