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
room for the roll as any choice), and the robot does not stand. With none safe, the plan is the plain one.
``ContactNetPlanner(reach=None)`` turns it off; the fixed gait (the paper's baseline) keeps its order. It applies on
terrain of one level; on terrain with heights the cornered legs (``contactnet.planning.planner``) order the first
step instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from contactnet.planning.safe_walk import rank_of

if TYPE_CHECKING:
    from contactnet.planning.ranking import OneLevelWalk


@dataclass(frozen=True)
class ReachConfig:
    """When a stance foot counts as left behind."""

    lookahead_steps: float = 2.0  # steps of commanded motion ahead of the plan's start
    threshold_m: float | None = None  # horizontal foot-to-hip-reference distance; None: the robot's kin_threshold_m

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lookahead_steps) and self.lookahead_steps >= 0.0):
            raise ValueError(f"ReachConfig.lookahead_steps must be a finite number >= 0, got {self.lookahead_steps!r}")
        if self.threshold_m is not None and not (math.isfinite(self.threshold_m) and self.threshold_m > 0.0):
            raise ValueError(f"ReachConfig.threshold_m must be a finite number > 0 or None, got {self.threshold_m!r}")


#: The planner's default (``ContactNetPlanner(reach=None)`` turns it off).
DEFAULT_REACH = ReachConfig()


def left_behind(feet_xy_world: list[list[float]], hips_xy_world: list[list[float]], shift_xy: tuple[float, float],
                threshold_m: float) -> list[int]:
    """The legs whose foot ``feet_xy_world`` is further than ``threshold_m`` from its hip reference ``hips_xy_world``
    moved by ``shift_xy`` (the commanded motion over the look-ahead, world metres). Python floats; the squared
    distances are compared, as ``contactnet.planning.plan_kernel`` compares them (the same floats there)."""
    limit = threshold_m * threshold_m
    out = []
    for leg, ((fx, fy), (hx, hy)) in enumerate(zip(feet_xy_world, hips_xy_world, strict=True)):
        dx, dy = fx - hx - shift_xy[0], fy - hy - shift_xy[1]
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


__all__ = ["DEFAULT_REACH", "ReachConfig", "first_moving", "left_behind"]
