"""A quadruped as a parameter: what a robot module states (`RobotSpec`), what is derived from its
URDF + SRDF (`RobotDescription`, frozen plain numbers), and the loaded model (`Robot`: pinocchio).

A robot module (``contactnet/robots/solo12.py``, ``go2.py``) writes one `RobotSpec`: where its files
lie inside the `example-robot-data` wheel, the names of its legs, joints and feet, and the few numbers
the files do not say (foot radius, torque limit when the URDF's is not the motor's, contact force cap,
kinematic threshold of the ranking cost, fall height, controller gain overrides, how PyBullet should
see its collisions). `Robot.load(spec)` builds the pinocchio model and derives the rest: mass,
composite inertia, CoM, hip and nominal foot positions, standing heights, limits, reach.

Conventions used across contactnet (any robot):
- legs are ordered front-left, front-right, hind-left, hind-right (index 0..3, canonical names
  ``LEG_NAMES``), joints per leg abduction, hip flexion, knee (pinocchio order);
- ``q`` is pinocchio's configuration (19: base xyz, base quaternion xyzw, 12 joints), ``v`` its
  velocity (18: base linear and angular velocity in the base frame, 12 joint velocities);
- arrays say their frame in their name: ``_world``, ``_base`` (base link frame), ``_com`` (CoM frame:
  origin at the CoM, axes aligned with the world but rotated by the base yaw).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from contactnet.robots.sim_urdf import write_pybullet_urdf

if TYPE_CHECKING:
    from contactnet.terrain import Terrain

#: The leg length (m) the paper's gaits are sized for: Solo12's hip flexion joint to knee to foot centre, 0.3245 m
#: (``RobotDescription.leg_reach_m``; ``contactnet.motion.gait.SIZE_RULE``).
REFERENCE_LEG_M = 0.3245
#: The weight (N) the ranking cost's force term is tuned for: Solo12's, 2.5 kg (``RobotDescription.weight_n`` to
#: 0.01 N; ``contactnet.planning.cost.ranking_trajopt_weights``).
REFERENCE_WEIGHT_N = 24.53
#: Canonical leg order and names of every quadruped here (a robot's own prefixes map onto these).
LEG_NAMES: tuple[str, ...] = ("FL", "FR", "HL", "HR")

#: Makes the collision element PyBullet simulates for one link of the URDF, or None to keep the URDF's:
#: ``(link_name) -> (geometry element, origin xyz text) | None``, or a list of ``(geometry element, origin xyz text,
#: origin rpy text)``: the link's collisions, all of the URDF's replaced (a bent lower leg as two cylinders).
CollisionRecipe = Callable[[str], "tuple[ET.Element, str] | list[tuple[ET.Element, str, str]] | None"]


class RobotDataError(RuntimeError):
    """The robot description files are missing or unreadable (a broken installation)."""


@dataclass(frozen=True)
class RobotSpec:
    """What a robot module states; everything else is read from its URDF and SRDF."""

    name: str
    description_dir: str  #: folder under example-robot-data/robots/, e.g. "solo_description"
    urdf: str  #: path of the URDF inside description_dir
    srdf: str  #: path of the SRDF inside description_dir
    standing_pose: str  #: SRDF group_state of the nominal stance
    leg_prefixes: tuple[str, str, str, str]  #: the robot's names of FL, FR, HL, HR
    joint_suffixes: tuple[str, str, str]  #: abduction, hip flexion, knee: joint = f"{prefix}_{suffix}"
    foot_suffix: str  #: foot frame = f"{prefix}_{foot_suffix}"
    foot_radius_m: float  #: radius of the foot ball; the foot frame is its centre
    fz_max_n: float  #: the whole-body controller's cap on one foot's normal force
    kin_threshold_m: float  #: ranking cost: horizontal foot-to-hip distance a stance foot may reach
    fall_base_height_m: float  #: base origin below the ground by less than this: fallen
    torque_limit_nm: float | None = None  #: every joint's limit; None: the URDF's effort limits
    #: The nominal stance's (abduction, hip flexion, knee) angles of every leg, rad, instead of the SRDF
    #: pose's (for a robot whose SRDF stance does not put the feet under the hips); None: the SRDF's.
    standing_leg_joints_rad: tuple[float, float, float] | None = None
    description: str = ""
    #: ControllerGains fields this robot sets differently from the defaults, as (name, value) pairs.
    controller_gains: tuple[tuple[str, Any], ...] = ()
    #: How PyBullet sees the collisions (see `CollisionRecipe`); None: the URDF's meshes.
    collision_recipe: CollisionRecipe | None = field(default=None, compare=False)
    recipe_version: str = "v1"  #: bump when collision_recipe changes (new cached URDF file)
    #: How much larger than the paper's Solo12 the robot's gaits are sized (``contactnet.motion.gait.SIZE_RULE``);
    #: None: its leg's length over `REFERENCE_LEG_M`, to 0.001.
    size_scale: float | None = None
    #: The walk's crouch on terrain of one level by default (m: the CoM reference this much lower,
    #: ``LocomotionConfig.crouch_m``); 0: the nominal height. Solo12 keeps 0 (its 2 cm, measured: docs/results.md).
    walk_crouch_m: float = 0.0
    #: The same for the trot (m, on terrain of one level); 0: the nominal height.
    trot_crouch_m: float = 0.0
    #: Each leg's abduction this much further out than the stance's (rad, SRDF pose or ``standing_leg_joints_rad``):
    #: the feet wider apart, sideways from under the hips. 0: the stance as given.
    stance_abduction_rad: float = 0.0
    #: On terrain of one level (every top flat, at one height), each leg's abduction this much further out instead of
    #: ``stance_abduction_rad`` (`Robot.for_terrain`): wider feet where no top is there for the legs to meet. 0: the
    #: same stance on every terrain.
    one_level_stance_abduction_rad: float = 0.0
    #: The gaits (by name) that take ``one_level_stance_abduction_rad``; None: every gait. Go2: the trot only.
    one_level_stance_gaits: tuple[str, ...] | None = None
    #: On terrain of one level, how far beyond where it is a foot in the air on the push's side lands when bracing
    #: puts it down (m, along the estimated push: ``BraceConfig.outward_m``); 0: where it is.
    brace_outward_m: float = 0.0
    #: ControllerGains fields set on terrain of one level only, every gait (`Robot.for_terrain`), over
    #: ``controller_gains``. Go2: its legs' weight held (``leg_gravity``), measured to help there and not on heights.
    one_level_controller_gains: tuple[tuple[str, Any], ...] = ()
    #: ControllerGains fields set on terrain with heights only, every gait (`Robot.for_terrain`), over
    #: ``controller_gains``. Solo12: its stance feet pressed with at least 4 % of its weight (``fz_min_n``), measured
    #: to keep a foot on a stone's edge there and to cost pushes and the narrow stones on one level.
    heights_controller_gains: tuple[tuple[str, Any], ...] = ()

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(f"{leg}_{kind}" for leg in self.leg_prefixes for kind in self.joint_suffixes)

    @property
    def foot_frames(self) -> tuple[str, ...]:
        return tuple(f"{leg}_{self.foot_suffix}" for leg in self.leg_prefixes)

    @property
    def hip_frames(self) -> tuple[str, ...]:
        """The hip flexion joints: the legs' hips."""
        return tuple(f"{leg}_{self.joint_suffixes[1]}" for leg in self.leg_prefixes)


