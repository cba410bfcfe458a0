"""Foothold update during the swing (the paper's named limitation, Sec. V: "ContactNet does not update the
foothold during the swing phase").

At every re-solve of the optimizer during a swing (``LocomotionConfig.reoptimize_every_nodes``), the planned
landing is checked against the measured state: when the CoM's horizontal velocity is off the command by more
than ``velocity_error_m_s`` (a push, a slip), the swinging legs' candidates are ranked again by the network from
the measured state (``ContactNetPlanner.replan_swing``: their feet at their lift-off points, only that group's
actions) and, if the best safe landing has moved by ``min_shift_m`` or more, the swing is retargeted there.

The retargeted swing (``RetargetedSwing``) is the old one plus the landing's displacement times a smoothstep
over the swing's remaining time: position and velocity stay continuous at the retarget, and the foot lands
on the new point with zero added velocity.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from contactnet.planning.planner import PlannedStep, PlanningContext


@dataclass(frozen=True)
class RetargetConfig:
    """When a swing is retargeted."""

    velocity_error_m_s: float = 0.1  # |CoM velocity (xy) - command| beyond which the landing is ranked again
    min_remaining_s: float = 0.06  # not in the swing's last 60 ms (the foot is coming down)
    min_shift_m: float = 0.02  # a new landing closer than this to the old one is not worth a change


@dataclass(frozen=True)
class RetargetedSwing:
    """``base`` (a swing) whose landing moved by ``delta_world`` at ``t_retarget_s``: ``base`` plus
    ``delta_world`` times a smoothstep of the remaining time (zero value and rate at the retarget, one and zero
    rate at touchdown)."""

    base: object  # a SwingTrajectory or a RetargetedSwing: anything with sample(t), t0_s, t1_s, end_world
    delta_world: np.ndarray
    t_retarget_s: float

    @property
    def t0_s(self) -> float:
        return self.base.t0_s

    @property
    def t1_s(self) -> float:
        return self.base.t1_s

    @property
    def start_world(self) -> np.ndarray:
        return self.base.start_world

    @property
    def end_world(self) -> np.ndarray:
        return self.base.end_world + self.delta_world

    def sample(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        position, velocity, acceleration = self.base.sample(t_s)
        span = self.t1_s - self.t_retarget_s
        u = min(max((t_s - self.t_retarget_s) / span, 0.0), 1.0)
        inside = 0.0 < u < 1.0
        blend = u * u * (3.0 - 2.0 * u)
        rate = 6.0 * u * (1.0 - u) / span if inside else 0.0
        curvature = (6.0 - 12.0 * u) / span**2 if inside else 0.0
        return (position + blend * self.delta_world, velocity + rate * self.delta_world,
                acceleration + curvature * self.delta_world)


def retarget(planner: object, ctx: PlanningContext, step: PlannedStep, swings: dict, t_s: float,
             foot_radius_m: float, config: RetargetConfig = RetargetConfig()) -> tuple[PlannedStep, dict] | None:
    """The new first step and swings of the legs of ``step`` now swinging (``swings``: leg -> swing), or None
    when nothing needs to change: no swing in progress with ``min_remaining_s`` left, the velocity within
    ``velocity_error_m_s`` of the command, a planner that cannot rank a single group (``replan_swing``), no
    safe landing, or one within ``min_shift_m`` of the old."""
    replan = getattr(planner, "replan_swing", None)
    legs = tuple(step.legs)
    if (replan is None or not legs or any(leg not in swings for leg in legs)
            or legs not in planner.gait.swing_groups):  # a leg stepping alone (contactnet.planning.reach) keeps it
        return None
    if not all(swings[leg].t0_s <= t_s <= swings[leg].t1_s - config.min_remaining_s for leg in legs):
        return None
    c, s = np.cos(ctx.yaw_rad), np.sin(ctx.yaw_rad)
    cmd_world = np.array([[c, -s], [s, c]]) @ np.asarray(ctx.vel_cmd_xy, dtype=float)
    if np.hypot(*(np.asarray(ctx.com_vel_world[:2]) - cmd_world)) <= config.velocity_error_m_s:
        return None
    feet = np.array(ctx.foot_pos_world, dtype=float)
    for leg in legs:  # the network sees the swinging feet where they lifted off (as when the step was planned)
        feet[leg] = swings[leg].start_world
    new = replan(dataclasses.replace(ctx, foot_pos_world=feet), legs)
    if new is None:
        return None
    old_xy = np.asarray(step.footholds_xy_world, dtype=float)
    new_xy = np.asarray(new.footholds_xy_world, dtype=float)
    if np.max(np.hypot(*(new_xy - old_xy).T)) < config.min_shift_m:
        return None
    tops = ctx.terrain.ground_z(new_xy)
    moved = {}
    for leg, xy, top in zip(legs, new_xy, tops, strict=True):
        target = np.array([xy[0], xy[1], top + foot_radius_m])
        moved[leg] = RetargetedSwing(swings[leg], target - swings[leg].end_world, t_s)
    return new, moved


__all__ = ["RetargetConfig", "RetargetedSwing", "retarget"]
