"""Solo12: the robot model (pinocchio), its nominal numbers, and the URDF variant PyBullet simulates.

The URDF comes from the `example-robot-data` wheel, a data-only package: nothing to import, the
files lie under its cmeel prefix. We find them through the installed distribution's file list,
never through a hard-coded site-packages path.

Conventions used across contactnet:
- legs are ordered FL, FR, HL, HR (index 0..3), joints per leg HAA, HFE, KFE (pinocchio order);
- `q` is pinocchio's configuration (19: base xyz, base quaternion xyzw, 12 joints), `v` its
  velocity (18: base linear and angular velocity in the base frame, 12 joint velocities);
- arrays say their frame in their name: `_world`, `_base` (base link frame), `_com` (CoM frame:
  origin at the CoM, axes aligned with the world but rotated by the base yaw).
"""

from __future__ import annotations

import hashlib
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from functools import cached_property
from importlib import metadata
from pathlib import Path

import numpy as np

LEG_NAMES: tuple[str, ...] = ("FL", "FR", "HL", "HR")
JOINT_KINDS: tuple[str, ...] = ("HAA", "HFE", "KFE")
JOINT_NAMES: tuple[str, ...] = tuple(f"{leg}_{kind}" for leg in LEG_NAMES for kind in JOINT_KINDS)
FOOT_FRAMES: tuple[str, ...] = tuple(f"{leg}_FOOT" for leg in LEG_NAMES)

#: Peak torque of a Solo12 actuator (0.025 N m/A x gear 9 x 12 A), in N m.
TORQUE_LIMIT_NM = 2.7
#: Radius of the foot ball (the foot mesh spans +-0.016 m), in m.
FOOT_RADIUS_M = 0.016
#: The SRDF pose used as the nominal stance.
STANDING_POSE = "straight_standing"


class RobotDataError(RuntimeError):
    """The robot description files are missing or unreadable (a broken installation)."""


@dataclass(frozen=True)
class RobotFiles:
    """Where the Solo12 description lives inside the installed example-robot-data wheel."""

    urdf: Path
    srdf: Path
    package_root: Path  # the folder that `package://example-robot-data/...` resolves against

    @staticmethod
    def locate() -> RobotFiles:
        try:
            dist = metadata.distribution("example-robot-data")
        except metadata.PackageNotFoundError as exc:
            raise RobotDataError(
                "the 'example-robot-data' package is not installed (pip install example-robot-data)"
            ) from exc
        suffix = "example-robot-data/robots/solo_description/robots/solo12.urdf"
        for file in dist.files or ():
            if str(file).endswith(suffix):
                urdf = Path(dist.locate_file(file)).resolve()
                break
        else:
            raise RobotDataError(f"example-robot-data {dist.version} does not ship {suffix}")
        description = urdf.parent.parent
        files = RobotFiles(
            urdf=urdf,
            srdf=description / "srdf" / "solo.srdf",
            package_root=description.parent.parent.parent,
        )
        for path in (files.urdf, files.srdf):
            if not path.is_file():
                raise RobotDataError(f"missing robot file {path}")
        return files


def standing_joint_positions(srdf: Path, pose: str = STANDING_POSE) -> np.ndarray:
    """The 12 joint angles (rad, pinocchio order) of a named SRDF group state."""
    root = ET.parse(srdf).getroot()
    for state in root.iter("group_state"):
        if state.get("name") == pose:
            values = {j.get("name"): j.get("value", "") for j in state.iter("joint")}
            return np.array([float(values[name]) for name in JOINT_NAMES])
    raise RobotDataError(f"{srdf}: no group_state named {pose!r}")


def default_cache_dir() -> Path:
    """Per-user cache for generated files ($CONTACTNET_CACHE, else $XDG_CACHE_HOME/contactnet)."""
    env = os.environ.get("CONTACTNET_CACHE")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "contactnet"


def write_pybullet_urdf(files: RobotFiles, cache_dir: Path | None = None, sphere_feet: bool = True) -> Path:
    """Write (once) the URDF variant PyBullet simulates, and return its path.

    Changes against the shipped URDF:
    - mesh paths are absolute (a copy elsewhere cannot resolve `package://`);
    - with `sphere_feet` (the default): each foot collides as a sphere of the foot's radius (the
      mesh foot simulates about half as fast), and each lower leg as a thin cylinder that stops
      above the foot ball, so a contact of the lower leg means the shin touched something.
    The file name carries a hash of the source and of this function's choices, so a new
    example-robot-data version or a change here makes a new file; writes are atomic.
    """
    source = files.urdf.read_bytes()
    recipe = b"sphere-feet-v1" if sphere_feet else b"mesh-feet-v1"
    digest = hashlib.sha256(source + recipe).hexdigest()[:12]
    out_dir = (cache_dir or default_cache_dir()) / "urdf"
    kind = "spherefeet" if sphere_feet else "meshfeet"
    out = out_dir / f"solo12_{kind}_{digest}.urdf"
    if out.is_file():
        return out

    root = ET.fromstring(source)
    for mesh in root.iter("mesh"):
        filename = mesh.get("filename", "")
        if filename.startswith("package://"):
            mesh.set("filename", str(files.package_root / filename[len("package://"):]))
    for link in root.iter("link"):
        name = link.get("name", "")
        collision = link.find("collision")
        if collision is None or not sphere_feet:
            continue
        if name.endswith("_FOOT"):
            _set_collision(collision, ET.Element("sphere", radius=f"{FOOT_RADIUS_M}"), xyz="0 0 0")
        elif name.endswith("_LOWER_LEG"):
            side_y = 0.008 if name[1] == "L" else -0.008
            cylinder = ET.Element("cylinder", radius="0.011", length="0.125")
            _set_collision(collision, cylinder, xyz=f"0 {side_y} -0.0725")

    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(f".tmp{os.getpid()}")
    ET.ElementTree(root).write(tmp, xml_declaration=True, encoding="utf-8")
    os.replace(tmp, out)
    return out