@dataclass(frozen=True)
class RobotFiles:
    """Where a robot's description lives inside the installed example-robot-data wheel."""

    urdf: Path
    srdf: Path | None  #: None: the stance is the spec's standing_leg_joints_rad
    package_root: Path  #: the folder that ``package://example-robot-data/...`` resolves against

    @staticmethod
    def locate(spec: RobotSpec) -> RobotFiles:
        """Find the files through the installed distribution's file list (no hard-coded site-packages), or in the
        folder ``spec.description_dir`` names when it is an absolute path (a robot file's own description: its
        ``package://NAME/...`` mesh paths resolve against the folder's parent)."""
        if Path(spec.description_dir).is_absolute():
            description = Path(spec.description_dir)
            files = RobotFiles(urdf=description / spec.urdf, srdf=description / spec.srdf if spec.srdf else None,
                               package_root=description.parent)
            for path in (files.urdf, files.srdf):
                if path is not None and not path.is_file():
                    raise RobotDataError(f"missing robot file {path}")
            return files
        try:
            dist = metadata.distribution("example-robot-data")
        except metadata.PackageNotFoundError as exc:
            raise RobotDataError(
                "the 'example-robot-data' package is not installed (pip install example-robot-data)"
            ) from exc
        suffix = f"example-robot-data/robots/{spec.description_dir}/{spec.urdf}"
        for file in dist.files or ():
            if str(file).endswith(suffix):
                urdf = Path(dist.locate_file(file)).resolve()
                break
        else:
            raise RobotDataError(f"example-robot-data {dist.version} does not ship {suffix}")
        description = urdf.parents[len(Path(spec.urdf).parts) - 1]
        files = RobotFiles(urdf=urdf, srdf=description / spec.srdf if spec.srdf else None,
                           package_root=description.parent.parent.parent)
        for path in (files.urdf, files.srdf):
            if path is not None and not path.is_file():
                raise RobotDataError(f"missing robot file {path}")
        return files


