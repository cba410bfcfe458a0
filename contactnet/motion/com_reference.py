"""The CoM reference path: where the optimizer is asked to take the body's CoM (xy, world).

The commanded velocity is integrated tick by tick, on a leash to the measured CoM (``LocomotionConfig.ref_leash_m``):
after a push the optimizer brings the robot back toward its path, a little, and does not only stop it where the push
left it; a body held back (on a top's edge, by a push) never has more than the leash to catch up. The loop advances it
with the command's velocity, or with none while it braces (``BraceConfig.hold_reference``): standing on four feet the
body then stays over them instead of creeping on with the command.
"""

from __future__ import annotations

import math

import numpy as np


class ComReference:
    """The CoM xy reference (world, m), advanced one tick at a time on a leash to the CoM."""

    def __init__(self, start_xy_world: np.ndarray, leash_m: float, dt_s: float):
        if not (math.isfinite(leash_m) and leash_m >= 0.0):  # 0: the reference is the CoM itself
            raise ValueError(f"the CoM reference's leash must be a finite number >= 0 (m), got {leash_m!r}")
        self.xy_world = np.array(start_xy_world, dtype=float)[:2]  # (2,)
        self.leash_m, self.dt_s = float(leash_m), float(dt_s)

    def advance(self, com_xy_world: np.ndarray, vel_xy_world: np.ndarray) -> None:
        """Move the reference by one tick of ``vel_xy_world`` (2,, m/s), then back within the leash of
        ``com_xy_world`` (2,) along the line to it (on Python floats: this runs at 1 kHz)."""
        ref_x, ref_y = self.xy_world.tolist()
        vel_x, vel_y = vel_xy_world.tolist()
        com_x, com_y = com_xy_world.tolist()
        ref_x, ref_y = ref_x + vel_x * self.dt_s, ref_y + vel_y * self.dt_s
        lead_x, lead_y = ref_x - com_x, ref_y - com_y
        distance = math.hypot(lead_x, lead_y)
        if distance > self.leash_m:
            scale = self.leash_m / distance
            ref_x, ref_y = com_x + lead_x * scale, com_y + lead_y * scale
        self.xy_world[0], self.xy_world[1] = ref_x, ref_y
