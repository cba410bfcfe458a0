"""A robot as a file: a `RobotSpec` written in TOML (``--robot FILE.toml`` on every command).

A robot file names where the robot's URDF (+ SRDF) lies and states what the files do not say; everything else is
read from them, as for the robots in modules::

    name = "a1"
    description = "Unitree A1"
    description_dir = "a1_description"     # a folder of example-robot-data, or a path (relative to this file)
    urdf = "urdf/a1.urdf"                  # inside description_dir
    srdf = "srdf/a1.srdf"                  # optional when standing_leg_joints_rad is given
    standing_pose = "standing"             # the SRDF's group_state of the stance
    leg_prefixes = ["FL", "FR", "RL", "RR"]            # the robot's names of front-left, front-right, hind-left, hind-right
    joint_suffixes = ["hip_joint", "thigh_joint", "calf_joint"]   # abduction, hip flexion, knee
    foot_suffix = "foot"
    foot_radius_m = 0.02
    fz_max_n = 120.0                       # the controller's cap on one foot's normal force
    kin_threshold_m = 0.15                 # the ranking cost's reach of a stance foot from its hip
    fall_base_height_m = 0.12
    # optional: torque_limit_nm (else the URDF's), standing_leg_joints_rad = [abduction, flexion, knee],
    # feet = "sphere" (default: each foot a ball of foot_radius_m in the simulators) or "mesh" (the URDF's),
    # size_scale = 1.3 (the gaits' size against the paper's Solo12; default: the leg's length over 0.3245 m),
    # walk_crouch_m = 0.02 (the walk's CoM reference this much lower on terrain of one level; default 0),
    # trot_crouch_m = 0.02 (the same for the trot; default 0),
    # stance_abduction_rad = 0.1 (each leg's abduction this much further out than the stance's: wider feet; default 0),
    # one_level_stance_abduction_rad = 0.1 (the same on terrain of one level only, instead; default 0),
    # one_level_stance_gaits = ["trot"] (the gaits that take it; default: every gait),
    # brace_outward_m = 0.05 (on terrain of one level, a foot bracing puts down on the push's side lands this much
    #   farther along the push; default 0),
    # [controller_gains] kp_swing = [900.0, 900.0, 900.0] ... (contactnet.motion.controller.ControllerGains),
    # [one_level_controller_gains] leg_gravity = 1.0 ... (the same, over them, on terrain of one level only)
    # [heights_controller_gains] fz_min_n = 0.98 ... (the same, over them, on terrain with heights only)

`contactnet robot init` drafts one from a description folder or a URDF; `contactnet robot check FILE.toml` says
whether it is ready (``docs/robots.md``). A file named on the command line is registered in this process and listed
in ``CONTACTNET_ROBOT_FILES`` so that worker processes register it too (``contactnet.plugins``).
"""

from __future__ import annotations

import os
import tomllib
import xml.etree.ElementTree as ET
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from contactnet.robots.description import (
    MAX_BRACE_OUTWARD_M,
    MAX_STANCE_ABDUCTION_RAD,
    RobotDataError,
    RobotSpec,
)

#: The environment variable listing robot files (os.pathsep-separated) that every process registers.
ROBOT_FILES_ENV = "CONTACTNET_ROBOT_FILES"

_REQUIRED = ("name", "description_dir", "urdf", "leg_prefixes", "joint_suffixes", "foot_suffix", "foot_radius_m",
             "fz_max_n", "kin_threshold_m", "fall_base_height_m")
_OPTIONAL = ("description", "srdf", "standing_pose", "torque_limit_nm", "standing_leg_joints_rad", "feet",
             "controller_gains", "size_scale", "walk_crouch_m", "trot_crouch_m", "stance_abduction_rad",
             "one_level_stance_abduction_rad", "one_level_stance_gaits", "one_level_controller_gains",
             "heights_controller_gains", "brace_outward_m")
#: The tables of ControllerGains fields: every terrain, then over them on terrain of one level, with heights.
_GAIN_TABLES = ("controller_gains", "one_level_controller_gains", "heights_controller_gains")
_POSITIVE = ("foot_radius_m", "fz_max_n", "kin_threshold_m", "fall_base_height_m", "torque_limit_nm", "size_scale")


@dataclass(frozen=True)
class SphereFeet:
    """The collision recipe of a robot file: each foot link a ball of ``radius_m``; the other links keep the URDF's."""

    radius_m: float
    foot_links: tuple[str, ...]

    def __call__(self, link_name: str) -> tuple[ET.Element, str] | None:
        if link_name in self.foot_links:
            return ET.Element("sphere", radius=f"{self.radius_m}"), "0 0 0"
        return None