def _frozen(values: Any) -> np.ndarray:
    array = np.array(values, dtype=float)
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class RobotDescription:
    """A robot's numbers, frozen and free of pinocchio: what planners, costs and optimizers take.

    Arrays are read-only. Positions are in the base frame with the robot in its nominal stance.
    """

    name: str
    joint_names: tuple[str, ...]  #: (12,) pinocchio order, legs in LEG_NAMES order
    foot_frames: tuple[str, ...]  #: (4,)
    mass_kg: float
    inertia_com_standing: np.ndarray  #: (3, 3) composite rotational inertia about the CoM, kg m^2
    com_base_standing: np.ndarray  #: (3,) CoM in the base frame
    hip_pos_base: np.ndarray  #: (4, 3) hip flexion joints in the base frame
    foot_nominal_base: np.ndarray  #: (4, 3) foot-ball centres in the nominal stance (candidate grid centres)
    q_standing: np.ndarray  #: (19,) standing configuration, base over the origin, feet touching z = 0
    foot_radius_m: float
    torque_limit_nm: np.ndarray  #: (12,)
    velocity_limit_rad_s: np.ndarray  #: (12,)
    leg_reach_m: float  #: hip-to-foot-centre distance of a straight leg (thigh + shank)
    size_scale: float  #: the robot's size against the paper's Solo12: what its gaits are scaled by
    fz_max_n: float
    kin_threshold_m: float
    fall_base_height_m: float
    controller_gains: tuple[tuple[str, Any], ...] = ()
    leg_names: tuple[str, ...] = LEG_NAMES
    knee_pos_base: np.ndarray | None = None  #: (4, 3) knee joints in the nominal stance (None: not known)
    walk_crouch_m: float = 0.0  #: the walk's crouch on terrain of one level by default (RobotSpec.walk_crouch_m)
    trot_crouch_m: float = 0.0  #: the trot's (RobotSpec.trot_crouch_m)
    brace_outward_m: float = 0.0  #: bracing's landing beyond a foot on the push's side (RobotSpec.brace_outward_m)
    #: (4, 3) the feet of the stance before ``RobotSpec.stance_abduction_rad`` turned them out (base frame, with
    #: the hips where the widened stance has them): each leg's upright position, the vertical plane its leg leans
    #: from; None: ``foot_nominal_base``.
    foot_upright_base: np.ndarray | None = None

    @property
    def base_height_standing_m(self) -> float:
        """Base-origin height above the ground in the nominal stance (feet touching)."""
        return float(self.q_standing[2])

    @property
    def com_height_nominal_m(self) -> float:
        """CoM height above the ground in the nominal stance."""
        return float(self.q_standing[2] + self.com_base_standing[2])

    @property
    def max_crouch_m(self) -> float:
        """The deepest crouch a walk may take (``LocomotionConfig.crouch_m``): a third of the nominal CoM height."""
        return self.com_height_nominal_m / 3.0

    def check_crouch(self, crouch_m: float) -> None:
        """ValueError (one line) unless ``crouch_m`` is a number from 0 to ``max_crouch_m``."""
        if not (isinstance(crouch_m, int | float) and math.isfinite(crouch_m) and crouch_m >= 0.0):
            raise ValueError(f"crouch must be a finite number >= 0 (m), got {crouch_m!r}")
        if crouch_m > self.max_crouch_m:
            raise ValueError(f"crouch {crouch_m:g} m is more than a third of {self.name}'s nominal CoM height "
                             f"({self.com_height_nominal_m:.3f} m)")

    def default_crouch_m(self, gait_name: str, heights: bool) -> float:
        """The crouch ``LocomotionConfig(crouch_m=None)`` takes: ``walk_crouch_m`` for the walk and ``trot_crouch_m``
        for the trot on terrain of one level (``heights`` False), else 0 (every other gait; and on terrain with
        heights, where a lower body brings the legs nearer the tops)."""
        if heights:
            return 0.0
        return {"walk": self.walk_crouch_m, "trot": self.trot_crouch_m}.get(gait_name, 0.0)

    @property
    def joint_standing(self) -> np.ndarray:
        """(12,) joint angles of the nominal stance, rad."""
        return self.q_standing[7:]

    @property
    def hip_offsets_com(self) -> np.ndarray:
        """(4, 3) hips relative to the CoM in the nominal stance (base frame)."""
        return self.hip_pos_base - self.com_base_standing

    @property
    def weight_n(self) -> float:
        return self.mass_kg * 9.81


