"""Contact planners: given the robot's state, decide the next steps (which legs swing, where they land).

Every planner answers `plan(context) -> list[PlannedStep]` with `gait.steps_per_plan` (3) steps: the
first is executed now, the next two complete the optimizer's 960 ms horizon. Planners differ only
in how they choose; the loop (`locomotion.py`) treats them alike.

- `HeuristicPlanner`: the fixed cyclic gait (walk: HL, FL, HR, FR; trot: alternating diagonal
  pairs) with Raibert-style footholds. Blind to holes. The baseline, and the loop's planner until
  ContactNet is trained.
- `OraclePlanner`: evaluates the ranking cost V of every action online and takes the cheapest safe
  one (exact and slow: the teacher of data generation, and a baseline).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from contactnet.gait import GaitSpec
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


@dataclass(frozen=True)
class PlanningContext:
    """What a planner sees when it plans (world frame, SI units)."""

    com_pos_world: np.ndarray  # (3,)
    com_vel_world: np.ndarray  # (3,)
    yaw_rad: float
    foot_pos_world: np.ndarray  # (4, 3) where the feet are now
    hip_ref_xy_base: np.ndarray  # (4, 2) nominal foot XY in the base frame (candidate grid centres)
    base_xy_world: np.ndarray  # (2,) base origin (the hip references move with it)
    vel_cmd_xy: np.ndarray  # (2,) commanded velocity, horizontal body frame
    terrain: Terrain
    gait: GaitSpec
    rpy: np.ndarray = field(default_factory=lambda: np.zeros(3))  # base roll, pitch, yaw
    ang_vel_world: np.ndarray = field(default_factory=lambda: np.zeros(3))
    com_height_ref_m: float = 0.215  # nominal CoM height above the surface

    def vel_cmd_world(self) -> np.ndarray:
        return rotate_xy(self.vel_cmd_xy, self.yaw_rad)

    def hip_ref_world(self, base_xy_world: np.ndarray) -> np.ndarray:
        """(4, 2) hip references (nominal foot XY) when the base origin is at base_xy_world."""
        return base_xy_world + rotate_xy(self.hip_ref_xy_base, self.yaw_rad)


def rotate_xy(xy: np.ndarray, yaw_rad: float) -> np.ndarray:
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    xy = np.asarray(xy, dtype=float)
    return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)


def touchdown_times_s(gait: GaitSpec) -> np.ndarray:
    """Time of each planned step's touchdown, from the start of the plan, (steps_per_plan,)."""
    touchdown_in_step = (gait.n_stance_pre + gait.n_swing) * gait.node_dt_s
    return np.arange(gait.steps_per_plan) * gait.step_duration_s + touchdown_in_step


@dataclass
class HeuristicPlanner:
    """Fixed cyclic gait with Raibert footholds: land under the hip's mid-stance position plus a
    velocity-error correction. It never looks at the terrain (the baseline the paper beats)."""

    gait: GaitSpec
    raibert_gain: float = 0.15  # s: extra step per m/s of velocity error (about sqrt(h / g))
    max_offset_m: float = 0.12  # clamp of the foothold around the hip reference
    _next_group: int = field(default=0, init=False)

    name = "heuristic"

    def reset(self) -> None:
        self._next_group = 0

    def stance_duration_s(self) -> float:
        """How long a leg stays down in the cyclic gait (one cycle minus its swing)."""
        cycle = len(self.gait.cyclic_order) * self.gait.step_duration_s
        return cycle - self.gait.swing_duration_s

    def plan(self, ctx: PlanningContext) -> list[PlannedStep]:
        gait = self.gait
        vel_cmd = ctx.vel_cmd_world()
        vel_err = ctx.com_vel_world[:2] - vel_cmd
        half_stance = 0.5 * self.stance_duration_s()
        steps = []
        for j, t_td in enumerate(touchdown_times_s(gait)):
            group = gait.cyclic_order[(self._next_group + j) % len(gait.cyclic_order)]
            legs = gait.swing_groups[group]
            base_td = ctx.base_xy_world + vel_cmd * t_td
            hip_td = ctx.hip_ref_world(base_td)[list(legs)]
            offset = vel_cmd * half_stance + (self.raibert_gain * vel_err if j == 0 else 0.0)
            offset = np.clip(offset, -self.max_offset_m, self.max_offset_m)
            steps.append(PlannedStep(legs=legs, footholds_xy_world=hip_td + offset))
        self._next_group = (self._next_group + 1) % len(gait.cyclic_order)
        return steps


