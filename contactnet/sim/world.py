"""What every physics engine shares: the simulation's configuration, what the sensors read (`SimState`), pushes,
the links that touch the terrain, and the referee (`Referee`: falls and the goal, the same rules for every engine).

A backend (``contactnet.sim.pybullet_world.Simulator``, ``contactnet.sim.mujoco_world.MujocoSimulator``) is what the
locomotion loop drives: ``step(tau)`` at ``config.dt_s``, ``state()``, ``foot_contact()``, ``add_push``, ``reset``,
``replace_terrain``, ``close``, and the referee's ``fall_reason()`` / ``reached_goal()``.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field

import numpy as np

from contactnet.frames import quat_to_matrix, quat_to_rpy, yaw_to_quat
from contactnet.sim.mismatch import ModelMismatch
from contactnet.terrain import Terrain

#: The physics engines (``SimConfig.engine``, ``--sim``): PyBullet (the default; every result before issue 28) and
#: MuJoCo (``contactnet.sim.mujoco_world``).
ENGINES = ("pybullet", "mujoco")
#: Each engine's Python module and package.
ENGINE_MODULES = {"pybullet": "pybullet", "mujoco": "mujoco"}
ENGINE_PACKAGES = {"pybullet": "pybullet", "mujoco": "mujoco-core"}
ENGINE_NAMES = {"pybullet": "PyBullet", "mujoco": "MuJoCo"}  # as written in text


def engine_installed(engine: str) -> bool:
    """Whether ``engine``'s Python module can be imported here (found, not imported; a module set to None in
    ``sys.modules``, Python's way to block an import, is not)."""
    import importlib.util
    import sys

    module = ENGINE_MODULES[engine]
    if module in sys.modules:
        return sys.modules[module] is not None
    return importlib.util.find_spec(module) is not None


def default_engine() -> str:
    """PyBullet where it is installed, else MuJoCo (pybullet has wheels up to Python 3.11 only: on a newer Python the
    package does not install it, ``pyproject.toml``)."""
    return "pybullet" if engine_installed("pybullet") else "mujoco"


@dataclass(frozen=True)
class SimConfig:
    """How the world is simulated, and what counts as a fall."""

    dt_s: float = 0.001
    gravity: float = 9.81
    foot_friction: float = 0.9
    joint_vel_noise_var: float = 0.0  # variance of the Gaussian noise on measured joint velocities
    seed: int = 0
    terrain_thickness_m: float = 0.4
    fall_base_height_m: float | None = None  # base origin below the ground + this: fallen (None: the robot's)
    fall_tilt_rad: float = 0.9  # |roll| or |pitch| above this: fallen
    solver_iterations: int = 50
    sphere_feet: bool = True  # False: the URDF's mesh feet (slower; for comparisons)
    mismatch: ModelMismatch = ModelMismatch()  # how the simulated robot differs from the model (neutral: not at all)
    engine: str = field(default_factory=default_engine)  # the physics engine (ENGINES): "pybullet" or "mujoco"

    def __post_init__(self) -> None:
        if self.engine not in ENGINES:
            raise ValueError(f"the physics engine must be one of {', '.join(ENGINES)}, got {self.engine!r}")
        if not 1e-4 <= self.dt_s <= 0.01:
            raise ValueError(f"dt_s must be in [1e-4, 0.01] s, got {self.dt_s}")
        if not (np.isfinite(self.joint_vel_noise_var) and 0.0 <= self.joint_vel_noise_var <= 10.0):
            raise ValueError(f"joint_vel_noise_var must be in [0, 10] (rad/s)^2, got {self.joint_vel_noise_var}")


#: An impulse (N s) is given as a force over this time: short against the robot's step and body dynamics.
IMPULSE_DURATION_S = 0.1


