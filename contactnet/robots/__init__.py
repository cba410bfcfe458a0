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
)
from contactnet.robots.robot_file import ROBOT_FILES_ENV, is_robot_file, load_robot_file, registered_files
from contactnet.robots.sim_urdf import write_pybullet_urdf

_ROBOTS: dict[str, RobotSpec] = {}


def register_robot(spec: RobotSpec) -> RobotSpec:
    """Make a robot known by its name (CLI ``--robot``, the web app, model files). Returns the spec. The same spec
    again (e.g. a robot file read twice) is no change; another spec under a taken name is refused."""
    if spec.name in _ROBOTS and _ROBOTS[spec.name] != spec:
        raise ValueError(f"a robot named {spec.name!r} is already registered")
    _ROBOTS.setdefault(spec.name, spec)
    return spec


def use_robot_file(path: str | Path) -> str:
    """Register the robot a robot file states, in this process and (through ``CONTACTNET_ROBOT_FILES``) in the
    processes it starts; returns its name. One line (`RobotDataError`) for a bad file or a taken name."""
    import os

    spec = load_robot_file(path)
    try:
        register_robot(spec)
    except ValueError:
        raise RobotDataError(f"robot file {path}: a robot named {spec.name!r} already exists (give it another "
                             "name)") from None
    resolved = str(Path(path).resolve())
    if resolved not in registered_files():
        os.environ[ROBOT_FILES_ENV] = os.pathsep.join([*registered_files(), resolved])
    return spec.name


def robot_names() -> tuple[str, ...]:
    """Every robot's name: the shipped ones, the plugins' and those of the robot files in ``CONTACTNET_ROBOT_FILES``."""
    from contactnet.plugins import load_plugins

    load_plugins()
    for path in registered_files():  # registering a file's spec again is no change
        try:
            register_robot(load_robot_file(path))
        except (RobotDataError, ValueError) as exc:  # the file changed or went away since: said, and skipped
            import sys

            print(f"contactnet: {ROBOT_FILES_ENV} names {path}: {exc}", file=sys.stderr)
    return tuple(_ROBOTS)


def robot_spec(name: str) -> RobotSpec:
    """The spec of a robot by name, or of a robot file (``*.toml``, registered then)."""
    if is_robot_file(name):
        return robot_spec(use_robot_file(name))
    if name not in _ROBOTS:
        robot_names()  # a plugin's robot, or a robot file's
    try:
        return _ROBOTS[name]
    except KeyError:
        raise RobotDataError(f"unknown robot {name!r}: choose one of {', '.join(_ROBOTS)} or a robot file "
                             "(FILE.toml)") from None


def load_robot(name: str = "solo12", cache_dir: Path | None = None) -> Robot:
    """Build the named robot's model (a few ms), or a robot file's (``*.toml``); give each thread its own."""
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
    "use_robot_file",
    "write_pybullet_urdf",
]
