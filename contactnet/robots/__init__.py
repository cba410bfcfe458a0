"""Robots as parameters: a frozen description per robot, built from example-robot-data's URDF + SRDF.

``load_robot("solo12")`` returns a `Robot` (pinocchio model, kinematics, PyBullet URDF) whose
``description`` (`RobotDescription`, plain frozen numbers) is what planners, costs and optimizers take.
A new robot is one module with a `RobotSpec` and one `register_robot` call (see docs/architecture.md).
"""

from __future__ import annotations

from pathlib import Path

from contactnet.robots import go2, solo12
from contactnet.robots.description import (
    LEG_NAMES,
    Robot,
    RobotDataError,
    RobotDescription,
    RobotFiles,
    RobotSpec,
    write_pybullet_urdf,
)

_ROBOTS: dict[str, RobotSpec] = {}


def register_robot(spec: RobotSpec) -> RobotSpec:
    """Make a robot known by its name (CLI ``--robot``, the web app, model files). Returns the spec."""
    if spec.name in _ROBOTS and _ROBOTS[spec.name] is not spec:
        raise ValueError(f"a robot named {spec.name!r} is already registered")
    _ROBOTS[spec.name] = spec
    return spec


def robot_names() -> tuple[str, ...]:
    from contactnet.plugins import load_plugins

    load_plugins()
    return tuple(_ROBOTS)


def robot_spec(name: str) -> RobotSpec:
    if name not in _ROBOTS:
        robot_names()  # a plugin's robot
    try:
        return _ROBOTS[name]
    except KeyError:
        raise RobotDataError(f"unknown robot {name!r}: choose one of {', '.join(_ROBOTS)}") from None


def load_robot(name: str = "solo12", cache_dir: Path | None = None) -> Robot:
    """Build the named robot's model (a few ms); give each thread its own."""
    return Robot.load(robot_spec(name), cache_dir)


register_robot(solo12.SPEC)
register_robot(go2.SPEC)

DEFAULT_ROBOT = "solo12"

__all__ = [
    "DEFAULT_ROBOT",
    "LEG_NAMES",
    "Robot",
    "RobotDataError",
    "RobotDescription",
    "RobotFiles",
    "RobotSpec",
    "load_robot",
    "register_robot",
    "robot_names",
    "robot_spec",
    "write_pybullet_urdf",
]