@dataclass(frozen=True)
class Push:
    """An external force on the base, in the world frame, from t0_s for duration_s."""

    t0_s: float
    duration_s: float
    force_world: tuple[float, float, float]

    def active(self, t_s: float) -> bool:
        return self.t0_s <= t_s < self.t0_s + self.duration_s

    @staticmethod
    def at_angle(t0_s: float, angle_rad: float, force_n: float, duration_s: float) -> Push:
        """A horizontal push of ``force_n`` at ``angle_rad`` (world: 0 along +x, pi / 2 along +y), forces to 0.1 mN."""
        fx, fy = round(force_n * math.cos(angle_rad), 4) + 0.0, round(force_n * math.sin(angle_rad), 4) + 0.0
        return Push(t0_s, duration_s, (fx, fy, 0.0))

    @staticmethod
    def impulse(t0_s: float, angle_rad: float, impulse_ns: float) -> Push:
        """An impulse of ``impulse_ns`` newton-seconds at ``angle_rad``: its force over ``IMPULSE_DURATION_S``."""
        return Push.at_angle(t0_s, angle_rad, impulse_ns / IMPULSE_DURATION_S, IMPULSE_DURATION_S)

    @staticmethod
    def parse(text: str) -> Push:
        """Parse 'T0,DURATION,FX,FY' (seconds, seconds, newtons, newtons)."""
        parts = text.split(",")
        if len(parts) != 4:
            raise ValueError(f"--push expects T0,DURATION,FX,FY (4 numbers), got {text!r}")
        try:
            t0, duration, fx, fy = (float(p) for p in parts)
        except ValueError:
            raise ValueError(f"--push expects numbers T0,DURATION,FX,FY, got {text!r}") from None
        if not all(np.isfinite([t0, duration, fx, fy])):
            raise ValueError(f"--push values must be finite, got {text!r}")
        if t0 < 0 or not 0 < duration <= 60:
            raise ValueError(f"--push needs T0 >= 0 and 0 < DURATION <= 60 s, got {text!r}")
        if max(abs(fx), abs(fy)) > 100:
            raise ValueError(f"--push force beyond +-100 N, got {text!r}")
        return Push(t0, duration, (fx, fy, 0.0))


@dataclass(frozen=True)
class BodyContact:
    """A robot link other than a foot touching the terrain (the referee's non-foot contact), world frame."""

    link: str  # the link's name in the URDF, e.g. FR_LOWER_LEG or base_link
    leg: str | None  # the leg the link belongs to (its foot's leg name), None for the body
    point_world: tuple[float, float, float]  # contact point on the terrain, m
    normal_world: tuple[float, float, float]  # contact normal, from the terrain toward the link
    normal_force_n: float
    foot_over_gap: bool  # the link's leg has its foot-ball centre over no steppable ground (a hole, off an edge)

    @property
    def on_edge(self) -> bool:
        """The terrain touches the link with its side or a corner (normal more than ~25 deg off vertical)."""
        return self.normal_world[2] < 0.9


@dataclass
class SimState:
    """What the robot's sensors (and the referee) see at one instant. World frame unless named."""

    t_s: float
    base_pos_world: np.ndarray  # (3,) base-link origin
    base_quat_world: np.ndarray  # (4,) x, y, z, w
    base_lin_vel_world: np.ndarray  # (3,)
    base_ang_vel_world: np.ndarray  # (3,)
    joint_pos: np.ndarray  # (12,) rad, pinocchio order
    joint_vel: np.ndarray  # (12,) rad/s as measured (with the configured noise)
    joint_vel_true: np.ndarray  # (12,) rad/s without noise
    foot_contact: np.ndarray  # (4,) bool, FL FR HL HR touching the terrain
    foot_force_world: np.ndarray = field(repr=False)  # (4, 3) contact force on each foot
    base_rot_world: np.ndarray | None = field(default=None, repr=False)  # (3, 3); None: from the quaternion
    _rpy: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def rpy(self) -> np.ndarray:
        """(3,) base roll, pitch, yaw (rad), computed at the first read (the same array after that: read only)."""
        if self._rpy is None:
            self._rpy = quat_to_rpy(self.base_quat_world)
        return self._rpy

    def q_pinocchio(self) -> np.ndarray:
        """(19,) pinocchio configuration."""
        return np.concatenate([self.base_pos_world, self.base_quat_world, self.joint_pos])

    def v_pinocchio(self) -> np.ndarray:
        """(18,) pinocchio velocity: base velocities in the base frame, then measured joint velocities."""
        rot = quat_to_matrix(self.base_quat_world) if self.base_rot_world is None else self.base_rot_world
        base_vel_world = np.array((self.base_lin_vel_world, self.base_ang_vel_world))  # (2, 3)
        return np.concatenate((np.dot(base_vel_world, rot).ravel(), self.joint_vel))



@dataclass(frozen=True)
class MassProperties:
    """What an engine simulates of a robot's mass, now: total mass (kg), CoM (world, m) and the composite rotational
    inertia about that CoM (world axes, kg m^2), summed over its links (``composite_of``)."""

    mass_kg: float
    com_world: np.ndarray
    inertia_com_world: np.ndarray


def composite_of(masses_kg: np.ndarray, coms_world: np.ndarray, rotations_world: np.ndarray,
                 principal_inertias: np.ndarray) -> MassProperties:
    """The links' (N) masses, CoMs (N, 3), inertial frames (N, 3, 3) and principal moments (N, 3) as one body."""
    masses_kg = np.asarray(masses_kg, dtype=float)
    total = float(masses_kg.sum())
    com = (masses_kg[:, None] * coms_world).sum(axis=0) / total
    inertia = np.zeros((3, 3))
    for m, c, rot, moments in zip(masses_kg, coms_world, rotations_world, principal_inertias, strict=True):
        r = c - com
        inertia += rot @ np.diag(moments) @ rot.T + m * (float(r @ r) * np.eye(3) - np.outer(r, r))
    return MassProperties(total, com, inertia)


