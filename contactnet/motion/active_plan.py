"""The locomotion loop's active plan: the contact schedule and footholds of the current step horizon, the
optimizer's solution over it and the swinging feet's trajectories, and the edits made to it mid-step (a retargeted
landing, contactnet.planning.retarget; feet put down early, contactnet.planning.brace)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from contactnet.motion.controller import SwingTrajectory
from contactnet.motion.gait import GaitSpec
from contactnet.motion.trajopt import TrajoptSolution


@dataclass
class ActivePlan:
    """The active plan: contact schedule, footholds, optimizer solution and swing trajectories."""

    t0_s: float  # time of node 0 of `solution`
    plan_t0_s: float  # time the step plan started (start of the current step horizon)
    steps: list  # the planner's PlannedSteps (contactnet.planning.ranking), the first being the current step
    contact: np.ndarray  # (N, 4) from plan_t0_s
    foot_pos: np.ndarray  # (N, 4, 3) contact points from plan_t0_s
    solution: TrajoptSolution | None
    swings: dict[int, SwingTrajectory] = field(default_factory=dict)
    tops_z: np.ndarray | None = None  # (N, 4) the top under each foot at each node (contactnet.motion.ground)
    touched: np.ndarray = field(default_factory=lambda: np.zeros(4, dtype=bool))  # swung legs that touched down
    solution_force_world: np.ndarray | None = None  # (3,) the external force `solution` was planned with (observer)
    braced_down: bool = False  # bracing put this step's swinging feet down early (contactnet.planning.brace)
    braced: bool = False  # the horizon stands because of a push (contactnet.planning.brace)

    def node_at(self, t_s: float, node_dt_s: float) -> int:
        """The node (from ``plan_t0_s``) that ``t_s`` falls in."""
        return int((t_s - self.plan_t0_s + 1e-9) // node_dt_s)

    def stand_on(self, leg: int, first_node: int, contact_point_world: np.ndarray, gait: GaitSpec,
                 in_contact: bool = False) -> None:
        """``leg``'s contact point is ``contact_point_world`` (3,) from ``first_node`` until its next planned step
        lands (or the horizon's end); with ``in_contact``, the leg is in stance over those nodes too."""
        later = [j for j, step in enumerate(self.steps[1:], 1) if leg in step.legs]
        end = later[0] * gait.nodes_per_step + gait.n_stance_pre + gait.n_swing if later else len(self.contact)
        self.foot_pos[first_node:end, leg] = contact_point_world
        if self.tops_z is not None:
            self.tops_z[first_node:end, leg] = contact_point_world[2]
        if in_contact:
            self.contact[first_node:end, leg] = True


def liftoff_point(swing) -> np.ndarray:
    """Where a swing (a ``SwingTrajectory``, or a retargeted one wrapping it) lifted off: its foot centre (3,)."""
    while not hasattr(swing, "start_world"):  # contactnet.planning.retarget.RetargetedSwing: the swing it displaces
        swing = swing.base
    return swing.start_world


__all__ = ["ActivePlan", "liftoff_point"]
