"""How the ranking cost's weights were chosen: greedy rollouts of the cheapest action on flat ground
(``weight_study``; see ``contactnet.motion.cost_weights.CostWeights``)."""

from __future__ import annotations

import numpy as np

from contactnet.motion.cost_weights import CostWeights
from contactnet.motion.gait import GaitSpec
from contactnet.planning.cost import CostState, RankingCost, nominal_state, predicted_state
from contactnet.robots.description import RobotDescription


def greedy_rollout(cost: RankingCost, state: CostState, n_steps: int = 30) -> dict:
    """Take the cheapest action ``n_steps`` times on flat ground, each from the state predicted by the
    previous one (``predicted_state``: the oracle's own prediction). A cheap stand-in for a simulation:
    a cost whose greedy choices let the feet fall behind the body, or lift a leg with the CoM outside
    the remaining support, is a bad cost.

    Returns ``sequence`` (leg names per step), ``worst_foot_hip_m`` (largest horizontal distance of a
    foot from its hip reference after any step), ``stab`` and ``kin`` (sums of the chosen actions'
    V_stab, V_kin) and ``repeats`` (fraction of steps that swing the same legs as the step before).
    """
    sequence, worst, stab, kin = [], 0.0, 0.0, 0.0
    for _ in range(n_steps):
        result = cost.evaluate(state)
        best = int(result.ranking()[0])
        legs = cost.gait.decode(best).legs
        sequence.append("".join(cost.robot.leg_names[leg] for leg in legs))
        stab += float(result.terms[best, 1])
        kin += float(result.terms[best, 2])
        footholds = result.footholds_xy_world[best, list(legs)]
        state = predicted_state(state, footholds, legs, cost.gait.step_duration_s)
        offsets = state.foot_pos_world[:, 0:2] - cost.hip_ref_world(state)
        worst = max(worst, float(np.hypot(offsets[:, 0], offsets[:, 1]).max()))
    repeats = sum(a == b for a, b in zip(sequence[:-1], sequence[1:], strict=True)) / max(1, n_steps - 1)
    return {"sequence": sequence, "worst_foot_hip_m": worst, "stab": stab, "kin": kin, "repeats": repeats}


#: Commanded velocities of ``weight_study`` (world frame, m/s): the data generation range.
STUDY_VELOCITIES: tuple[tuple[float, float], ...] = (
    (0.1, 0.0), (0.05, 0.0), (0.0, 0.1), (-0.07, 0.05), (0.06, -0.1), (-0.09, -0.075),
)


def weight_study(gait: GaitSpec, weights: CostWeights, robot: RobotDescription, n_steps: int = 30,
                 **cost_kwargs) -> list[dict]:
    """Greedy rollouts from standing at every ``STUDY_VELOCITIES`` (rows: velocity + ``greedy_rollout``)."""
    cost = RankingCost(gait, robot, weights, **cost_kwargs)
    rows = []
    for vel in STUDY_VELOCITIES:
        row = greedy_rollout(cost, nominal_state(robot, vel), n_steps)
        rows.append({"vel": vel, **row})
    return rows


