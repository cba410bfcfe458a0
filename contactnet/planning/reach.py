"""A leg left behind goes first (issue 32): a stance foot about to leave its leg's reach is stepped before the others.

Traced on the frontier's falls (random field with 155-185 squares removed, walk and trot, and `narrow_map`'s bars;
ContactNet, current defaults): in each, one stance foot stayed where it was while the body went on at the
commanded velocity (the planner stood, or stepped other legs, or found nothing safe), until the foot was 18-20 cm
from its hip reference, against the 15 cm the ranking cost's kinematic term allows (``kin_threshold_m``); then it
slid off its top, or the leg's shin met an edge. On `narrow_map`'s 3 cm bars with an 18 cm last gap (seed 0) the
hind left foot stood on the second bar for 6.5 s; one plan had a safe cell for it on the third bar, 21st in the
network's ranking, and took the front right leg's first choice instead. The network was trained on flat ground,
where a foot is never left that far behind, and does not rank such a leg first.

So on the first step of a plan, the legs whose stance foot will be further than ``threshold_m`` (default: the
robot's ``kin_threshold_m``) from its hip reference after ``lookahead_steps`` steps of the commanded motion are
*left behind*; the first safe action in the network's ranking among those moving one of them is taken (with the
room for the roll as any choice), and the robot does not stand. With none safe in a gait that moves several legs a
step (the trot), such a leg steps alone (``alone_step``) to the first safe cell of its own in the order the network
ranks its groups' actions, its partners staying; with none of those either, the plan is the plain one.
``ContactNetPlanner(reach=None)`` turns it off; the fixed gait (the paper's baseline) keeps its order. It applies on
terrain of one level; on terrain with heights the cornered legs (``contactnet.planning.planner``) order the first
step instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from contactnet.planning.ranking import PlannedStep
from contactnet.planning.safe_walk import rank_of

if TYPE_CHECKING:
    from contactnet.planning.ranking import ActionCells, OneLevelWalk
    from contactnet.terrain import Terrain


@dataclass(frozen=True)
class ReachConfig:
    """When a stance foot counts as left behind."""

    lookahead_steps: float = 2.0  # steps of commanded motion ahead of the plan's start
    threshold_m: float | None = None  # horizontal foot-to-hip-reference distance; None: the robot's kin_threshold_m
    # With no safe action of its swing groups, a leg left behind steps alone in a gait moving several legs a step
    step_alone: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lookahead_steps) and self.lookahead_steps >= 0.0):
            raise ValueError(f"ReachConfig.lookahead_steps must be a finite number >= 0, got {self.lookahead_steps!r}")
        if self.threshold_m is not None and not (math.isfinite(self.threshold_m) and self.threshold_m > 0.0):
            raise ValueError(f"ReachConfig.threshold_m must be a finite number > 0 or None, got {self.threshold_m!r}")


#: The planner's default (``ContactNetPlanner(reach=None)`` turns it off).
DEFAULT_REACH = ReachConfig()


def left_behind(feet_xy_world: list[list[float]], hips_xy_world: list[list[float]], shift_x: float, shift_y: float,
                threshold_m: float) -> list[int]:
    """The legs whose foot ``feet_xy_world`` is further than ``threshold_m`` from its hip reference ``hips_xy_world``
    moved by ``shift_x, shift_y`` (the commanded motion over the look-ahead, world metres); none for a threshold 0
    (no reach test). Python floats; the squared distances are compared, as ``contactnet.planning.plan_kernel``
    compares them (the same floats there)."""
    if threshold_m == 0.0:
        return []
    limit = threshold_m * threshold_m
    out = []
    for leg, ((fx, fy), (hx, hy)) in enumerate(zip(feet_xy_world, hips_xy_world, strict=True)):
        dx, dy = fx - hx - shift_x, fy - hy - shift_y
        if dx * dx + dy * dy > limit:
            out.append(leg)
    return out


def first_moving(walk: OneLevelWalk, costs: np.ndarray,
                 spans: list[tuple[int, int]]) -> tuple[int, int, list[list[float]]] | None:
    """The first safe action of a plan's first step in the network's ranking (the stable ascending order of
    ``costs``) among the action ranges ``spans`` (the swing groups moving a leg left behind): (its rank in the whole
    ranking, action, landing points), None if none is safe."""
    best = None
    for span in dict.fromkeys(spans):
        found = walk.first_safe(0, costs, span)
        if found is not None and (best is None or (costs[found[1]], found[1]) < (costs[best[1]], best[1])):
            best = found
    if best is None:
        return None
    return int(rank_of(costs, 0, len(costs), best[1])), best[1], best[2]


def alone_step(walk: OneLevelWalk, costs: np.ndarray, behind: list[int], spans_of_leg: list[list[tuple[int, int]]],
               actions: ActionCells, terrain: Terrain, margin_m: float,
               ahead_xy: tuple[float, float] | None) -> PlannedStep | None:
    """A plan's first step when the legs ``behind`` have no safe action (``first_moving`` found none) in a gait that
    moves several legs a step (the trot; None for one leg a step): one of them steps alone, to the first cell of its
    grid that is safe (``margin_m`` from the edges, and the point ``ahead_xy`` further on too; None: the point alone)
    in the order the network ranks the actions of its swing groups (``spans_of_leg``), the cheapest such choice over
    the legs; its partners stay. With no such cell, the safe point of the grid widened by a spacing each way (the
    walk's 5 x 5 for the trot's 3 x 3) nearest its centre. None if none of those is safe either.

    Traced on the trot at n = 200 (seed 17): the front-left/hind-right pair had no safe pair of landings for 3.3 s,
    the other pair stepped eleven times in a row, and the hind-right foot, left behind, slid off its square's edge."""
    if actions.legs_per_step < 2 or not behind:
        return None
    grid = walk.grid(0)()  # (4, cells per leg, 2) world
    best = None
    for leg in behind:
        safe = _safe_with_room(terrain, grid[leg], margin_m, ahead_xy)
        if not safe.any():
            continue
        for first, stop in spans_of_leg[leg]:
            order = first + np.argsort(costs[first:stop], kind="stable")
            legs_cells = actions.leg_cell_array[actions.flat_array[order]]  # (actions, legs per step, 2)
            mine = legs_cells[np.arange(len(order)), np.argmax(legs_cells[..., 0] == leg, axis=1), 1]
            usable = safe[mine]
            if usable.any():
                i = int(usable.argmax())
                key = (float(costs[order[i]]), int(order[i]))
                if best is None or key < best[0]:
                    best = (key, leg, int(mine[i]))
    if best is not None:
        _, leg, cell = best
        return PlannedStep(legs=(leg,), footholds_xy_world=grid[leg, cell][None].copy())
    # none in their own grids: the ring around them a spacing further out (the walk's 5 x 5 grid), the safe point
    # nearest the grid's centre (the hip reference at touchdown)
    offsets = np.asarray(walk.offsets_world, dtype=float)
    wider = np.unique(np.round((offsets[:, None] + offsets[None]).reshape(-1, 2), 12), axis=0)
    nearest = None
    for leg in behind:
        centre = grid[leg].mean(axis=0)
        points = centre + wider
        for i in np.flatnonzero(_safe_with_room(terrain, points, margin_m, ahead_xy)).tolist():
            key = (float(np.hypot(*(points[i] - centre))), leg, i)
            if nearest is None or key < nearest[0]:
                nearest = (key, points[i])
    if nearest is None:
        return None
    (_, leg, _), point = nearest
    return PlannedStep(legs=(leg,), footholds_xy_world=point[None].copy())


def _safe_with_room(terrain: Terrain, points: np.ndarray, margin_m: float,
                    ahead_xy: tuple[float, float] | None) -> np.ndarray:
    """(N,) which landing points (N, 2) are safe with ``margin_m``, and the point ``ahead_xy`` further on too (None:
    the point alone), as the compiled walk asks them (``safe_walk._cell_state``)."""
    safe = terrain.is_safe(points, margin_m)
    if ahead_xy is not None and safe.any():
        safe &= terrain.is_safe(points + np.asarray(ahead_xy, dtype=float), margin_m)
    return safe


__all__ = ["DEFAULT_REACH", "ReachConfig", "alone_step", "first_moving", "left_behind"]