def describe_body_contacts(contacts: list[BodyContact]) -> str:
    """The referee's sentence for a non-foot contact: which links touch where, and why when a foot stepped into
    a gap, e.g. "non-foot contact: FR_LOWER_LEG on an edge at x 0.25, y -0.14 m (the FR foot stepped into a
    gap)". Starts with "non-foot contact: " and the link names."""
    places = []
    for contact in contacts:
        x, y, _ = contact.point_world
        where = "on an edge" if contact.on_edge else "on top of the terrain"
        places.append(f"{contact.link} {where} at x {x:.2f}, y {y:.2f} m")
    gap_legs = sorted({c.leg for c in contacts if c.foot_over_gap and c.leg is not None})
    why = ""
    if gap_legs:
        feet = " and ".join(gap_legs)
        why = f" (the {feet} foot stepped into a gap)" if len(gap_legs) == 1 else f" (the {feet} feet stepped into gaps)"
    return "non-foot contact: " + "; ".join(places) + why


@dataclass(frozen=True)
class StandingGains:
    """Joint PD that holds the nominal stance (the simplest controller; the benchmark reference)."""

    kp_nm_per_rad: float = 5.0
    kd_nms_per_rad: float = 0.2


def standing_torques(state: SimState, joint_target: np.ndarray, gains: StandingGains = StandingGains()) -> np.ndarray:
    return gains.kp_nm_per_rad * (joint_target - state.joint_pos) - gains.kd_nms_per_rad * state.joint_vel


class Referee:
    """Falls and the goal, judged on the true state (never the noisy sensors). A backend that mixes this in has
    ``terrain``, ``config`` (`SimConfig`), ``fall_base_height_m``, ``_noisy_base`` (the base's sensors are noisy),
    ``_highest_ground`` (None at first), ``state(with_contacts)``, ``_true_base()`` (position, quaternion x y z w,
    linear and angular velocity, world, without noise) and ``body_contacts()``."""

    terrain: Terrain
    config: SimConfig
    fall_base_height_m: float
    _noisy_base: bool
    _highest_ground: tuple[Terrain, float] | None

    def fall_reason(self, state: SimState | None = None) -> str | None:
        """Why the robot counts as fallen now, or None: base too low, too tilted, or a shin/body contact."""
        s = self._truth(state)
        # The height above the highest ground anywhere bounds the height above the ground here from below: when it
        # clears the limit, the terrain need not be asked (the check runs every few milliseconds).
        terrain = self.terrain
        if self._highest_ground is None or self._highest_ground[0] is not terrain:
            self._highest_ground = (terrain, max(terrain.surface_z, terrain.top_z_range()[1]))
        if float(s.base_pos_world[2]) - self._highest_ground[1] < self.fall_base_height_m:
            height = s.base_pos_world[2] - float(terrain.ground_z(s.base_pos_world[:2]))
            if height < self.fall_base_height_m:
                return f"base height {height:.3f} m below {self.fall_base_height_m} m"
        roll, pitch, _ = s.rpy
        if max(abs(roll), abs(pitch)) > self.config.fall_tilt_rad:
            return f"base tilted (roll {roll:.2f}, pitch {pitch:.2f} rad)"
        touching = self.body_contacts()
        if touching:
            return describe_body_contacts(touching)
        return None

    def _truth(self, state: SimState | None) -> SimState:
        """``state`` for the referee: read now when not given, and read without noise when the base's sensors are
        noisy (the referee sees the truth)."""
        if not self._noisy_base:
            return self.state() if state is None else state
        pos, quat, lin, ang = self._true_base()
        base = state or self.state(with_contacts=False)
        return SimState(base.t_s, np.array(pos), np.array(quat), np.array(lin), np.array(ang), base.joint_pos,
                        base.joint_vel, base.joint_vel_true, base.foot_contact, base.foot_force_world)

    def fallen(self, state: SimState | None = None) -> bool:
        return self.fall_reason(state) is not None

    def reached_goal(self, state: SimState | None = None) -> bool:
        s = self._truth(state)
        return bool(s.base_pos_world[0] >= self.terrain.goal_x)