class OraclePlanner:
    """The exact teacher: evaluate the ranking cost V of every action online and take the cheapest safe one.

    Slow (one batched optimization of all N_a candidates per planned step) but exact: the teacher of data
    generation and a baseline. Each of the ``gait.steps_per_plan`` steps is chosen from a state: step 1
    from the measured one, steps 2 and 3 from the state predicted at the end of the previous step horizon
    (``contactnet.cost.predicted_state``: the CoM moved by the commanded velocity, level, no angular
    velocity, the previous step's legs on their footholds; the paper's procedure).

    Safe = every swinging leg's landing point inside the steppable terrain shrunk by ``margin_m``. The
    default, half the foot-ball radius (8 mm), covers the swing controller's touchdown error (a few mm)
    while keeping the contact point, which is the bottom of the ball, on the surface; a larger margin
    throws away too many footholds on stepping stones. ``rank`` is the chosen action's position in the
    ascending-V order (0 = cheapest) and ``discarded`` how many cheaper actions were unsafe (the same
    number for this planner).

    No safe action at all: the robot steps in place. Swing groups are tried in the order of their
    cheapest action; the first group whose legs stand on safe ground (margin 0: they already stand
    there) lifts those legs and puts them back where they are (``action_index=None``, ``rank=None``,
    ``discarded=N_a``, ``safe=True``): the body keeps moving, so the next plan sees new candidates. Only
    when no group stands on safe ground does it step in place with the cheapest group and ``safe=False``.

    ``last_costs`` is the ``CostBreakdown`` of step 1 and ``last_state`` its ``CostState``, so data
    generation can record (u_r, V) without evaluating again.
    """

    name = "oracle"

    def __init__(
        self,
        gait: GaitSpec,
        robot_nominal_foot_xy_base: np.ndarray,
        weights=None,  # noqa: ANN001 - contactnet.cost.CostWeights (default: the gait's tuned weights)
        margin_m: float | None = None,
        model=None,  # noqa: ANN001 - contactnet.trajopt.SrbdModel (default: SrbdModel())
    ) -> None:
        from contactnet.cost import CostWeights, RankingCost
        from contactnet.robot import FOOT_RADIUS_M

        self.gait = gait
        self.weights = weights if weights is not None else CostWeights.for_gait(gait.name)
        self.margin_m = 0.5 * FOOT_RADIUS_M if margin_m is None else float(margin_m)
        self.cost = RankingCost(gait, robot_nominal_foot_xy_base, self.weights, model=model)
        self.last_costs = None
        self.last_state = None

    def reset(self) -> None:
        self.last_costs = None
        self.last_state = None

    def plan(self, ctx: PlanningContext) -> list[PlannedStep]:
        from contactnet.cost import CostState, predicted_state

        state = CostState.from_context(ctx)
        steps = []
        for j in range(self.gait.steps_per_plan):
            costs = self.cost.evaluate(state)
            if j == 0:
                self.last_costs, self.last_state = costs, state
            step = self.choose(costs, state, ctx.terrain)
            steps.append(step)
            state = predicted_state(state, step.footholds_xy_world, step.legs, self.gait.step_duration_s)
        return steps

    def choose(self, costs, state, terrain: Terrain) -> PlannedStep:  # noqa: ANN001 - cost types
        """The cheapest safe action of one evaluated state (or the step in place, see the class doc)."""
        swing, _ = self.gait.action_table
        order = costs.ranking()
        landing = costs.footholds_xy_world[swing]  # (N_a * legs_per_step, 2), row-major by action
        safe = terrain.is_safe(landing, self.margin_m).reshape(len(swing), -1).all(axis=1)
        safe_ranks = np.flatnonzero(safe[order])
        if len(safe_ranks):
            rank = int(safe_ranks[0])
            index = int(order[rank])
            legs = self.gait.swing_groups[self.gait.decode(index).group]
            return PlannedStep(
                legs=legs,
                footholds_xy_world=costs.footholds_xy_world[index, list(legs)].copy(),
                action_index=index,
                rank=rank,
                discarded=rank,
            )
        groups = list(dict.fromkeys(self.gait.decode(int(a)).group for a in order))
        feet_xy = np.asarray(state.foot_pos_world, dtype=float)[:, 0:2]
        for group in groups:
            legs = self.gait.swing_groups[group]
            if terrain.is_safe(feet_xy[list(legs)], 0.0).all():
                return PlannedStep(legs=legs, footholds_xy_world=feet_xy[list(legs)].copy(),
                                   discarded=len(order))
        legs = self.gait.swing_groups[groups[0]]
        return PlannedStep(legs=legs, footholds_xy_world=feet_xy[list(legs)].copy(), discarded=len(order),
                           safe=False)
