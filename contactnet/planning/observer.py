"""The disturbance observer (issue 14, push recovery): an estimate of the horizontal external force on the body.

Neither the optimizer nor the planner knows that someone pushes the robot: the optimizer plans ground forces that
balance gravity only, and the capture step (``contactnet.planning.capture``) reacts to the velocity the push has already
caused. Under pushes of 7.5 N (30 % of Solo12's weight) for 1 s the shipped models fell in 14 of 40 walk trials
and 17 of 40 trot trials, 24 of the 31 after a sideways push (19 of those by tipping over the feet on the pushed
side).

The CoM's momentum tells the force: over one control tick ``m (v_k - v_{k-1}) / dt = sum of the ground forces
applied + m g + F_ext``. The ground forces are the controller's commanded ones (``WholeBodyController.last_forces``
of the tick before); the horizontal part of the difference, low-pass filtered with ``time_constant_s``, estimates
F_ext (horizontal, world frame). Leg inertia, impacts and the torque tracking of the commanded forces make it
noisy (below 1.1 N walking undisturbed on flat, below 0.2 N trotting); below ``threshold_n`` the estimate is not
used at all, so walking that stays below it runs exactly as without the observer. Stumbles over holes can pass it
(in 10 of 93 random-field trials), which is why the observer is off by default until the paper's evaluation has
been run with it. Above it:

* the controller cancels it: its centroidal feedback force gets ``-F_ext``, spread over the stance feet with the
  rest of the feedback wrench (the feet push against the push, and the vertical loads shift to balance the
  moment about the CoM);
* the planner leans into it: the capture step moves the first step's candidate grid by
  ``F_ext h / (m g)`` beyond its velocity part, the offset of the centre of pressure from the CoM that balances
  a horizontal force at the CoM height ``h`` (``contactnet.planning.capture.capture_offset``);
* the trajectory optimizer plans with it (``plan``): at each re-solve the estimate is a known force on the body
  over the horizon (``TrajoptProblem.external_force_world``), so the planned ground forces hold it and the planned
  CoM moves where the feet can hold it from (a walk's three feet cannot hold a sideways push with the CoM near
  the edge of their triangle). The controller then cancels only what changed since that solve.

Computed on Python floats: it runs at 1 kHz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ObserverConfig:
    """How the external force is estimated and used."""

    time_constant_s: float = 0.03  # low-pass filter of the momentum mismatch
    threshold_n: float = 2.0  # an estimate below this (horizontal magnitude) is not used
    feedforward: bool = True  # the controller cancels the estimate
    lean: bool = True  # the capture step leans the footholds into it
    plan: bool = True  # the trajectory optimizer plans with it (its re-solves; the controller cancels the rest)

    def __post_init__(self) -> None:
        for name in ("time_constant_s", "threshold_n"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"ObserverConfig.{name} must be a finite number >= 0, got {value!r}")
        if self.time_constant_s <= 0.0:
            raise ValueError(f"ObserverConfig.time_constant_s must be > 0, got {self.time_constant_s!r}")


#: The recommended settings: ``LocomotionConfig(observer=DEFAULT_OBSERVER)``, ``--observer`` on the command line.
DEFAULT_OBSERVER = ObserverConfig()


class DisturbanceObserver:
    """The filtered horizontal momentum mismatch of the CoM (see the module doc); one per locomotion loop."""

    def __init__(self, config: ObserverConfig, mass_kg: float, dt_s: float) -> None:
        self.config = config
        self.mass_kg = float(mass_kg)
        self.dt_s = float(dt_s)
        self._gain = min(1.0, self.dt_s / config.time_constant_s)
        self.reset()

    def reset(self) -> None:
        """Forget the state (a new episode, or the robot moved by hand)."""
        self.estimate_x_n = self.estimate_y_n = 0.0
        self.max_estimate_n = 0.0
        self._previous_vel: tuple[float, float] | None = None

    def update(self, com_vel_world: np.ndarray, applied_forces_world: np.ndarray) -> None:
        """One tick: ``com_vel_world`` (3,) the CoM velocity now, ``applied_forces_world`` (4, 3) the ground forces
        commanded over the tick that led here (forces on the robot)."""
        vel_x, vel_y = float(com_vel_world[0]), float(com_vel_world[1])
        previous, self._previous_vel = self._previous_vel, (vel_x, vel_y)
        if previous is None:
            return
        (x0, y0, _), (x1, y1, _), (x2, y2, _), (x3, y3, _) = applied_forces_world.tolist()  # four legs
        total_x, total_y = x0 + x1 + x2 + x3, y0 + y1 + y2 + y3
        scale = self.mass_kg / self.dt_s
        mismatch_x = scale * (vel_x - previous[0]) - total_x
        mismatch_y = scale * (vel_y - previous[1]) - total_y
        gain = self._gain
        self.estimate_x_n += gain * (mismatch_x - self.estimate_x_n)
        self.estimate_y_n += gain * (mismatch_y - self.estimate_y_n)
        magnitude = math.hypot(self.estimate_x_n, self.estimate_y_n)
        if magnitude > self.max_estimate_n:
            self.max_estimate_n = magnitude

    def force_for(self, use: str) -> tuple[float, float] | None:
        """``active_force_xy`` if ``use`` (``"lean"``: the planner's, ``"feedforward"``: the controller's, ``"plan"``:
        the trajectory optimizer's) is on in the config, else None."""
        return self.active_force_xy() if getattr(self.config, use) else None

    def feedforward_world(self, planned_world: np.ndarray | None) -> np.ndarray | None:
        """The push (3,) (N, world) the controller cancels (``ControlTarget.external_force_world``): the estimate,
        less ``planned_world``, the force the active plan was solved with (its forces hold that already); after
        a push, minus what the plan still holds. None: nothing to cancel (or the feedforward is off)."""
        if not self.config.feedforward:
            return None
        now = self.force_world("feedforward")
        if now is None and planned_world is None:
            return None
        external = np.zeros(3) if now is None else now
        return external if planned_world is None else external - planned_world

    def force_world(self, use: str) -> np.ndarray | None:
        """``force_for(use)`` as a horizontal force (3,) (N, world), e.g. for ``TrajoptProblem.external_force_world``;
        None when not used."""
        force = self.force_for(use)
        return None if force is None else np.array([force[0], force[1], 0.0])

    def active_force_xy(self) -> tuple[float, float] | None:
        """The estimate (N, world) when it is at least ``threshold_n``, else None (not used)."""
        if not math.hypot(self.estimate_x_n, self.estimate_y_n) >= self.config.threshold_n:
            return None
        return self.estimate_x_n, self.estimate_y_n


__all__ = ["DEFAULT_OBSERVER", "DisturbanceObserver", "ObserverConfig"]
