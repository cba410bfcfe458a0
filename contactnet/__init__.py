"""contactnet: acyclic quadruped contact planning (the ContactNet paper and beyond).

The main objects, importable from here (loaded on first use, so ``import contactnet`` stays cheap)::

    from contactnet import Locomotion, registry, resolve_terrain
    robot = registry.load_robot("solo12")
    gait = registry.gait_by_name("walk")
    planner = registry.make_planner("contactnet", gait, robot)
    with Locomotion(robot, resolve_terrain("stepping_stones"), gait, planner, vel_cmd_xy=(0.05, 0.0)) as loco:
        print(loco.run(40.0))

See ``examples/`` for runnable scripts and ``docs/architecture.md`` for the layers.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

#: public name -> module that defines it
_EXPORTS: dict[str, str] = {
    "registry": "contactnet.registry",
    "Robot": "contactnet.robots",
    "RobotDescription": "contactnet.robots",
    "RobotSpec": "contactnet.robots",
    "load_robot": "contactnet.robots",
    "GaitSpec": "contactnet.gait",
    "Terrain": "contactnet.terrain",
    "TerrainError": "contactnet.terrain",
    "resolve_terrain": "contactnet.terrain",
    "Planner": "contactnet.planner",
    "PlannedStep": "contactnet.planner",
    "PlanningContext": "contactnet.planner",
    "CostWeights": "contactnet.cost_weights",
    "RankingCost": "contactnet.cost",
    "TrajectoryOptimizer": "contactnet.trajopt",
    "WholeBodyController": "contactnet.controller",
    "Simulator": "contactnet.sim",
    "SimConfig": "contactnet.sim",
    "Push": "contactnet.sim",
    "Locomotion": "contactnet.locomotion",
    "LocomotionConfig": "contactnet.locomotion",
}
_RENAMED = {"resolve_terrain": "resolve"}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'contactnet' has no attribute {name!r}")
    loaded = importlib.import_module(module)
    value = loaded if module == f"contactnet.{name}" else getattr(loaded, _RENAMED.get(name, name))
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
