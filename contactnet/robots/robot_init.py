"""`contactnet robot init SOURCE --out FILE.toml`: draft a robot file from a URDF (+ SRDF).

SOURCE is a folder of example-robot-data (``a1_description``) or a URDF file (its SRDF with ``--srdf``, or found
beside it in a ROS-style ``srdf/`` folder). What is found, and how:

- **Legs**: the kinematic tree's chains of three revolute joints from the root to a leaf link (the foot); four are
  needed. Each leg is placed by where its first joint sits in the base frame (front: x > 0, left: y > 0).
- **Names**: each leg's joints and foot must read ``PREFIX_SUFFIX`` with one prefix per leg and the same suffixes
  on every leg (what a `RobotSpec` can name); the joints must come in the order front-left, front-right, hind-left,
  hind-right in the URDF's tree, as the controller reads them.
- **The stance**: the SRDF's ``standing`` group_state (else its first); without an SRDF, or when that stance does not
  put the feet under the hips, one (abduction, hip flexion, knee) for every leg found by a search over the joints'
  range: the foot under the hip, the hip-to-foot distance 70 % of the leg's length.
- **The numbers**: the foot radius from the foot link's collision sphere (else half the smallest extent of its
  mesh or box); the force cap at the robot's weight, the kinematic threshold and the fall height scaled by the leg's
  length from Solo12's (0.12 m and 0.10 m for a 0.32 m leg), as Go2's were.

Every guess it had to make is one line of ``problems`` (a link without inertia, a missing limit, a stance it
computed); ``contactnet robot check FILE.toml`` then says whether the robot is ready.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from contactnet.robots.description import LEG_NAMES, RobotDataError
from contactnet.robots.sim_urdf import links_without_inertia

#: Solo12's numbers per metre of leg (0.32 m): the rule that sizes a drafted robot's thresholds.
KIN_THRESHOLD_PER_LEG = 0.12 / 0.32
FALL_HEIGHT_PER_LEG = 0.10 / 0.32
#: The drafted stance's hip-to-foot distance as a fraction of the leg's length.
STANCE_EXTENSION = 0.7


@dataclass(frozen=True)
class Draft:
    """A drafted robot file: its values (``robot_file.to_toml``) and the lines saying what was guessed."""

    values: dict[str, Any]
    problems: tuple[str, ...]


def locate_source(source: str, srdf: str | None = None) -> tuple[Path, Path | None, str, str, str | None]:
    """(urdf, srdf or None, the robot file's description_dir, urdf and srdf inside it) of a SOURCE."""
    path = Path(source).expanduser()
    if path.suffix == ".urdf":
        if not path.is_file():
            raise RobotDataError(f"{source}: no such URDF file")
        urdf = path.resolve()
        folder = urdf.parent.parent if urdf.parent.name == "urdf" else urdf.parent
        srdf_path = Path(srdf).resolve() if srdf else next(iter(sorted((folder / "srdf").glob("*.srdf"))), None)
        inside = lambda p: str(p.relative_to(folder)) if p is not None and p.is_relative_to(folder) else (  # noqa: E731
            str(p) if p is not None else None)
        return urdf, srdf_path, str(folder), inside(urdf), inside(srdf_path)
    from importlib import metadata

    dist = metadata.distribution("example-robot-data")
    marker = f"example-robot-data/robots/{source}/"
    found = sorted(str(f) for f in dist.files or () if marker in str(f))
    urdfs = [f for f in found if f.endswith(".urdf")]
    if not urdfs:
        raise RobotDataError(f"{source}: neither a URDF file nor a folder of example-robot-data with a URDF")
    stem = source.removesuffix("_description")
    chosen = next((f for f in urdfs if Path(f).stem == stem), urdfs[0])
    srdfs = [f for f in found if f.endswith(".srdf")]
    chosen_srdf = next((f for f in srdfs if Path(f).stem == Path(chosen).stem), srdfs[0] if srdfs else None)
    rel = lambda f: f.split(marker, 1)[1]  # noqa: E731
    return (Path(dist.locate_file(chosen)), None if chosen_srdf is None else Path(dist.locate_file(chosen_srdf)),
            source, rel(chosen), None if chosen_srdf is None else rel(chosen_srdf))


def draft(source: str, srdf: str | None = None, name: str | None = None) -> Draft:
    """Draft a robot file from SOURCE (see the module's docstring); a robot it cannot describe raises one line."""
    import pinocchio as pin

    urdf, srdf_path, description_dir, urdf_rel, srdf_rel = locate_source(source, srdf)
    problems: list[str] = []
    root = ET.parse(urdf).getroot()
    model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    try:
        legs = _legs(model, root)
    except RobotDataError as exc:
        raise RobotDataError(f"{urdf.name}: {exc}") from None
    prefixes, suffixes, foot_suffix = _names(legs, urdf)
    order = [j for leg in legs for j in leg["joints"]]
    if tuple(model.names)[2:] != tuple(order):
        raise RobotDataError(f"{urdf}: its joints come in the order {tuple(model.names)[2:]}, not leg by leg as front-"
                             "left, front-right, hind-left, hind-right: contactnet reads the joints in that order")
    missing = links_without_inertia(root)
    if missing:
        problems.append(f"links without <inertial> ({', '.join(missing)}): simulated with 1 mg, as pinocchio gives "
                        "them none")
    effort = np.asarray(model.effortLimit[6:], dtype=float)
    torque_limit = None
    if not np.all(effort > 0):
        torque_limit = 20.0
        problems.append(f"joints without an effort limit in the URDF: torque_limit_nm = {torque_limit} for every "
                        "joint is a guess: set the motors' peak torque")
    if not np.all(np.asarray(model.velocityLimit[6:]) > 0):
        problems.append("joints without a velocity limit in the URDF (not used by the controller)")
    foot_radius, how = _foot_radius(root, legs[0]["foot_link"], urdf)
    if how:
        problems.append(how)
    leg_length = _leg_length(model, legs[0])
    values: dict[str, Any] = {
        "name": name or Path(urdf).stem.replace("-", "_"),
        "description": f"drafted by contactnet robot init from {urdf.name}",
        "description_dir": description_dir, "urdf": urdf_rel,
    }
    if srdf_rel is not None:
        states = [s.get("name") for s in ET.parse(srdf_path).getroot().iter("group_state")]
        pose = "standing" if "standing" in states else (states[0] if states else None)
        if pose is None:
            problems.append(f"{srdf_path.name} has no group_state: the stance is computed")
        else:
            values.update(srdf=srdf_rel, standing_pose=pose)
    else:
        problems.append("no SRDF: the stance is computed")
    values.update(leg_prefixes=prefixes, joint_suffixes=suffixes, foot_suffix=foot_suffix,
                  foot_radius_m=round(foot_radius, 4), fz_max_n=round(float(pin.computeTotalMass(model)) * 9.81, 1),
                  kin_threshold_m=round(KIN_THRESHOLD_PER_LEG * leg_length, 3),
                  fall_base_height_m=round(FALL_HEIGHT_PER_LEG * leg_length, 3))
    if torque_limit is not None:
        values["torque_limit_nm"] = torque_limit
    stance_ok = "standing_pose" in values and _feet_under_hips(model, legs, srdf_path, values["standing_pose"],
                                                               order, leg_length)
    if not stance_ok:
        joints = _stance_search(model, legs, leg_length)
        if joints is None:
            problems.append("no stance with the feet under the hips was found for one set of angles on every leg: "
                            "set standing_leg_joints_rad (or give an SRDF with a standing pose)")
        else:
            values["standing_leg_joints_rad"] = [round(float(a), 3) for a in joints]
            if "standing_pose" in values:
                problems.append(f"the SRDF's {values['standing_pose']!r} does not put the feet under the hips: "
                                f"standing_leg_joints_rad = {values['standing_leg_joints_rad']} instead")
            else:
                problems.append(f"computed standing_leg_joints_rad = {values['standing_leg_joints_rad']}")
    if "standing_pose" not in values and "standing_leg_joints_rad" not in values:
        raise RobotDataError(f"{urdf}: no stance (no SRDF pose, none found): " + problems[-1])
    values["feet"] = "sphere"
    return Draft(values, tuple(problems))


def _legs(model, root: ET.Element) -> list[dict]:  # noqa: ANN001 - a pinocchio Model
    """The four legs (FL, FR, HL, HR): their three joints (from the base) and their foot link."""
    children: dict[str, list[tuple[str, str, str]]] = {}
    for joint in root.iter("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is not None and child is not None:
            children.setdefault(parent.get("link"), []).append((joint.get("name"), joint.get("type"), child.get("link")))
    names = {link.get("name") for link in root.iter("link")}
    base = next(iter(names - {c for kids in children.values() for _, _, c in kids}))
    chains = []

    def walk(link: str, joints: list[str]) -> None:
        moving = [(j, t, c) for j, t, c in children.get(link, []) if t in ("revolute", "continuous")]
        if len(joints) == 3 and not moving:
            chains.append((list(joints), _foot_link(link, children)))
            return
        for joint, kind, child in children.get(link, []):
            walk(child, joints + [joint] if kind in ("revolute", "continuous") else joints)

    walk(base, [])
    chains = [c for c in chains if len(c[0]) == 3]
    if len(chains) != 4:
        raise RobotDataError(f"found {len(chains)} chains of three revolute joints from {base!r} to a foot, not the "
                             "four legs of a 12-joint quadruped")
    import pinocchio as pin

    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    legs = []
    for joints, foot in chains:
        hip_xy = data.oMi[model.getJointId(joints[0])].translation[:2]
        legs.append({"joints": joints, "foot_link": foot, "front": hip_xy[0] > 0, "left": hip_xy[1] > 0})
    by_place = {(leg["front"], leg["left"]): leg for leg in legs}
    if len(by_place) != 4:
        raise RobotDataError("the four legs' hips are not one at each corner of the base (front/hind, left/right)")
    return [by_place[(True, True)], by_place[(True, False)], by_place[(False, True)], by_place[(False, False)]]


def _foot_link(link: str, children: dict) -> str:
    """The leg's foot: the last link below ``link`` through fixed joints (or ``link`` itself)."""
    fixed = [c for _, t, c in children.get(link, []) if t == "fixed"]
    return _foot_link(fixed[0], children) if len(fixed) == 1 else link


def _names(legs: list[dict], urdf: Path) -> tuple[list[str], list[str], str]:
    prefixes, suffix_sets = [], []
    for leg, canonical in zip(legs, LEG_NAMES, strict=True):
        names = [*leg["joints"], leg["foot_link"]]
        if not all("_" in n for n in names):
            raise RobotDataError(f"{urdf}: the {canonical} leg's names {names} are not PREFIX_SUFFIX")
        prefix = names[0].split("_", 1)[0]
        if not all(n.startswith(prefix + "_") for n in names):
            raise RobotDataError(f"{urdf}: the {canonical} leg's names {names} do not share a prefix")
        prefixes.append(prefix)
        suffix_sets.append(tuple(n[len(prefix) + 1:] for n in names))
    if len(set(suffix_sets)) != 1:
        raise RobotDataError(f"{urdf}: the legs' joints and feet are not named alike ({sorted(set(suffix_sets))})")
    suffixes = list(suffix_sets[0])
    return prefixes, suffixes[:3], suffixes[3]


def _foot_radius(root: ET.Element, foot_link: str, urdf: Path) -> tuple[float, str]:
    """The foot ball's radius and, when guessed, a line saying how."""
    link = next(link for link in root.iter("link") if link.get("name") == foot_link)
    for geometry in link.iter("geometry"):
        sphere = geometry.find("sphere")
        if sphere is not None:
            return float(sphere.get("radius")), ""
        box = geometry.find("box")
        if box is not None:
            size = [float(v) for v in box.get("size").split()]
            return min(size) / 2, f"foot_radius_m = {min(size) / 2:.4f}: half the smallest side of the foot's box"
        mesh = geometry.find("mesh")
        if mesh is not None:
            import trimesh

            filename = mesh.get("filename", "")
            path = Path(filename[len("package://"):]) if filename.startswith("package://") else urdf.parent / filename
            candidates = [urdf.parents[i] / path for i in range(min(4, len(urdf.parents)))] if filename.startswith(
                "package://") else [path]
            for candidate in candidates:
                if candidate.is_file():
                    extents = trimesh.load(candidate, force="mesh").extents
                    radius = float(min(extents) / 2)
                    return radius, f"foot_radius_m = {radius:.4f}: half the smallest extent of the foot's mesh"
    return 0.02, "foot_radius_m = 0.02: the foot has no collision shape to read it from (a guess)"


def _leg_length(model, leg: dict) -> float:  # noqa: ANN001
    """Hip flexion joint to knee, plus knee to the foot (the straight leg's reach)."""
    import pinocchio as pin

    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    hip = data.oMi[model.getJointId(leg["joints"][1])].translation
    knee = data.oMi[model.getJointId(leg["joints"][2])].translation
    foot = data.oMf[model.getFrameId(leg["foot_link"])].translation
    return float(np.linalg.norm(knee - hip) + np.linalg.norm(foot - knee))


def _foot_offsets(model, legs: list[dict], q: np.ndarray) -> np.ndarray:  # noqa: ANN001
    """Per leg: (foot x - hip x, hip-to-foot distance) at configuration q."""
    import pinocchio as pin

    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    out = []
    for leg in legs:
        hip = data.oMi[model.getJointId(leg["joints"][1])].translation
        foot = data.oMf[model.getFrameId(leg["foot_link"])].translation
        out.append((foot[0] - hip[0], np.linalg.norm(foot - hip), hip[2] - foot[2]))
    return np.array(out)


def _feet_under_hips(model, legs, srdf: Path, pose: str, order: list[str], leg_length: float) -> bool:  # noqa: ANN001
    import pinocchio as pin

    from contactnet.robots.description import standing_joint_positions

    q = pin.neutral(model)
    q[7:] = standing_joint_positions(srdf, tuple(order), pose)
    offsets = _foot_offsets(model, legs, q)
    return bool(np.all(np.abs(offsets[:, 0]) <= 0.1 * leg_length) and np.all(offsets[:, 2] > 0.5 * leg_length))


def _stance_search(model, legs: list[dict], leg_length: float) -> np.ndarray | None:  # noqa: ANN001
    """One (0, hip flexion, knee) for every leg: feet under the hips at `STANCE_EXTENSION` of the leg, within the
    joints' limits; None if no grid point puts every foot within 10 % of the leg under its hip."""
    import pinocchio as pin

    lower, upper = np.asarray(model.lowerPositionLimit[7:]), np.asarray(model.upperPositionLimit[7:])
    finite = lambda lo, hi, k: (lo[k], hi[k]) if np.isfinite(lo[k]) and np.isfinite(hi[k]) and hi[k] > lo[k] else (  # noqa: E731
        -np.pi, np.pi)
    flex_range, knee_range = finite(lower, upper, 1), finite(lower, upper, 2)
    best, best_cost = None, np.inf
    for flex in np.linspace(*flex_range, 61):
        for knee in np.linspace(*knee_range, 61):
            joints = np.array([0.0, flex, knee])
            if np.any(np.tile(joints, 4) < lower - 1e-9) or np.any(np.tile(joints, 4) > upper + 1e-9):
                continue
            q = pin.neutral(model)
            q[7:] = np.tile(joints, 4)
            offsets = _foot_offsets(model, legs, q)
            if np.any(offsets[:, 2] <= 0):  # a foot above its hip
                continue
            cost = np.abs(offsets[:, 0]).max() + np.abs(offsets[:, 1] / leg_length - STANCE_EXTENSION).max() * leg_length
            if cost < best_cost:
                best, best_cost, worst_x = joints, cost, np.abs(offsets[:, 0]).max()
    if best is None or worst_x > 0.1 * leg_length:
        return None
    return best


__all__ = ["Draft", "draft", "locate_source"]