def _set_collision(collision: ET.Element, shape: ET.Element, xyz: str) -> None:
    origin = collision.find("origin")
    if origin is None:
        origin = ET.SubElement(collision, "origin")
    origin.set("xyz", xyz)
    origin.set("rpy", "0 0 0")
    geometry = collision.find("geometry")
    for child in list(geometry):
        geometry.remove(child)
    geometry.append(shape)


@dataclass
class Solo12:
    """Solo12's pinocchio model and the nominal numbers the planner and controllers need.

    Build it once with `Solo12.load()` and pass it around; it holds a pinocchio Data for its own
    kinematics queries, so give each thread its own instance.
    """

    files: RobotFiles
    model: object  # pinocchio.Model (free-flyer root)
    q_standing: np.ndarray  # (19,) standing configuration, base at the origin, feet on z = 0
    cache_dir: Path | None = None
    data: object = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.data = self.model.createData()

    @staticmethod
    def load(cache_dir: Path | None = None) -> Solo12:
        import pinocchio as pin

        files = RobotFiles.locate()
        model = pin.buildModelFromUrdf(str(files.urdf), pin.JointModelFreeFlyer())
        names = tuple(model.names)[2:]
        if names != JOINT_NAMES:
            raise RobotDataError(f"{files.urdf}: unexpected joint order {names}")
        for frame in FOOT_FRAMES:
            if not model.existFrame(frame):
                raise RobotDataError(f"{files.urdf}: no frame {frame}")
        q = pin.neutral(model)
        q[7:] = standing_joint_positions(files.srdf)
        # Put the base so that the lowest point of the feet touches z = 0.
        data = model.createData()
        pin.framesForwardKinematics(model, data, q)
        foot_z = min(data.oMf[model.getFrameId(f)].translation[2] for f in FOOT_FRAMES)
        q[2] = -foot_z + FOOT_RADIUS_M
        return Solo12(files=files, model=model, q_standing=q, cache_dir=cache_dir)

    # ---- nominal numbers -------------------------------------------------------------------
    @cached_property
    def mass_kg(self) -> float:
        import pinocchio as pin

        return float(pin.computeTotalMass(self.model))

    @cached_property
    def joint_standing(self) -> np.ndarray:
        """(12,) joint angles of the nominal stance, rad."""
        return self.q_standing[7:].copy()

    @cached_property
    def base_height_standing_m(self) -> float:
        """Base-origin height above the ground in the nominal stance (feet touching)."""
        return float(self.q_standing[2])

    @cached_property
    def com_base_standing(self) -> np.ndarray:
        """(3,) CoM in the base frame in the nominal stance."""
        import pinocchio as pin

        q = self.q_standing.copy()
        q[:3] = 0.0
        return np.asarray(pin.centerOfMass(self.model, self.data, q)).copy()

    @cached_property
    def inertia_com_standing(self) -> np.ndarray:
        """(3, 3) composite rotational inertia about the CoM in the nominal stance, kg m^2.

        This is the single-rigid-body inertia of the trajectory optimizer (axes of the base frame).
        """
        import pinocchio as pin

        pin.ccrba(self.model, self.data, self.q_standing, np.zeros(self.model.nv))
        return np.asarray(self.data.Ig.inertia).copy()

    @cached_property
    def hip_pos_base(self) -> np.ndarray:
        """(4, 3) positions of the HFE joints (the hips) in the base frame."""
        import pinocchio as pin

        q = self.q_standing.copy()
        q[:7] = [0, 0, 0, 0, 0, 0, 1]
        pin.framesForwardKinematics(self.model, self.data, q)
        return np.array([self.data.oMf[self.model.getFrameId(f"{leg}_HFE")].translation for leg in LEG_NAMES])

    @cached_property
    def foot_nominal_base(self) -> np.ndarray:
        """(4, 3) foot-ball centres in the base frame in the nominal stance.

        Their XY is the centre of each leg's candidate foothold grid (the paper's fixed offsets
        "from the current hip position": under the hip, at the leg's natural lateral offset).
        """
        q = self.q_standing.copy()
        q[:7] = [0, 0, 0, 0, 0, 0, 1]
        return self.foot_positions_world(q)

    # ---- kinematics ------------------------------------------------------------------------
    def foot_positions_world(self, q: np.ndarray) -> np.ndarray:
        """(4, 3) foot-ball centres in the world for configuration q (19,)."""
        import pinocchio as pin

        pin.framesForwardKinematics(self.model, self.data, np.asarray(q, dtype=float))
        return np.array([self.data.oMf[self.model.getFrameId(f)].translation for f in FOOT_FRAMES])

    def pybullet_urdf(self, sphere_feet: bool = True) -> Path:
        """Path of the URDF PyBullet loads (generated once into the cache); sphere feet by default."""
        return write_pybullet_urdf(self.files, self.cache_dir, sphere_feet)
