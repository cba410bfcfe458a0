"""The network input u_r of the paper (14 numbers), the one definition used by data generation, training and
the planners. Plain numpy: the planner's hot path uses it without importing torch.

u_r is expressed in the yaw-aligned CoM frame: foot XY relative to the CoM (8: FL, FR, HL, HR, x then y),
CoM height above the ground (1: above the feet's support, ``contactnet.motion.ground``, the ground itself on flat
terrain), CoM velocity (3: x, y in the heading frame, z), commanded velocity (2,
heading frame). Expressing the horizontal vectors in the heading frame makes the ranking independent of
where the robot stands and which way it faces.

- `network_input`: the general function, vectorised over any leading axes;
- `network_input_one`: the same for one state, lean (a few microseconds: the planner's hot loop), and
  `network_input_values` on Python floats (the planner's state);
- `network_input_of_context` / `network_input_of_state`: a ``PlanningContext`` / a ``CostState``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

N_INPUTS = 14
INPUT_NAMES = (
    "FL_x_com", "FL_y_com", "FR_x_com", "FR_y_com", "HL_x_com", "HL_y_com", "HR_x_com", "HR_y_com",
    "com_z", "com_vx", "com_vy", "com_vz", "cmd_vx", "cmd_vy",
)  # fmt: skip


def network_input(
    feet_xy_world: np.ndarray,
    com_pos_world: np.ndarray,
    com_vel_world: np.ndarray,
    vel_cmd_xy: np.ndarray,
    yaw_rad: np.ndarray | float,
    ground_z: np.ndarray | float,
) -> np.ndarray:
    """The network inputs u_r (..., 14) of states given by arrays with common (broadcast) leading axes.

    ``feet_xy_world`` (..., 4, 2) foot XY, legs FL, FR, HL, HR; ``com_pos_world`` (..., 3);
    ``com_vel_world`` (..., 3); ``vel_cmd_xy`` (..., 2) commanded velocity in the heading frame;
    ``yaw_rad`` (...) heading; ``ground_z`` (...) height of the ground the CoM height is measured from.
    """
    feet = np.asarray(feet_xy_world, dtype=np.float64)
    com = np.asarray(com_pos_world, dtype=np.float64)
    vel = np.asarray(com_vel_world, dtype=np.float64)
    cmd = np.asarray(vel_cmd_xy, dtype=np.float64)
    yaw = np.asarray(yaw_rad, dtype=np.float64)
    ground = np.asarray(ground_z, dtype=np.float64)
    if feet.shape[-2:] != (4, 2) or com.shape[-1:] != (3,) or vel.shape[-1:] != (3,) or cmd.shape[-1:] != (2,):
        raise ValueError(f"network_input: feet (..., 4, 2), com (..., 3), vel (..., 3), cmd (..., 2) expected; "
                         f"got {feet.shape}, {com.shape}, {vel.shape}, {cmd.shape}")
    lead = np.broadcast_shapes(feet.shape[:-2], com.shape[:-1], vel.shape[:-1], cmd.shape[:-1], yaw.shape,
                               ground.shape)
    c, s = np.cos(yaw), np.sin(yaw)
    u = np.empty((*lead, N_INPUTS))
    dx = feet[..., 0] - com[..., None, 0]
    dy = feet[..., 1] - com[..., None, 1]
    u[..., 0:8:2] = c[..., None] * dx + s[..., None] * dy
    u[..., 1:8:2] = -s[..., None] * dx + c[..., None] * dy
    u[..., 8] = com[..., 2] - ground
    u[..., 9] = c * vel[..., 0] + s * vel[..., 1]
    u[..., 10] = -s * vel[..., 0] + c * vel[..., 1]
    u[..., 11] = vel[..., 2]
    u[..., 12:14] = cmd
    return u


def network_input_one(
    feet_xy_world: np.ndarray,
    com_pos_world: np.ndarray,
    com_vel_world: np.ndarray,
    vel_cmd_xy: np.ndarray,
    yaw_rad: float,
    ground_z: float,
) -> np.ndarray:
    """`network_input` of one state, (14,): the same arguments without leading axes (``feet_xy_world``
    (4, 2), ``com_pos_world`` (3,), ``com_vel_world`` (3,), ``vel_cmd_xy`` (2,), scalar ``yaw_rad`` and
    ``ground_z``), computed on Python floats: a few microseconds, the planner's hot loop."""
    return np.array(network_input_values(feet_xy_world.tolist(), com_pos_world.tolist(), com_vel_world.tolist(),
                                         vel_cmd_xy.tolist(), math.cos(yaw_rad), math.sin(yaw_rad), ground_z))