def standing_joint_positions(srdf: Path, joint_names: tuple[str, ...], pose: str) -> np.ndarray:
    """The joint angles (rad, ``joint_names`` order) of a named SRDF group state."""
    root = ET.parse(srdf).getroot()
    for state in root.iter("group_state"):
        if state.get("name") == pose:
            values = {j.get("name"): j.get("value", "") for j in state.iter("joint")}
            missing = [name for name in joint_names if name not in values]
            if missing:
                raise RobotDataError(f"{srdf}: group_state {pose!r} lacks {missing}")
            return np.array([float(values[name]) for name in joint_names])
    raise RobotDataError(f"{srdf}: no group_state named {pose!r}")


class Robot:
    """A loaded robot: its frozen `description`, its pinocchio model, and kinematics queries.

    Build it once with `Robot.load(spec)` (or `contactnet.robots.load_robot(name)`) and pass it around;
    it holds a pinocchio Data for its own queries, so give each thread its own instance.
    """

    def __init__(self, spec: RobotSpec, files: RobotFiles, model: Any, description: RobotDescription,
                 cache_dir: Path | None = None) -> None:
        self.spec = spec
        self.files = files
        self.model = model
        self.description = description
        self.cache_dir = cache_dir
        self.data = model.createData()
        import pinocchio as pin

        self._pin = pin
        self._foot_ids = [model.getFrameId(f) for f in spec.foot_frames]
        self._one_level: dict[bool, Robot] = {}  # for_terrain's twins (by: the stance widened), built on first use
        self._heights: Robot | None = None  # ... and its twin on terrain with heights

    def for_terrain(self, terrain: Terrain, gait: str | None = None) -> Robot:
        """The robot that walks ``terrain`` with ``gait`` (a gait's name): this one, or its twin. On terrain of one
        level (``Terrain.has_heights`` False) the twin's stance is ``spec.one_level_stance_abduction_rad`` wider when
        ``spec.one_level_stance_gaits`` is None or names ``gait``, and ``spec.one_level_controller_gains`` lie over its
        controller gains; on terrain with heights ``spec.heights_controller_gains`` do (each twin built once, then
        kept; the same name, model files and URDF; a twin is its own robot on every terrain). Build the gait, the
        planner and `contactnet.locomotion.Locomotion` with it. A robot whose spec has none of them is its own robot
        on every terrain; with ``gait`` None only a stance for every gait applies."""
        spec = self.spec
        if terrain.has_heights:
            if not spec.heights_controller_gains:
                return self
            if self._heights is None:
                self._heights = self._twin(replace(spec, controller_gains=spec.controller_gains
                                                   + spec.heights_controller_gains))
            return self._heights
        widen = bool(spec.one_level_stance_abduction_rad) and (spec.one_level_stance_gaits is None
                                                               or gait in spec.one_level_stance_gaits)
        if not widen and not spec.one_level_controller_gains:
            return self
        if widen not in self._one_level:
            twin = replace(spec, controller_gains=spec.controller_gains + spec.one_level_controller_gains)
            if widen:
                twin = replace(twin, stance_abduction_rad=spec.one_level_stance_abduction_rad)
            self._one_level[widen] = self._twin(twin)
        return self._one_level[widen]

    def _twin(self, spec: RobotSpec) -> Robot:
        """A twin of this robot for one kind of terrain: ``spec`` with the terrain-scoped fields cleared (so that the
        twin is its own robot on every terrain), the same model and files."""
        spec = replace(spec, one_level_stance_abduction_rad=0.0, one_level_stance_gaits=None,
                       one_level_controller_gains=(), heights_controller_gains=())
        return Robot(spec, self.files, self.model, describe(spec, self.files, self.model), self.cache_dir)

    @staticmethod
    def load(spec: RobotSpec, cache_dir: Path | None = None) -> Robot:
        import pinocchio as pin

        files = RobotFiles.locate(spec)
        model = pin.buildModelFromUrdf(str(files.urdf), pin.JointModelFreeFlyer())
        names = tuple(model.names)[2:]
        if names != spec.joint_names:
            raise RobotDataError(f"{files.urdf}: joint order {names}, expected {spec.joint_names}")
        for frame in (*spec.foot_frames, *spec.hip_frames):
            if not model.existFrame(frame):
                raise RobotDataError(f"{files.urdf}: no frame {frame}")
        return Robot(spec, files, model, describe(spec, files, model), cache_dir)

    # ---- the description's numbers, for callers that hold the robot --------------------------
    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def mass_kg(self) -> float:
        return self.description.mass_kg

    @property
    def q_standing(self) -> np.ndarray:
        return self.description.q_standing

    @property
    def joint_standing(self) -> np.ndarray:
        return self.description.joint_standing

    @property
    def base_height_standing_m(self) -> float:
        return self.description.base_height_standing_m

    @property
    def com_base_standing(self) -> np.ndarray:
        return self.description.com_base_standing

    @property
    def inertia_com_standing(self) -> np.ndarray:
        return self.description.inertia_com_standing

    @property
    def hip_pos_base(self) -> np.ndarray:
        return self.description.hip_pos_base

    @property
    def foot_nominal_base(self) -> np.ndarray:
        return self.description.foot_nominal_base

    # ---- kinematics ----------------------------------------------------------------------------
    def foot_positions_world(self, q: np.ndarray) -> np.ndarray:
        """(4, 3) foot-ball centres in the world for configuration q (19,)."""
        self._pin.framesForwardKinematics(self.model, self.data, np.asarray(q, dtype=float))
        return np.array([self.data.oMf[i].translation for i in self._foot_ids])

    def pybullet_urdf(self, sphere_feet: bool = True) -> Path:
        """Path of the URDF PyBullet loads (generated once into the cache: `contactnet.robots.sim_urdf`)."""
        return write_pybullet_urdf(self.spec, self.files, self.cache_dir, sphere_feet)


