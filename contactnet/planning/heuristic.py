"""The heuristic planner: the fixed cyclic gait (walk: HL, FL, HR, FR; trot: alternating diagonal pairs) with
Raibert-style footholds. Blind to holes: the baseline the paper beats, and the loop's planner for a robot without a
trained model."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from contactnet.motion.gait import GaitSpec
from contactnet.planning.planner import PlannedStep, PlanningContext, touchdown_times_s


@dataclass
class HeuristicPlanner:
    """Fixed cyclic gait with Raibert footholds: land under the hip's mid-stance position plus a
    velocity-error correction. It never looks at the terrain (the baseline the paper beats)."""

    gait: GaitSpec
    raibert_gain: float = 0.15  # s: extra step per m/s of velocity error (about sqrt(h / g))
    max_offset_m: float = 0.12  # clamp of the foothold around the hip reference
    _next_group: int = field(default=0, init=False)
    last_candidates: None = field(default=None, init=False)  # it does not rank

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


__all__ = ["HeuristicPlanner"]
