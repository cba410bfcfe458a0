"""The disturbance observer (issue 14, push recovery): an estimate of the horizontal external force on the body.

Neither the optimizer nor the planner knows that someone pushes the robot: the optimizer plans ground forces that
balance gravity only, and the capture step (``contactnet.planning.capture``) reacts to the velocity the push has already
caused. Under pushes of 7.5 N (30 % of Solo12's weight) for 1 s the shipped models fell in 14 of 40 walk trials
and 17 of 40 trot trials, 24 of the 31 after a sideways push (19 of those by tipping over the feet on the pushed
side).

The CoM's momentum tells the force: ``m dv/dt = sum of the ground forces + m g + F_ext``. A second-order
observer per horizontal axis tracks the CoM velocity and the force together: it predicts the velocity from the
ground forces the torques of the tick before delivered (``WholeBodyController.delivered_forces``: each stance leg's
static balance with its own weight, on the feet the contact sensor says are down) and its current force
estimate, and corrects both by the error of that prediction against the measured velocity (gains ``2 w`` and
``m w^2``, ``w`` = ``bandwidth_rad_s``: both poles at ``-w``). A constant force is then seen as
``F (1 - (1 + w t) e^(-w t))`` (63 % after ``2.15 / w``). It never differentiates the measured velocity, so
white velocity noise of spectral density ``S`` (std ``sigma`` per tick: ``S = sigma^2 dt``) reaches the
estimate with std ``m w^1.5 sqrt(S) / 2``: 0.5 N at ``w = 40 rad/s`` with base-velocity noise of 0.05 m/s at 1 kHz.
(The first version filtered the differentiated momentum, ``m (v_k - v_(k-1)) / dt``, over 30 ms: that noise gave
it about 4 N of false pushes, and with noisy base sensors the robot crossed 2 of 30 fields instead of 30.)
Leg inertia and impacts are the rest of its noise walking undisturbed (0.05 N median, 0.5 N at most over 8 s of
Solo12's walk on flat). It first subtracted the commanded forces (``last_forces``), which leave the legs' weight
out: that read 0.2 N median on flat, and on Table II's seed 3 a rear leg stretched behind the standing robot
delivered 2-3 N backwards that nobody commanded; the estimate crept to 6 N and the walk fell. A tick with a
stance leg stretched straight (``min_leg_jacobian_m``), whose torques do not tell the force along it, holds the
estimate. Below ``threshold_m_s2`` times the robot's mass (2 N for Solo12, 13 N for Go2) the estimate is not used
at all, so walking that stays below it runs exactly as without the observer. Above it:

* the controller cancels it: its centroidal feedback force gets ``-F_ext``, spread over the stance feet with the
  rest of the feedback wrench (the feet push against the push, and the vertical loads shift to balance the
  moment about the CoM);
* the planner leans into it: the capture step moves the first step's candidate grid by
  ``F_ext h / (m g)`` beyond its velocity part, the offset of the centre of pressure from the CoM that balances
  a horizontal force at the CoM height ``h`` (``contactnet.planning.capture.capture_offset``);
* the trajectory optimizer plans with it (``plan``) when it rose from half the threshold to the threshold within
  0.2 s (``onset_s``: a push is sudden, a slow drift is kept out): at each re-solve the estimate is a known force
  on the body
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

    bandwidth_rad_s: float = 40.0  # both poles of the velocity-and-force observer (63 % of a step after 2.15 / w)
    threshold_m_s2: float = 0.8  # an estimate below this times the mass (horizontal magnitude, N) is not used
    # the trajectory optimizer plans with it only when it rose from half the threshold to the threshold within this
    # time (a push is sudden, a drift of the estimate is slow), and then until it falls below the threshold
    onset_s: float = 0.2
    # a tick with a stance leg whose foot Jacobian's smallest singular value is below this (m: the leg stretched
    # straight; about 9 cm in Solo12's stance) holds the estimate: the leg's torques do not tell its ground force
    min_leg_jacobian_m: float = 0.03
    feedforward: bool = True  # the controller cancels the estimate
    lean: bool = True  # the capture step leans the footholds into it
    plan: bool = True  # the trajectory optimizer plans with it (its re-solves; the controller cancels the rest)

    def __post_init__(self) -> None:
        for name in ("threshold_m_s2", "onset_s", "min_leg_jacobian_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"ObserverConfig.{name} must be a finite number >= 0, got {value!r}")
        # 500 rad/s: beyond it the 1 kHz loop's explicit update is no longer a good approximation (w dt = 0.5)
        if not (math.isfinite(self.bandwidth_rad_s) and 0.0 < self.bandwidth_rad_s <= 500.0):
            raise ValueError(f"ObserverConfig.bandwidth_rad_s must be in (0, 500], got {self.bandwidth_rad_s!r}")


#: The recommended settings: ``LocomotionConfig(observer=DEFAULT_OBSERVER)``, ``--observer`` on the command line.
DEFAULT_OBSERVER = ObserverConfig()


class DisturbanceObserver:
    """The horizontal CoM velocity and external force, observed together from the momentum (see the module doc); one
    per locomotion loop."""

    def __init__(self, config: ObserverConfig, mass_kg: float, dt_s: float) -> None:
        self.config = config
        self.mass_kg = float(mass_kg)
        self.dt_s = float(dt_s)
        w = config.bandwidth_rad_s
        self._velocity_gain = 2.0 * w * self.dt_s  # per tick, on the velocity's prediction error
        self._force_gain_n_per_m_s = self.mass_kg * w * w * self.dt_s  # per tick, N per (m/s) of that error
        # the first 1 / w seconds: the observed velocity is the mean of the measured ones and the force is not yet
        # estimated (one noisy first sample taken as the velocity would be a false push of m w |error| / e)
        self._warmup_ticks = max(1, round(1.0 / (w * self.dt_s)))
        self.threshold_n = config.threshold_m_s2 * self.mass_kg  # the estimate is used from this force on
        self.reset()

    def reset(self) -> None:
        """Forget the state (a new episode, or the robot moved by hand)."""
        self.estimate_x_n = self.estimate_y_n = 0.0
        self.max_estimate_n = 0.0
        self._vel_xy: tuple[float, float] | None = None  # the observed CoM velocity (m/s, world)
        self._sudden = False  # the estimate rose to the threshold within ObserverConfig.onset_s
        self._samples = 0  # velocities measured since the reset
        self._last_quiet_sample = 0  # the last of them with the estimate below half the threshold

    def update(self, com_vel_world: np.ndarray, applied_forces_world: np.ndarray, known: bool = True) -> None:
        """One tick: ``com_vel_world`` (3,) the CoM velocity measured now, ``applied_forces_world`` (4, 3) the ground
        forces on the robot over the tick that led here (``WholeBodyController.delivered_forces``, zero for a foot
        in the air). ``known`` False: those forces are not known (a stance leg stretched straight), so the tick
        tells nothing about the push: the velocity is followed (the measurement taken as it is) and the estimate
        held."""
        vel_x, vel_y = float(com_vel_world[0]), float(com_vel_world[1])
        if not known and self._vel_xy is not None:
            self._vel_xy = (vel_x, vel_y)
            return
        self._samples += 1
        if self._samples <= self._warmup_ticks:  # the mean so far: the velocity's estimate under white noise
            if self._vel_xy is None:
                self._vel_xy = (vel_x, vel_y)
            else:
                share = 1.0 / self._samples
                self._vel_xy = (self._vel_xy[0] + share * (vel_x - self._vel_xy[0]),
                                self._vel_xy[1] + share * (vel_y - self._vel_xy[1]))
            return
        (x0, y0, _), (x1, y1, _), (x2, y2, _), (x3, y3, _) = applied_forces_world.tolist()  # four legs
        step = self.dt_s / self.mass_kg
        # the velocity predicted from the forces of the tick: the commanded ground forces and the estimated push
        predicted_x = self._vel_xy[0] + step * (x0 + x1 + x2 + x3 + self.estimate_x_n)
        predicted_y = self._vel_xy[1] + step * (y0 + y1 + y2 + y3 + self.estimate_y_n)
        error_x, error_y = vel_x - predicted_x, vel_y - predicted_y
        gain = self._velocity_gain
        self._vel_xy = (predicted_x + gain * error_x, predicted_y + gain * error_y)
        self.estimate_x_n += self._force_gain_n_per_m_s * error_x
        self.estimate_y_n += self._force_gain_n_per_m_s * error_y
        magnitude = math.hypot(self.estimate_x_n, self.estimate_y_n)
        if magnitude > self.max_estimate_n:
            self.max_estimate_n = magnitude
        if magnitude < 0.5 * self.threshold_n:
            self._last_quiet_sample = self._samples
        if magnitude < self.threshold_n:
            self._sudden = False
        elif not self._sudden:  # the onset: from half the threshold to the threshold within onset_s
            self._sudden = (self._samples - self._last_quiet_sample) * self.dt_s <= self.config.onset_s

    def force_for(self, use: str) -> tuple[float, float] | None:
        """``active_force_xy`` if ``use`` (``"lean"``: the planner's, ``"feedforward"``: the controller's, ``"plan"``:
        the trajectory optimizer's) is on in the config, else None; for ``"plan"`` only if the estimate rose suddenly
        (``ObserverConfig.onset_s``)."""
        if not getattr(self.config, use) or (use == "plan" and not self._sudden):
            return None
        return self.active_force_xy()

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
        if not math.hypot(self.estimate_x_n, self.estimate_y_n) >= self.threshold_n:
            return None
        return self.estimate_x_n, self.estimate_y_n


__all__ = ["DEFAULT_OBSERVER", "DisturbanceObserver", "ObserverConfig"]