#: The largest ``RobotSpec.brace_outward_m`` and ``BraceConfig.outward_m`` (m): a foot bracing puts down within its
#: touchdown time moves no farther.
MAX_BRACE_OUTWARD_M = 0.15

#: The largest ``RobotSpec.stance_abduction_rad`` (rad): about 17 degrees.
MAX_STANCE_ABDUCTION_RAD = 0.3


def widened_stance(model: Any, q: np.ndarray, spec: RobotSpec) -> np.ndarray:
    """``q`` (pinocchio configuration, the base at the origin) with each leg's abduction joint turned
    ``spec.stance_abduction_rad`` outward: its foot away from the body's sagittal plane (the left legs, FL and HL, to
    +y). Which way a joint turns is read from the model (a small turn's effect on the foot), not assumed, so a robot
    whose abduction axes are mirrored widens the same way."""
    import pinocchio as pin

    angle = spec.stance_abduction_rad
    if not (math.isfinite(angle) and 0.0 <= angle <= MAX_STANCE_ABDUCTION_RAD):
        raise RobotDataError(f"{spec.name}: stance_abduction_rad must be from 0 to {MAX_STANCE_ABDUCTION_RAD} rad, "
                             f"got {angle!r}")
    data = model.createData()
    widened = np.array(q, dtype=float)
    for leg in range(4):
        index = model.joints[model.getJointId(spec.joint_names[3 * leg])].idx_q
        foot = model.getFrameId(spec.foot_frames[leg])
        outward = 1.0 if leg in (0, 2) else -1.0  # FL, HL on the left (+y)
        probe = widened.copy()
        probe[index] += 1e-3
        pin.framesForwardKinematics(model, data, widened)
        before_y = float(data.oMf[foot].translation[1])
        pin.framesForwardKinematics(model, data, probe)
        turn = 1.0 if (float(data.oMf[foot].translation[1]) - before_y) * outward > 0.0 else -1.0
        widened[index] += turn * angle
    return widened


