"""The 1 kHz whole-body controller: track the optimizer's CoM motion and forces, swing the feet.

Per tick (`WholeBodyController.torques`), as in the paper's Fig. 3 (after Grimminger et al. 2020):
1. centroidal feedback: a PD on the CoM position/velocity and on the base orientation/angular
   velocity gives a corrective wrench; its horizontal force is scaled down where the centre of pressure
   would leave the stance feet's polygon (``cop_margin_m``: beyond the paper, against tipping under pushes);
   the wrench is spread over the stance feet (regularized least squares;
   with ``unload_rounds``, feet it would make pull are held at the minimum load and the rest spread
   again over the others) and added to the optimizer's reference forces; the forces are kept in the
   friction pyramid, built about the ground's normal under each foot (``ControlTarget.contact_normals_world``;
   +z on flat ground);
2. stance legs: tau = -J^T f (the ground pushes the robot with f);
3. swing legs: a Cartesian PD that tracks the swing trajectory (semi-ellipse for the horizontal
   progress, fifth-order polynomial for the height, in the swing frame);
4. a joint impedance layer: joint damping on every joint; with ``leg_gravity`` > 0, that share of each leg's own
   weight held by its joints (``tau += g_leg(q)``: a stance leg then gives the ground the planned force, and one
   planned with almost none holds its pose instead of sagging and sliding its foot; off in the paper's controller,
   whose legs are massless);
5. torques saturated to the motor limit.
Kinematics and Jacobians come from pinocchio on the measured state.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields, replace

import numpy as np

from contactnet.motion.controller_kernel import leg_ground_forces, pack_gains, wbc_torques
from contactnet.robots.description import Robot, RobotDescription

#: Damping of ``delivered_forces``'s least squares (m^2): directions in which a leg's Jacobian is below about 2 cm
#: (a leg stretched straight) are damped instead of amplifying torque errors.
LEG_FORCE_DAMPING_M2 = 4e-4


@dataclass(frozen=True)
class ControllerGains:
    """Gains of the whole-body controller (SI units)."""

    kp_com: tuple[float, float, float] = (60.0, 60.0, 120.0)  # N/m, per robot (times mass below)
    kd_com: tuple[float, float, float] = (8.0, 8.0, 10.0)  # N s/m, per kg
    kp_base_rot: tuple[float, float, float] = (300.0, 300.0, 150.0)  # N m/rad per kg m^2 of inertia
    kd_base_rot: tuple[float, float, float] = (25.0, 25.0, 15.0)
    kp_swing: tuple[float, float, float] = (150.0, 150.0, 150.0)  # N/m
    kd_swing: tuple[float, float, float] = (6.0, 6.0, 6.0)  # N s/m
    kd_joint: float = 0.02  # N m s/rad, joint damping on every joint
    force_regularization: float = 1e-3
    mu: float = 0.6
    fz_min_n: float = 0.5  # stance feet keep a little load so they do not slip off
    fz_max_n: float | None = None  # None: the robot's (RobotDescription.fz_max_n)
    # A stance foot the feedback would make pull on the ground is held at fz_min_n and the rest of the wrench spread
    # again over the others, up to this many rounds (0: spread once, then clip, as in the paper's controller).
    unload_rounds: int = 0
    # The horizontal feedback force is scaled down so the centre of pressure stays this far inside the stance
    # feet's polygon (controller_kernel.cop_scale); None: not limited.
    cop_margin_m: float | None = 0.01
    # The share of each leg's own weight its joints hold (pinocchio's generalized gravity, the joints' rows): 0 leaves
    # the legs massless (the paper's controller, Solo12's); 1 holds all of it (Go2's on terrain of one level).
    leg_gravity: float = 0.0

    def __post_init__(self) -> None:
        share = self.leg_gravity
        if not (isinstance(share, int | float) and math.isfinite(share) and 0.0 <= share <= 1.0):
            raise ValueError(f"ControllerGains.leg_gravity must be a share in [0, 1] of the legs' weight, got {share!r}")
        margin = self.cop_margin_m
        if margin is not None and not (isinstance(margin, int | float) and math.isfinite(margin) and margin >= 0.0):
            raise ValueError(f"ControllerGains.cop_margin_m must be None (off) or a finite number >= 0 (m), got {margin!r}")

    @classmethod
    def for_robot(cls, robot: RobotDescription) -> ControllerGains:
        """The defaults with the robot's force cap and the gains its module (or file) sets differently."""
        gains = dict(robot.controller_gains)
        unknown = sorted(set(gains) - {f.name for f in fields(cls)})
        if unknown:
            from contactnet.robots import RobotDataError

            raise RobotDataError(f"robot {robot.name}: unknown controller gain {unknown[0]!r} (gains: "
                                 f"{', '.join(f.name for f in fields(cls))})")
        try:
            return replace(cls(fz_max_n=robot.fz_max_n), **gains)
        except ValueError as exc:  # a value out of its range (e.g. leg_gravity 2): one line that names the robot
            from contactnet.robots import RobotDataError

            raise RobotDataError(f"robot {robot.name}: {exc}") from None