def network_input_values(
    feet_xy_world: list[list[float]],
    com_pos_world: list[float],
    com_vel_world: list[float],
    vel_cmd_xy: list[float],
    cos_yaw: float,
    sin_yaw: float,
    ground_z: float,
) -> list[float]:
    """`network_input_one` on Python floats and lists, as a list of 14 floats: feet [[x, y]] * 4, CoM [x, y, z],
    velocity [x, y, z], command [x, y], the cosine and sine of the yaw (``math.cos``, ``math.sin``) and the
    ground height. The planner keeps its state in floats and calls this directly."""
    (fl_x, fl_y), (fr_x, fr_y), (hl_x, hl_y), (hr_x, hr_y) = feet_xy_world
    com_x, com_y, com_z = com_pos_world
    vel_x, vel_y, vel_z = com_vel_world
    cmd_x, cmd_y = vel_cmd_xy
    c, s = cos_yaw, sin_yaw
    fl_x, fr_x, hl_x, hr_x = fl_x - com_x, fr_x - com_x, hl_x - com_x, hr_x - com_x
    fl_y, fr_y, hl_y, hr_y = fl_y - com_y, fr_y - com_y, hl_y - com_y, hr_y - com_y
    return [
        c * fl_x + s * fl_y, -s * fl_x + c * fl_y, c * fr_x + s * fr_y, -s * fr_x + c * fr_y,
        c * hl_x + s * hl_y, -s * hl_x + c * hl_y, c * hr_x + s * hr_y, -s * hr_x + c * hr_y,
        com_z - ground_z, c * vel_x + s * vel_y, -s * vel_x + c * vel_y, vel_z, cmd_x, cmd_y,
    ]  # fmt: skip


def network_input_of_context(ctx: Any) -> np.ndarray:
    """The network input u_r (14,) of a ``contactnet.planning.planner.PlanningContext`` (the measured state a planner
    sees); the CoM height is measured from the feet's support (``contactnet.motion.ground.support_height``)."""
    from contactnet.motion.ground import support_height

    feet_xy = np.asarray(ctx.foot_pos_world, dtype=np.float64)[:, :2]
    return network_input_one(
        feet_xy,
        np.asarray(ctx.com_pos_world, dtype=np.float64),
        np.asarray(ctx.com_vel_world, dtype=np.float64),
        np.asarray(ctx.vel_cmd_xy, dtype=np.float64),
        float(ctx.yaw_rad),
        support_height(ctx.terrain, feet_xy),
    )


def network_input_of_state(state: Any) -> np.ndarray:
    """The network input u_r (14,) of a ``contactnet.planning.cost.CostState`` (a measured one or one predicted a step ahead): the
    planner's steps 2 and 3 feed the predicted state, with the chosen footholds, back into the network.
    The state's command is in the world frame; u_r has it in the heading frame."""
    c, s = math.cos(state.yaw_rad), math.sin(state.yaw_rad)
    cmd_x, cmd_y = np.asarray(state.vel_cmd_world, dtype=np.float64).tolist()
    return network_input_one(
        np.asarray(state.foot_pos_world, dtype=np.float64)[:, :2],
        np.asarray(state.com_pos_world, dtype=np.float64),
        np.asarray(state.com_vel_world, dtype=np.float64),
        np.array([c * cmd_x + s * cmd_y, -s * cmd_x + c * cmd_y]),
        float(state.yaw_rad),
        float(state.ground_z),
    )


__all__ = ["INPUT_NAMES", "N_INPUTS", "network_input", "network_input_of_context", "network_input_of_state",
           "network_input_one", "network_input_values"]
