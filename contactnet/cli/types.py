"""The command line's argument types: each parses one option's text and says in one line, naming the option, what
was wrong (argparse prints it and exits 2); `UserError`, a mistake found after parsing (one line, exit code 2); and
`sim_of`, the engine an option chose."""

from __future__ import annotations

import argparse
import sys

SIM_HELP = "the physics engine (default pybullet; mujoco where pybullet is not installed)"
ROBOT_METAVAR = "NAME|FILE.toml"
SCALE_HELP = ("the scene's size against the paper's (default: the robot's size_scale, 1 for Solo12; esfal's "
              "stone_grid and files are never scaled)")
HEIGHT_HELP = "random_heights: each square's top within +-H m (default 0.03)"


class UserError(Exception):
    """A mistake in what the user asked for: printed as one line, exit code 2."""


def sim_of(args: argparse.Namespace) -> str:
    """``--sim``, or the default engine (PyBullet; MuJoCo where pybullet is not installed, with a one-line notice)."""
    from contactnet.sim.world import default_engine

    if getattr(args, "sim", None) is None:
        args.sim = default_engine()
        if args.sim != "pybullet":
            print(f"contactnet: pybullet is not installed here: simulating in {args.sim} (--sim)", file=sys.stderr)
    return args.sim


def bounded_float(name: str, low: float, high: float):
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (low <= value <= high):  # also rejects nan
            raise argparse.ArgumentTypeError(f"{name} must be in [{low}, {high}], got {text}")
        return value

    return parse


def choices(name: str, allowed: tuple[str, ...]):
    def parse(text: str) -> tuple[str, ...]:
        items = tuple(t.strip() for t in text.split(",") if t.strip())
        bad = [t for t in items if t not in allowed]
        if bad or not items:
            raise argparse.ArgumentTypeError(f"{name}: expected a comma-separated list of {', '.join(allowed)}, got {text!r}")
        return items

    return parse


def number_list(name: str, low: float, high: float, kind: type = float):
    """Comma-separated numbers of ``kind`` (int: whole numbers), each in [low, high] (nan rejected)."""
    what = "whole numbers" if kind is int else "numbers"
    bounds = f"{low}..{high}" if kind is int else f"[{low:g}, {high:g}]"

    def parse(text: str) -> tuple:
        try:
            items = tuple(kind(t) for t in text.split(",") if t.strip())
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name}: expected comma-separated {what}, got {text!r}") from None
        if not items or any(not low <= v <= high for v in items):
            raise argparse.ArgumentTypeError(f"{name}: every value must be in {bounds}, got {text!r}")
        return items

    return parse


def bounded_int(name: str, low: int, high: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a whole number, got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{name} must be in {low}..{high}, got {value}")
        return value

    return parse


def robot_argument(text: str) -> str:
    """``--robot NAME|FILE.toml``: a registered robot's name, or a robot file's (registered here and, through the
    environment, in the processes this one starts); returns the robot's name."""
    from contactnet.robots import RobotDataError, robot_names, use_robot_file
    from contactnet.robots.robot_file import is_robot_file

    if is_robot_file(text):
        try:
            return use_robot_file(text)
        except RobotDataError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    if text not in robot_names():
        raise argparse.ArgumentTypeError(f"unknown robot {text!r}: choose one of {', '.join(robot_names())} or a "
                                         "robot file (FILE.toml)")
    return text


def positive_int(name: str, high: int):
    return bounded_int(name, 1, high)


__all__ = ["HEIGHT_HELP", "SCALE_HELP", "ROBOT_METAVAR", "SIM_HELP", "UserError", "sim_of", "bounded_float", "bounded_int", "choices", "number_list", "positive_int", "robot_argument"]