def is_robot_file(text: str) -> bool:
    """Whether a ``--robot`` value names a robot file rather than a registered robot."""
    return text.endswith(".toml")


def load_robot_file(path: str | os.PathLike[str]) -> RobotSpec:
    """The `RobotSpec` a robot file states; a missing file, bad TOML or a bad field is one line naming it."""
    path = Path(path)
    try:
        values = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RobotDataError(f"robot file {path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise RobotDataError(f"robot file {path}: unreadable ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise RobotDataError(f"robot file {path}: not TOML ({exc})") from None
    return spec_from_values(values, path)


def spec_from_values(values: dict[str, Any], path: Path) -> RobotSpec:
    """A `RobotSpec` from a robot file's parsed ``values`` (``path`` for messages and relative folders)."""
    def bad(field: str, why: str) -> RobotDataError:
        return RobotDataError(f"robot file {path}: {field}: {why}")

    unknown = sorted(set(values) - set(_REQUIRED) - set(_OPTIONAL))
    if unknown:
        raise bad(unknown[0], f"unknown field (fields: {', '.join(_REQUIRED + _OPTIONAL)})")
    missing = [field for field in _REQUIRED if field not in values]
    if missing:
        raise bad(missing[0], "missing")
    for field in ("name", "description_dir", "urdf", "foot_suffix", "description", "srdf", "standing_pose"):
        if field in values and not (isinstance(values[field], str) and (values[field] or field in ("srdf",))):
            raise bad(field, f"expected a text, got {values[field]!r}")
    for field in ("leg_prefixes", "joint_suffixes"):
        wanted = 4 if field == "leg_prefixes" else 3
        value = values[field]
        if not (isinstance(value, list) and len(value) == wanted and all(isinstance(v, str) and v for v in value)):
            raise bad(field, f"expected {wanted} names, got {value!r}")
    for field in _POSITIVE:
        if field in values:
            value = values[field]
            if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < 1e6:
                raise bad(field, f"expected a positive number, got {value!r}")
    crouch = {name: values.get(name, 0.0) for name in ("walk_crouch_m", "trot_crouch_m")}
    for name, depth in crouch.items():
        if isinstance(depth, bool) or not isinstance(depth, int | float) or not 0.0 <= depth < 1.0:
            raise bad(name, f"expected a number from 0 to 1 (m), got {depth!r}")
    outward = values.get("brace_outward_m", 0.0)
    if isinstance(outward, bool) or not isinstance(outward, int | float) or not 0.0 <= outward <= MAX_BRACE_OUTWARD_M:
        raise bad("brace_outward_m", f"expected a number from 0 to {MAX_BRACE_OUTWARD_M} (m), got {outward!r}")
    widen, widen_one_level = values.get("stance_abduction_rad", 0.0), values.get("one_level_stance_abduction_rad", 0.0)
    for name, angle in (("stance_abduction_rad", widen), ("one_level_stance_abduction_rad", widen_one_level)):
        if isinstance(angle, bool) or not isinstance(angle, int | float) or not 0.0 <= angle <= MAX_STANCE_ABDUCTION_RAD:
            raise bad(name, f"expected a number from 0 to {MAX_STANCE_ABDUCTION_RAD} (rad), got {angle!r}")
    stance_gaits = values.get("one_level_stance_gaits")
    if stance_gaits is not None and not (isinstance(stance_gaits, list)
                                         and all(isinstance(g, str) and g for g in stance_gaits)):
        raise bad("one_level_stance_gaits", f"expected a list of gait names, got {stance_gaits!r}")
    stance = values.get("standing_leg_joints_rad")
    if stance is not None and not (isinstance(stance, list) and len(stance) == 3
                                   and all(isinstance(v, int | float) and not isinstance(v, bool) for v in stance)):
        raise bad("standing_leg_joints_rad", f"expected 3 angles (abduction, hip flexion, knee), got {stance!r}")
    if not values.get("srdf") and stance is None:
        raise bad("srdf", "missing: a stance needs the SRDF's pose or standing_leg_joints_rad")
    feet = values.get("feet", "sphere")
    if feet not in ("sphere", "mesh"):
        raise bad("feet", f"expected 'sphere' or 'mesh', got {feet!r}")
    tables = {}
    for table in _GAIN_TABLES:
        gains = tables[table] = values.get(table, {})
        if not isinstance(gains, dict):
            raise bad(table, "expected a table")
        for name, value in gains.items():  # the names are checked by the controller (ControllerGains.for_robot)
            numbers = value if isinstance(value, list) else [value]
            if not numbers or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in numbers):
                raise bad(f"{table}.{name}", f"expected a number or numbers, got {value!r}")
    description_dir = values["description_dir"]
    if description_dir.startswith((".", "/", "~")):  # a path, not an example-robot-data folder
        folder = Path(description_dir).expanduser()
        description_dir = str((path.parent / folder).resolve() if not folder.is_absolute() else folder)
    prefixes, foot_suffix = tuple(values["leg_prefixes"]), values["foot_suffix"]
    recipe = SphereFeet(float(values["foot_radius_m"]), tuple(f"{p}_{foot_suffix}" for p in prefixes)) \
        if feet == "sphere" else None
    return RobotSpec(
        name=values["name"], description_dir=description_dir, urdf=values["urdf"], srdf=values.get("srdf", ""),
        standing_pose=values.get("standing_pose", ""), leg_prefixes=prefixes,
        joint_suffixes=tuple(values["joint_suffixes"]), foot_suffix=foot_suffix,
        foot_radius_m=float(values["foot_radius_m"]), fz_max_n=float(values["fz_max_n"]),
        kin_threshold_m=float(values["kin_threshold_m"]), fall_base_height_m=float(values["fall_base_height_m"]),
        torque_limit_nm=None if "torque_limit_nm" not in values else float(values["torque_limit_nm"]),
        standing_leg_joints_rad=None if stance is None else tuple(float(v) for v in stance),
        description=values.get("description", ""),
        controller_gains=_gains(tables["controller_gains"]),
        one_level_controller_gains=_gains(tables["one_level_controller_gains"]),
        heights_controller_gains=_gains(tables["heights_controller_gains"]),
        collision_recipe=recipe, recipe_version=f"file-{feet}-feet-v1",
        size_scale=None if "size_scale" not in values else float(values["size_scale"]),
        walk_crouch_m=float(crouch["walk_crouch_m"]), trot_crouch_m=float(crouch["trot_crouch_m"]),
        stance_abduction_rad=float(widen),
        one_level_stance_abduction_rad=float(widen_one_level),
        one_level_stance_gaits=None if stance_gaits is None else tuple(stance_gaits),
        brace_outward_m=float(outward),
    )