def describe(spec: RobotSpec, files: RobotFiles, model: Any) -> RobotDescription:
    """Derive a robot's numbers from its pinocchio model, SRDF and spec."""
    import pinocchio as pin

    data = model.createData()
    q = pin.neutral(model)
    if files.srdf is not None:
        q[7:] = standing_joint_positions(files.srdf, spec.joint_names, spec.standing_pose)
    if spec.standing_leg_joints_rad is not None:
        q[7:] = np.tile(spec.standing_leg_joints_rad, 4)
    widen = spec.one_level_stance_abduction_rad  # used by Robot.for_terrain's twin: checked now, as the spec is read
    if not (math.isfinite(widen) and 0.0 <= widen <= MAX_STANCE_ABDUCTION_RAD):
        raise RobotDataError(f"{spec.name}: one_level_stance_abduction_rad must be from 0 to "
                             f"{MAX_STANCE_ABDUCTION_RAD} rad, got {widen!r}")
    outward = spec.brace_outward_m
    if not (math.isfinite(outward) and 0.0 <= outward <= MAX_BRACE_OUTWARD_M):
        raise RobotDataError(f"{spec.name}: brace_outward_m must be from 0 to {MAX_BRACE_OUTWARD_M} m, got {outward!r}")
    gaits = spec.one_level_stance_gaits
    if gaits is not None and not (isinstance(gaits, tuple) and all(isinstance(g, str) and g for g in gaits)):
        raise RobotDataError(f"{spec.name}: one_level_stance_gaits must be None (every gait) or gait names, "
                             f"got {gaits!r}")
    upright = q.copy()  # the stance before it is widened (the base at the origin): each leg's vertical plane
    if spec.stance_abduction_rad:
        q = widened_stance(model, q, spec)

    def frames(q_: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
        pin.framesForwardKinematics(model, data, q_)
        return np.array([data.oMf[model.getFrameId(n)].translation for n in names])

    # Put the base so that the lowest foot ball touches z = 0 (the SRDF's base pose is not used).
    q[:7] = [0, 0, 0, 0, 0, 0, 1]
    at_origin = q.copy()
    feet_base = frames(at_origin, spec.foot_frames)
    upright_feet_base = frames(upright, spec.foot_frames) if spec.stance_abduction_rad else feet_base
    hips_base = frames(at_origin, spec.hip_frames)
    knees_base = frames(at_origin, spec.joint_names[2::3])
    com_base = np.asarray(pin.centerOfMass(model, data, at_origin)).copy()
    q[2] = -feet_base[:, 2].min() + spec.foot_radius_m
    pin.ccrba(model, data, q, np.zeros(model.nv))
    inertia = np.asarray(data.Ig.inertia).copy()
    # Reach of a straight leg: hip flexion joint -> knee -> foot centre, for the first leg.
    knee = model.getJointId(spec.joint_names[2])
    hip = model.getJointId(spec.joint_names[1])
    foot_frame = model.frames[model.getFrameId(spec.foot_frames[0])]
    shank = foot_frame.placement.translation if foot_frame.parentJoint == knee else np.zeros(3)
    reach = float(np.linalg.norm(model.jointPlacements[knee].translation) + np.linalg.norm(shank))
    del hip
    torque = (np.full(12, spec.torque_limit_nm) if spec.torque_limit_nm is not None
              else np.asarray(model.effortLimit[6:], dtype=float))
    return RobotDescription(
        name=spec.name,
        joint_names=spec.joint_names,
        foot_frames=spec.foot_frames,
        mass_kg=float(pin.computeTotalMass(model)),
        inertia_com_standing=_frozen(inertia),
        com_base_standing=_frozen(com_base),
        hip_pos_base=_frozen(hips_base),
        foot_nominal_base=_frozen(feet_base),
        q_standing=_frozen(q),
        foot_radius_m=float(spec.foot_radius_m),
        torque_limit_nm=_frozen(torque),
        velocity_limit_rad_s=_frozen(model.velocityLimit[6:]),
        leg_reach_m=reach,
        size_scale=float(spec.size_scale) if spec.size_scale is not None else round(reach / REFERENCE_LEG_M, 3),
        fz_max_n=float(spec.fz_max_n),
        kin_threshold_m=float(spec.kin_threshold_m),
        fall_base_height_m=float(spec.fall_base_height_m),
        controller_gains=spec.controller_gains,
        knee_pos_base=_frozen(knees_base),
        walk_crouch_m=float(spec.walk_crouch_m),
        trot_crouch_m=float(spec.trot_crouch_m),
        brace_outward_m=float(spec.brace_outward_m),
        foot_upright_base=_frozen(upright_feet_base),
    )
