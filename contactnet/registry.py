"""The one place names live: gaits, planners, robots and model files.

The command line's choices, the web API's enums and the live session all read these tables, so a
gait, planner or robot registered here (or from outside the package, before they are read) is
offered everywhere::

    from contactnet import registry
    registry.register_planner("my_planner", lambda gait, robot, model: MyPlanner(gait, robot))

The tables of gaits (``contactnet.motion.gait``) and robots (``contactnet.robots``) live beside their
definitions and are re-exported here. Built in: gaits ``walk`` and ``trot``; planners ``contactnet``, ``fixed``, ``heuristic``, ``oracle``;
robots ``solo12`` and ``go2`` (``contactnet.robots``). Trained models ship as
``contactnet/models/{gait}.pt`` for Solo12 and ``{robot}_{gait}.pt`` for other robots.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from contactnet.motion.gait import GaitSpec, gait_by_name, gait_for, gait_names, register_gait
from contactnet.planning.heuristic import HeuristicPlanner
from contactnet.planning.oracle import OraclePlanner
from contactnet.planning.planner import ContactNetPlanner, FixedGaitPlanner, Planner
from contactnet.plugins import load_plugins
from contactnet.robots import (
    DEFAULT_ROBOT,
    Robot,
    RobotDescription,
    load_robot,
    register_robot,
    robot_names,
    robot_spec,
)

# ---- planners ---------------------------------------------------------------------------------
#: Builds a planner for a gait and a robot; ``model`` is the loaded network (None unless ``needs_model``).
PlannerFactory = Callable[[GaitSpec, RobotDescription, Any], Planner]


@dataclass(frozen=True)
class PlannerEntry:
    name: str
    build: PlannerFactory
    needs_model: bool = False  #: loads the gait's ContactNet model (``model_path``)
    summary: str = ""


_PLANNERS: dict[str, PlannerEntry] = {}


def register_planner(name: str, build: PlannerFactory, needs_model: bool = False, summary: str = "") -> PlannerEntry:
    """Make a planner known by its name (CLI ``--planner``, the web app's dropdown, experiments)."""
    if name in _PLANNERS:
        raise ValueError(f"a planner named {name!r} is already registered")
    entry = PlannerEntry(name, build, needs_model, summary)
    _PLANNERS[name] = entry
    return entry


def planner_names() -> tuple[str, ...]:
    return tuple(_PLANNERS)


def planner_entry(name: str) -> PlannerEntry:
    try:
        return _PLANNERS[name]
    except KeyError:
        raise ValueError(f"unknown planner {name!r}: choose one of {', '.join(_PLANNERS)}") from None


def make_planner(name: str, gait: GaitSpec, robot: Robot | RobotDescription | None = None,
                 model: str | Path | None = None) -> Planner:
    """The planner called ``name`` for ``gait`` and ``robot`` (default Solo12). Planners that rank with the
    network load ``model`` (default: the shipped ``model_path(robot, gait)``); a missing, broken or foreign
    model file raises ``contactnet.planning.network.ModelFileError``."""
    entry = planner_entry(name)
    if robot is None:
        robot = load_robot(DEFAULT_ROBOT)
    description = robot.description if isinstance(robot, Robot) else robot
    loaded = None
    if entry.needs_model:
        from contactnet.planning.network import load_model

        path = model_path(description.name, gait.name) if model is None else Path(model)
        if model is None and not path.exists():  # no shipped model: say what to do instead
            from contactnet.planning.network import ModelFileError

            others = ", ".join(f"--planner {n}" for n, e in _PLANNERS.items() if not e.needs_model)
            raise ModelFileError(
                f"no {name} model for {description.name} {gait.name} ({path} does not exist): use {others}, or "
                f"--model FILE.pt, or make one with contactnet datagen --robot {description.name} --gait {gait.name} "
                f"--out DIR and contactnet train --robot {description.name} --gait {gait.name} --data DIR --out FILE.pt")
        loaded = load_model(path, expect_gait=gait.name, expect_robot=description.name, dtype="float32")
    return entry.build(gait, description, loaded)


# ---- terrains at the robot's size ------------------------------------------------------------------
#: Scenes whose numbers are absolute, never scaled to the robot: esfal's Go2 stones are given at Go2's size.
ABSOLUTE_SCENES = ("stone_grid",)


def terrain_for(name: str, robot: Robot | RobotDescription, removed: int | None = None, seed: int = 0,
                height_m: float | None = None, scale: float | None = None):  # noqa: ANN201 - a Terrain
    """The terrain ``name`` for ``robot``: a scene (the random field, the stones, ...) at the robot's size
    (``size_scale``, `contactnet.motion.gait.SIZE_RULE`) unless ``scale`` says otherwise; a file as it is.
    Solo12's scenes are the paper's."""
    from contactnet.terrain import resolve

    description = robot.description if isinstance(robot, Robot) else robot
    if scale is None:
        scale = 1.0 if name in ABSOLUTE_SCENES else description.size_scale
    return resolve(name, removed=removed, seed=seed, height_m=height_m, scale=scale)


# ---- model files --------------------------------------------------------------------------------
MODELS_DIR = Path(__file__).resolve().parent / "models"


def model_path(robot_name: str, gait_name: str, models_dir: Path | None = None) -> Path:
    """Where the trained model of a robot and gait lives: ``{gait}.pt`` for Solo12 (the paper's robot),
    ``{robot}_{gait}.pt`` for the others, in ``models_dir`` (default: the package's ``models/``)."""
    folder = MODELS_DIR if models_dir is None else Path(models_dir)
    stem = gait_name if robot_name == DEFAULT_ROBOT else f"{robot_name}_{gait_name}"
    return folder / f"{stem}.pt"


# ---- the built-in tables --------------------------------------------------------------------------
register_planner("contactnet", lambda gait, robot, model: ContactNetPlanner(gait, robot, model), needs_model=True,
                 summary="the network ranks every candidate; the best safe one is taken (acyclic)")
register_planner("fixed", lambda gait, robot, model: FixedGaitPlanner(gait, robot, model), needs_model=True,
                 summary="the same network held to a fixed leg order (the paper's baseline)")
register_planner("heuristic", lambda gait, robot, model: HeuristicPlanner(gait),
                 summary="fixed cyclic gait with Raibert footholds, blind to holes")
register_planner("oracle", lambda gait, robot, model: OraclePlanner(gait, robot),
                 summary="evaluates the ranking cost of every candidate online (exact, slow)")
# The paper's planner as a baseline: the same network and safe-landing walk with every addition of this project off (no
# capture step after a push, no standing still at a zero command, no room for the foot's roll nor its slide back or
# reseat, no leg stepping alone by the reach rule, and a step with no safe action stays where it stands).
register_planner("contactnet_paper",
                 lambda gait, robot, model: ContactNetPlanner(gait, robot, model, capture=None, idle=None, roll=None,
                                                              reach=None, put_back=False),
                 needs_model=True, summary="ContactNet as the paper has it, without this project's additions (a baseline)")

# Robots, gaits, planners and terrains of installed plugins (contactnet.plugins): registered before any name is read.
load_plugins()

__all__ = [
    "ABSOLUTE_SCENES",
    "DEFAULT_ROBOT",
    "MODELS_DIR",
    "PlannerEntry",
    "gait_by_name",
    "gait_for",
    "gait_names",
    "load_robot",
    "make_planner",
    "model_path",
    "planner_entry",
    "planner_names",
    "register_gait",
    "register_planner",
    "register_robot",
    "terrain_for",
    "robot_names",
    "robot_spec",
]
