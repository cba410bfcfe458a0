"""The oracle planner: the ranking cost V evaluated online for every action, the cheapest safe one taken.

Exact and slow: the teacher of data generation (``contactnet.jobs.datagen``) and a baseline. The learned planners
(``contactnet.planning.planner``) rank the same actions with a network instead.
"""

from __future__ import annotations

import numpy as np

from contactnet.frames import rotate_xy
from contactnet.motion.gait import GaitSpec
from contactnet.planning.planner import PlanningContext
from contactnet.planning.ranking import (
    LANDING_MARGIN_RADII,
    CandidateRanking,
    PlannedStep,
    cell_grid,
    first_safe_step,
)
from contactnet.planning.stand import prefer_stand, split_stand
from contactnet.robots.description import RobotDescription
from contactnet.terrain import Terrain


class OraclePlanner:
    """The exact teacher: evaluate the ranking cost V of every action online and take the cheapest safe one.

    Slow (one batched optimization of all N_a candidates per planned step) but exact: the teacher of data
    generation and a baseline. Each of the ``gait.steps_per_plan`` steps is chosen from a state: step 1
    from the measured one, steps 2 and 3 from the state predicted at the end of the previous step horizon
    (``contactnet.planning.cost.predicted_state``: the CoM moved by the commanded velocity, level, no angular
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

    ``evaluated_steps`` (default all): how many of the plan's steps are chosen by V; later ones only fill
    the optimizer's horizon (``continue_cyclically``). Data generation evaluates step 1 only, the one
    it records and executes, which makes it three times cheaper; the next plan starts afresh anyway.

    ``last_costs`` is the ``CostBreakdown`` of step 1 and ``last_state`` its ``CostState``, so data
    generation can record (u_r, V) without evaluating again.
    """

    name = "oracle"

    def __init__(
        self,
        gait: GaitSpec,
        robot: RobotDescription,
        weights=None,  # noqa: ANN001 - contactnet.motion.cost_weights.CostWeights (default: the gait's)
        margin_m: float | None = None,
        model=None,  # noqa: ANN001 - contactnet.motion.trajopt.SrbdModel (default: the robot's)
        evaluated_steps: int | None = None,
    ) -> None:
        from contactnet.planning.cost import RankingCost

        self.gait = gait
        self.robot = robot
        self.weights = weights if weights is not None else gait.cost_weights
        self.margin_m = LANDING_MARGIN_RADII * robot.foot_radius_m if margin_m is None else float(margin_m)
        self.cost = RankingCost(gait, robot, self.weights, model=model)
        self.evaluated_steps = gait.steps_per_plan if evaluated_steps is None else int(evaluated_steps)
        if not 1 <= self.evaluated_steps <= gait.steps_per_plan:
            raise ValueError(f"evaluated_steps must be in 1..{gait.steps_per_plan}, got {evaluated_steps}")
        self.hip_ref_xy_base = np.array(robot.foot_nominal_base[:, :2], dtype=float)
        self.last_costs = None
        self.last_state = None
        self.last_candidates: CandidateRanking | None = None

    def reset(self) -> None:
        self.last_costs = None
        self.last_state = None
        self.last_candidates = None

    def plan(self, ctx: PlanningContext) -> list[PlannedStep]:
        from contactnet.planning.cost import CostState, predicted_state

        state = CostState.from_context(ctx, self.robot.foot_radius_m)
        steps = []
        for j in range(self.gait.steps_per_plan):
            if j >= self.evaluated_steps:
                step = self.continue_cyclically(state, steps[-1].legs)
                steps.append(step)
                state = predicted_state(state, step.footholds_xy_world, step.legs, self.gait.step_duration_s)
                continue
            costs = self.cost.evaluate(state)
            if j == 0:
                self.last_costs, self.last_state = costs, state
            candidates = self.last_candidates
            step = self.choose(costs, state, ctx.terrain)
            if j > 0:
                self.last_candidates = candidates  # the viewer shows the step executed now
            steps.append(step)
            state = predicted_state(state, step.footholds_xy_world, step.legs, self.gait.step_duration_s)
        return steps

    def continue_cyclically(self, state, previous_legs: tuple[int, ...]) -> PlannedStep:  # noqa: ANN001
        """A step past ``evaluated_steps``: the group after ``previous_legs`` in the gait's cyclic order,
        landing at its hip reference shifted by the commanded velocity over half a stance (the Raibert
        nominal). It only fills the optimizer's horizon; the next plan re-evaluates from the new state."""
        gait = self.gait
        cyclic = gait.cyclic_order
        if previous_legs:
            group = gait.swing_groups.index(tuple(previous_legs))
            legs = gait.swing_groups[cyclic[(cyclic.index(group) + 1) % len(cyclic)]]
        else:  # after standing: the order's first group
            legs = gait.swing_groups[cyclic[0]]
        vel = np.asarray(state.vel_cmd_world, dtype=float)
        half_stance = 0.5 * (len(cyclic) * gait.step_duration_s - gait.swing_duration_s)
        touchdown_s = (gait.n_stance_pre + gait.n_swing) * gait.node_dt_s
        base = np.asarray(state.base_xy_world, dtype=float) + vel * touchdown_s
        hips = base + rotate_xy(self.hip_ref_xy_base, state.yaw_rad)
        return PlannedStep(legs=legs, footholds_xy_world=hips[list(legs)] + vel * half_stance)

    def choose(self, costs, state, terrain: Terrain) -> PlannedStep:  # noqa: ANN001 - cost types
        """The cheapest safe action of one evaluated state (or the step in place, see the class doc)."""
        order, stand_position = split_stand(self.gait, costs.ranking())
        cells = cell_grid(self.gait, costs.footholds_xy_world)
        step = first_safe_step(self.gait, order, cells, state.foot_pos_world, terrain, self.margin_m)
        step = prefer_stand(self.gait, step, stand_position)
        self.last_candidates = CandidateRanking(self.gait, order, cells, terrain, self.margin_m,
                                                step.action_index)
        return step


__all__ = ["OraclePlanner"]