def _gains(table: dict[str, Any]) -> tuple[tuple[str, Any], ...]:
    """A robot file's gains table as ``RobotSpec``'s (name, value) pairs (lists become tuples)."""
    return tuple((name, tuple(float(v) for v in value) if isinstance(value, list) else float(value))
                 for name, value in table.items())


def spec_values(spec: RobotSpec) -> dict[str, Any]:
    """A spec as a robot file's values (the inverse of `spec_from_values`, for `write_robot_file`)."""
    values: dict[str, Any] = {}
    for field in fields(RobotSpec):
        value = getattr(spec, field.name)
        if field.name in ("collision_recipe", "recipe_version", *_GAIN_TABLES) or value is None or value == "" \
                or value == ():  # (the gains tables: as tables, below)
            continue
        if field.name in ("walk_crouch_m", "trot_crouch_m", "stance_abduction_rad", "one_level_stance_abduction_rad",
                          "brace_outward_m") and value == 0.0:  # the default: not written
            continue
        values[field.name] = list(value) if isinstance(value, tuple) else value
    values["feet"] = "sphere" if spec.collision_recipe is not None else "mesh"
    for table in _GAIN_TABLES:
        if getattr(spec, table):
            values[table] = {name: list(v) if isinstance(v, tuple) else v for name, v in getattr(spec, table)}
    return values


def to_toml(values: dict[str, Any], comments: dict[str, str] | None = None) -> str:
    """The robot file's TOML text of ``values`` (scalars and lists first, then the tables), each field with its
    comment from ``comments``."""
    comments = comments or {}

    def text(value: Any) -> str:
        if isinstance(value, str):
            return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(value, bool):
            return "true" if value else "false"
        if isinstance(value, list | tuple):
            return "[" + ", ".join(text(v) for v in value) + "]"
        return repr(float(value)) if isinstance(value, float) else str(value)

    lines = []
    for key, value in values.items():
        if not isinstance(value, dict):
            lines.append(f"{key} = {text(value)}" + (f"  # {comments[key]}" if key in comments else ""))
    for key, value in values.items():
        if isinstance(value, dict):
            lines += ["", f"[{key}]"] + [f"{k} = {text(v)}" for k, v in value.items()]
    return "\n".join(lines) + "\n"


def registered_files() -> tuple[str, ...]:
    """The robot files listed in ``CONTACTNET_ROBOT_FILES``."""
    return tuple(p for p in os.environ.get(ROBOT_FILES_ENV, "").split(os.pathsep) if p)


__all__ = ["ROBOT_FILES_ENV", "SphereFeet", "is_robot_file", "load_robot_file", "registered_files",
           "spec_from_values", "spec_values", "to_toml"]