@dataclass(frozen=True)
class SwingTrajectory:
    """A foot's swing from `start_world` to `end_world` between t0_s and t1_s, apex `height_m` above
    the higher of the two points (and above `clear_z_m`, the highest point the foot must pass over, when
    given). For the first `liftoff_fraction` and the last `touchdown_fraction` of the swing time the foot
    only rises or descends (no horizontal motion): it leaves or lands near-vertically next to a higher top."""

    start_world: np.ndarray
    end_world: np.ndarray
    t0_s: float
    t1_s: float
    height_m: float = 0.05
    clear_z_m: float | None = None  # world z the foot centre passes over (highest terrain on the way + radius)
    liftoff_fraction: float = 0.0  # share of the swing time rising at the lift-off point (no horizontal motion)
    touchdown_fraction: float = 0.0  # share descending onto the landing point (the two add up to at most 0.6)

    @property
    def apex_z(self) -> float:
        """World z of the foot centre at mid-swing."""
        return self._constants[6]

    @functools.cached_property
    def _constants(self) -> tuple[float, ...]:
        """(x0, y0, z0, x1, y1, z1, apex_z) as Python floats, computed at the first use (``sample`` runs at 1 kHz)."""
        top = max(float(self.start_world[2]), float(self.end_world[2]))
        if self.clear_z_m is not None:
            top = max(top, float(self.clear_z_m))
        return (*self.start_world.tolist(), *self.end_world.tolist(), top + self.height_m)

    def sample(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration (world frame) at time t_s (clamped to the swing).

        Computed on Python floats (it runs at 1 kHz for every swinging foot)."""
        duration = self.t1_s - self.t0_s
        s = min(max((t_s - self.t0_s) / duration, 0.0), 1.0)
        x0, y0, z0, x1, y1, z1, apex = self._constants
        dx, dy = x1 - x0, y1 - y0
        # Horizontal: the projection of a semi-ellipse swept at a constant angular rate (between the
        # vertical parts at both ends, if any).
        f0, f1 = self.liftoff_fraction, self.touchdown_fraction
        if f0 > 0.0 or f1 > 0.0:
            share = 1.0 - f0 - f1
            moving = duration * share
            theta = math.pi * min(max((s - f0) / share, 0.0), 1.0)
            still = s <= f0 or s >= 1.0 - f1
        else:
            moving, theta, still = duration, math.pi * s, False
        cos_theta = math.cos(theta)
        h = 0.5 * (1.0 - cos_theta)
        dh = 0.0 if still else 0.5 * math.pi * math.sin(theta) / moving
        ddh = 0.0 if still else 0.5 * math.pi**2 * cos_theta / moving**2
        # Vertical: a quintic up to the apex, then a quintic down (zero velocity and acceleration at
        # lift-off, apex and touchdown), on top of a linear blend of the two end heights.
        t_half = 0.5 * duration
        if s < 0.5:
            tau, rise, base, sign = 2.0 * s, apex - z0, z0, 1.0
        else:
            tau, rise, base, sign = 2.0 * (1.0 - s), apex - z1, z1, -1.0
        p5 = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
        dp5 = (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / t_half
        ddp5 = (60 * tau - 180 * tau**2 + 120 * tau**3) / t_half**2
        pos = np.array([x0 + h * dx, y0 + h * dy, base + rise * p5])
        vel = np.array([dh * dx, dh * dy, sign * rise * dp5])
        acc = np.array([ddh * dx, ddh * dy, rise * ddp5])
        return pos, vel, acc

    def height_at_progress(self, progress: np.ndarray) -> np.ndarray:
        """World z of the foot centre when it has covered ``progress`` (fractions in [0, 1]) of the horizontal
        distance: where the swing passes over the terrain it must clear."""
        f = np.clip(np.asarray(progress, dtype=float), 0.0, 1.0)
        f0, f1 = self.liftoff_fraction, self.touchdown_fraction
        s = f0 + (1.0 - f0 - f1) * np.arccos(1.0 - 2.0 * f) / math.pi
        z0, z1, apex = float(self.start_world[2]), float(self.end_world[2]), self.apex_z
        tau = np.where(s < 0.5, 2.0 * s, 2.0 * (1.0 - s))
        p5 = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
        return np.where(s < 0.5, z0 + (apex - z0) * p5, z1 + (apex - z1) * p5)


@dataclass
class ControlTarget:
    """What the controller tracks at one instant (world frame)."""

    com_pos: np.ndarray  # (3,)
    com_vel: np.ndarray  # (3,)
    rpy: np.ndarray  # (3,) base roll, pitch, yaw
    ang_vel: np.ndarray  # (3,)
    forces: np.ndarray  # (4, 3) reference ground reaction forces (zero for swing legs)
    stance: np.ndarray  # (4,) bool
    swing_pos: np.ndarray  # (4, 3) desired foot positions (used for swing legs)
    swing_vel: np.ndarray  # (4, 3)
    external_force_world: np.ndarray | None = None  # (3,) estimated push on the body, cancelled (None: none)
    contact_normals_world: np.ndarray | None = None  # (4, 3) unit normals of the ground under the feet (None: +z)


def clip_to_friction_pyramid(forces: np.ndarray, mu: float, fz_min: float, fz_max: float) -> np.ndarray:
    """Project each (3,) force into {fz_min <= fz <= fz_max, |fx|, |fy| <= mu fz} (axis-wise)."""
    out = np.array(forces, dtype=float)
    out[..., 2] = np.minimum(np.maximum(out[..., 2], fz_min), fz_max)
    limit = mu * out[..., 2:3]
    out[..., :2] = np.minimum(np.maximum(out[..., :2], -limit), limit)
    return out


class WholeBodyController:
    """Torques from the measured state and a ControlTarget; one instance per simulation thread."""

    def __init__(self, robot: Robot, gains: ControllerGains | None = None):
        import pinocchio as pin

        self._pin = pin
        self.robot = robot
        description = robot.description
        gains = ControllerGains.for_robot(description) if gains is None else gains
        if gains.fz_max_n is None:
            gains = replace(gains, fz_max_n=description.fz_max_n)
        self.gains = gains
        self.torque_limit_nm = np.asarray(description.torque_limit_nm, dtype=float)
        self.model = robot.model
        self.data = robot.model.createData()
        self.foot_ids = [robot.model.getFrameId(f) for f in description.foot_frames]
        self.mass = robot.mass_kg
        self.inertia_diag = np.diag(robot.inertia_com_standing).copy()
        self._kp_com = np.array(gains.kp_com) * self.mass
        self._kd_com = np.array(gains.kd_com) * self.mass
        self._kp_rot = np.array(gains.kp_base_rot) * self.inertia_diag
        self._kd_rot = np.array(gains.kd_base_rot) * self.inertia_diag
        self._kp_swing = np.array(gains.kp_swing)
        self._kd_swing = np.array(gains.kd_swing)
        self._gains = pack_gains(self._kp_com, self._kd_com, self._kp_rot, self._kd_rot, self._kp_swing,
                                 self._kd_swing, gains.mu, gains.fz_min_n, gains.fz_max_n, gains.kd_joint,
                                 gains.force_regularization, gains.unload_rounds, gains.cop_margin_m,
                                 gains.leg_gravity)
        self._gravity_tau = np.zeros(12)  # the legs' weight's torques of the last ``torques`` call (when on) ...
        self._gravity_q: np.ndarray | None = None  # ... at this configuration array (None: not computed there)
        self._no_force = np.zeros(3)
        self._up = np.zeros((4, 3))
        self._up[:, 2] = 1.0
        self._frame_jacobian = pin.getFrameJacobian
        self._frame_placement = pin.updateFramePlacement
        self._local_world_aligned = pin.LOCAL_WORLD_ALIGNED
        self._rpy_to_matrix = pin.rpy.rpyToMatrix
        # Filled by the last call, for viewers and tests.
        self.last_forces = np.zeros((4, 3))
        self.last_foot_pos = np.zeros((4, 3))
        self.last_com = np.zeros(3)
        self.last_com_vel = np.zeros(3)
        self._last_jacobians: tuple | None = None  # the feet's Jacobians of the last ``torques`` call

    def kinematics(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """CoM position, CoM velocity, foot positions (4, 3) and foot Jacobians (4, 3, 18), world frame."""
        pin, model, data = self._pin, self.model, self.data
        com = pin.centerOfMass(model, data, q, v)  # also runs forward kinematics with velocities
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        feet = np.array([data.oMf[fid].translation for fid in self.foot_ids])
        jacobians = np.array([pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3] for fid in self.foot_ids])
        return np.array(com), np.array(data.vcom[0]), feet, jacobians

    def torques(self, q: np.ndarray, v: np.ndarray, target: ControlTarget) -> np.ndarray:
        """Joint torques (12,), saturated, for configuration q (19,) and velocity v (18,) (pinocchio).

        Runs at 1 kHz: the kinematics of ``kinematics`` with one forward-kinematics pass (pinocchio), then steps
        1-5 in one compiled call (``contactnet.motion.controller_kernel.wbc_torques``: about 25 numpy operations on tiny
        arrays cost 20 us a tick, the compiled loops about 1 us)."""
        pin, model, data = self._pin, self.model, self.data
        com = pin.centerOfMass(model, data, q, v)  # forward kinematics with velocities, then the CoM
        vcom = np.array(data.vcom[0])
        pin.computeJointJacobians(model, data)  # on that forward kinematics
        # The feet's Jacobians and positions (written out: a comprehension costs a function call per tick).
        jacobian, placement, frame = self._frame_jacobian, self._frame_placement, self._local_world_aligned
        f0, f1, f2, f3 = self.foot_ids
        jacobians = (jacobian(model, data, f0, frame), jacobian(model, data, f1, frame),
                     jacobian(model, data, f2, frame), jacobian(model, data, f3, frame))
        feet = (placement(model, data, f0).translation, placement(model, data, f1).translation,
                placement(model, data, f2).translation, placement(model, data, f3).translation)
        rot = data.oMi[1].rotation  # base orientation
        rot_err = pin.log3(np.dot(self._rpy_to_matrix(target.rpy), rot.T))
        external = self._no_force if target.external_force_world is None else target.external_force_world
        tau, forces, foot_pos = np.empty(12), np.empty((4, 3)), np.empty((4, 3))  # new each tick: callers keep them
        self._gravity_q = None
        if self.gains.leg_gravity:
            self._gravity_tau, self._gravity_q = self._leg_gravity(q).copy(), q  # (pinocchio may reuse its array)
        wbc_torques(  # steps 1-5, compiled (contactnet.motion.controller_kernel)
            com, vcom, jacobians, feet, rot, v, rot_err, target.com_pos, target.com_vel, target.ang_vel,
            target.forces, np.asarray(target.stance, dtype=bool), target.swing_pos, target.swing_vel, external,
            self._gains, self.torque_limit_nm, tau, forces, foot_pos,
            self._up if target.contact_normals_world is None else target.contact_normals_world, self._gravity_tau)
        self.last_forces = forces
        self.last_foot_pos = foot_pos
        self.last_com = com
        self.last_com_vel = vcom
        self._last_jacobians = jacobians
        return tau

    def delivered_forces(self, q: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(4, 3) the ground forces (on the robot, world frame) that the torques ``tau`` (12,), as applied at ``q``
        (the configuration of the last ``torques`` call), deliver on each foot that is on the ground: each leg's
        static balance with its own weight, ``tau = g_leg(q) - J^T f``
        (``contactnet.motion.controller_kernel.leg_ground_forces``).

        Not ``last_forces``: step 2 commands ``tau = -J^T f`` and leaves the legs' weight out, so the ground
        receives the commanded forces plus ``J^-T g_leg``, a few tenths of a newton per leg that grow as a leg
        stretches (a rear leg stretched behind a standing robot: 2-3 N backwards, measured against PyBullet's
        contact forces), and the saturated torques, not the commanded forces, are what the motors give. The
        disturbance observer (``contactnet.planning.observer``) takes these forces, so that neither reads as a
        push.

        Also returns (4,) each leg's smallest singular value of its foot Jacobian (m): about 9 cm in Solo12's
        stance, near 0 for a leg stretched straight, whose torques do not tell the force along it."""
        if self._last_jacobians is None:
            raise RuntimeError("delivered_forces needs a torques() call first (its Jacobians)")
        gravity = self._gravity_tau if q is self._gravity_q else self._leg_gravity(q)  # torques' own, when it made it
        forces, sigma_min = np.empty((4, 3)), np.empty(4)
        leg_ground_forces(self._last_jacobians, np.asarray(tau, dtype=float), gravity, LEG_FORCE_DAMPING_M2, forces,
                          sigma_min)
        return forces, sigma_min

    def _leg_gravity(self, q: np.ndarray) -> np.ndarray:
        """(12,) the torques that hold the legs' own weight at ``q`` (pinocchio's generalized gravity without the base
        rows)."""
        return self._pin.computeGeneralizedGravity(self.model, self.data, q)[6:]