class EngineBase(Referee):
    """What both backends do alike around their engine: the motor limits and the control delay, the sensor noise of
    the base, the standing height at a reset, pushes and the clock (``_init_common`` first in ``__init__``,
    ``_restart_clock`` at every reset)."""

    def _init_common(self, robot, terrain: Terrain, config: SimConfig) -> None:  # noqa: ANN001 - a Robot
        self.robot = robot
        self.terrain = terrain
        self.config = config
        description = robot.description
        self.torque_limit_nm = np.asarray(description.torque_limit_nm, dtype=float) * config.mismatch.torque_scale
        self._neg_torque_limit_nm = -self.torque_limit_nm
        self.fall_base_height_m = (description.fall_base_height_m if config.fall_base_height_m is None
                                   else float(config.fall_base_height_m))
        self._rng = np.random.default_rng(config.seed)
        self.pushes: list[Push] = []
        self.t_s = 0.0
        self.steps = 0
        self._highest_ground: tuple[Terrain, float] | None = None  # (terrain, its highest ground z), for fall_reason
        self._delay_steps = round(config.mismatch.delay_ms / (1e3 * config.dt_s))
        self._noisy_base = config.mismatch.sensor_noise  # read at 1 kHz (state) and every tick (the referee)
        self._pending_tau: collections.deque = collections.deque()

    def _check_mass(self, simulated_kg: float) -> None:
        """The robot the engine loaded (``simulated_kg``, with the mismatch's mass scale and payload) weighs what the
        model says within 0.5 %; else one line naming both (e.g. a URDF link the engine read another mass for)."""
        mismatch = self.config.mismatch
        expected_kg = self.robot.mass_kg * mismatch.mass_scale + mismatch.payload_kg
        if abs(simulated_kg - expected_kg) > 0.005 * expected_kg:
            from contactnet.robots.description import RobotDataError

            raise RobotDataError(f"{self.engine} simulates {self.robot.description.name} at {simulated_kg:.3f} kg but its "
                                 f"model (pinocchio) weighs {expected_kg:.3f} kg: check the <inertial> blocks of "
                                 f"{self.robot.files.urdf.name}")

    def _restart_clock(self) -> None:
        """A reset: no pushes, time 0, the noise's seed again, no delayed torques."""
        self.pushes = []
        self.t_s = 0.0
        self.steps = 0
        self._rng = np.random.default_rng(self.config.seed)
        self._pending_tau.clear()

    def foot_forces(self) -> tuple[np.ndarray, np.ndarray]:
        """The feet touching the terrain now (4,) and the contact force on each (4, 3; world, N): the engine's contact
        query only, no state read and no sensor noise drawn (a run read this way stays the same run)."""
        return self._foot_contacts()

    def add_push(self, push: Push) -> None:
        self.pushes.append(push)

    def _motor_torque(self, tau: np.ndarray) -> np.ndarray:
        """The torques (12,) that act this step: ``tau`` saturated to the motor limit, and with a control delay the
        ones computed ``delay_ms`` ago (the first ones until then)."""
        tau = np.minimum(np.maximum(np.asarray(tau, dtype=float), self._neg_torque_limit_nm), self.torque_limit_nm)
        if self._delay_steps:
            pending = self._pending_tau
            pending.append(tau)
            tau = pending[0] if len(pending) <= self._delay_steps else pending.popleft()
        return tau

    def _standing_height(self, q_joint: np.ndarray) -> float:
        """The base height (m) at which the lowest foot of the pose ``q_joint`` just touches flat ground."""
        q = np.concatenate([[0, 0, 0], yaw_to_quat(0.0), q_joint])
        return -self.robot.foot_positions_world(q)[:, 2].min() + self.robot.description.foot_radius_m + 1e-3

    def _measured_base(self, quat, rot: np.ndarray, lin: np.ndarray, ang: np.ndarray) -> tuple:  # noqa: ANN001
        """The base's orientation and velocities as the noisy sensors measure them."""
        from scipy.spatial.transform import Rotation

        mismatch, rng = self.config.mismatch, self._rng
        if mismatch.orientation_noise_rad:
            error = Rotation.from_rotvec(rng.normal(0.0, mismatch.orientation_noise_rad, size=3))
            measured = Rotation.from_quat(quat) * error
            quat, rot = measured.as_quat(), measured.as_matrix()
        if mismatch.lin_vel_noise_m_s:
            lin = lin + rng.normal(0.0, mismatch.lin_vel_noise_m_s, size=3)
        if mismatch.ang_vel_noise_rad_s:
            ang = ang + rng.normal(0.0, mismatch.ang_vel_noise_rad_s, size=3)
        return np.asarray(quat, dtype=float), np.asarray(rot, dtype=float), lin, ang


__all__ = ["ENGINES", "ENGINE_MODULES", "ENGINE_NAMES", "ENGINE_PACKAGES", "IMPULSE_DURATION_S", "EngineBase", "MassProperties",
           "composite_of", "default_engine", "engine_installed", "BodyContact", "Push", "Referee", "SimConfig", "SimState", "StandingGains",
           "describe_body_contacts", "standing_torques"]
