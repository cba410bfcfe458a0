"""The capture step (issue 14, push recovery): after a push, the next step's candidates move to where a foot
must land to stop the body.

The network ranks a fixed grid of cells around each hip (walk: +-10 cm, trot: +-5 cm), and it learned its
ranking from undisturbed walking. A push of 5 N for 1 s gives Solo12 a velocity error of 0.3-0.5 m/s, and the
foot that stops it must land about ``velocity error x sqrt(h / g)`` beyond the hip (Raibert's foot-placement
correction, the linear inverted pendulum's capture point): 5-8 cm, outside the trot's grid. Without it the trot
fell in 2 of 40 pushes, the body drifting sideways until a thigh touched the ground.

So when the CoM velocity differs from the command by more than ``CaptureConfig.velocity_error_m_s`` (a
disturbance: undisturbed walking stays well below it), the planner shifts the first step's candidate grid by
``gain_s x velocity error`` (at most ``max_offset_m`` along x and y) and ranks and checks the shifted cells as
usual: the network still picks the cell, the shift moves the whole grid towards the capture point, and only safe
cells are taken. The later steps of the plan are predicted at the commanded velocity and are not shifted; the
robot does not stand while it is being captured. Below the threshold nothing changes.

With an estimate of an external force that still acts (``contactnet.planning.observer``: a push in progress), the grid
also leans into it: it moves by ``F h / (m g)`` more (``lean_m_per_n`` per newton), the offset of the centre of
pressure from the CoM that balances a horizontal force at the CoM height ``h``, and the whole shift is clipped to
``max_offset_with_force_m``. Then the step is a capture step whatever the velocity error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CaptureConfig:
    """When and how far the first step's candidate grid moves after a push."""

    velocity_error_m_s: float = 0.15  # |CoM velocity (xy) - command| beyond which the grid moves
    gain_s: float = 0.15  # the shift per m/s of velocity error (about sqrt(h / g) for Solo12's CoM height)
    max_offset_m: float = 0.08  # the shift is clipped to this along x and y
    max_offset_with_force_m: float = 0.12  # ... and with the lean into a known external force, to this

    def __post_init__(self) -> None:
        for name in ("velocity_error_m_s", "gain_s", "max_offset_m", "max_offset_with_force_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"CaptureConfig.{name} must be a finite number >= 0, got {value!r}")


#: The planners' default: capture on (``ContactNetPlanner(capture=None)`` turns it off).
DEFAULT_CAPTURE = CaptureConfig()


def capture_offset(com_vel_world: np.ndarray, vel_cmd_xy: np.ndarray, yaw_rad: float,
                   config: CaptureConfig | None, external_force_xy_world: tuple[float, float] | None = None,
                   lean_m_per_n: float = 0.0) -> tuple[float, float] | None:
    """The shift (x, y, m, world) of the first step's candidate grid, None when the velocity error is within the
    threshold and no external force is given (or ``config`` is None: capture off). ``vel_cmd_xy`` is the command
    in the heading frame (rotated by ``yaw_rad`` here, on Python floats: this runs in every plan);
    ``external_force_xy_world`` (N) a force that acts now, leaned into by ``lean_m_per_n`` per newton."""
    if config is None:
        return None
    cmd_x, cmd_y = float(vel_cmd_xy[0]), float(vel_cmd_xy[1])
    cos_yaw, sin_yaw = math.cos(yaw_rad), math.sin(yaw_rad)
    err_x = float(com_vel_world[0]) - (cos_yaw * cmd_x - sin_yaw * cmd_y)
    err_y = float(com_vel_world[1]) - (sin_yaw * cmd_x + cos_yaw * cmd_y)
    disturbed = math.hypot(err_x, err_y) > config.velocity_error_m_s
    if not disturbed and external_force_xy_world is None:
        return None
    limit = config.max_offset_m
    shift_x, shift_y = (min(max(config.gain_s * err_x, -limit), limit), min(max(config.gain_s * err_y, -limit), limit)) \
        if disturbed else (0.0, 0.0)
    if external_force_xy_world is None:
        return shift_x, shift_y
    limit = config.max_offset_with_force_m
    shift_x += lean_m_per_n * float(external_force_xy_world[0])
    shift_y += lean_m_per_n * float(external_force_xy_world[1])
    return min(max(shift_x, -limit), limit), min(max(shift_y, -limit), limit)


__all__ = ["DEFAULT_CAPTURE", "CaptureConfig", "capture_offset"]
