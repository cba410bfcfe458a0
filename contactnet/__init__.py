"""contactnet: acyclic quadruped contact planning (the ContactNet paper and beyond).

The main objects, importable from here (loaded on first use, so ``import contactnet`` stays cheap)::

    from contactnet import Locomotion, registry, resolve_terrain
    terrain = resolve_terrain("stepping_stones")
    robot = registry.load_robot("solo12").for_terrain(terrain, "walk")  # its stance for this terrain and gait
    gait = registry.gait_by_name("walk")
    planner = registry.make_planner("contactnet", gait, robot)
    with Locomotion(robot, terrain, gait, planner, vel_cmd_xy=(0.05, 0.0)) as loco:
        print(loco.run(40.0))

See ``examples/`` for runnable scripts and ``docs/architecture.md`` for the layers.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

def lazy_exports(package: str, exports: dict[str, str], renamed: dict[str, str] | None = None):
    """``(__getattr__, __dir__)`` for a package face that hands names on from its modules, loaded on first
    use: ``exports`` maps a public name to the module that defines it (a name equal to that module's last
    part is the module itself); ``renamed`` gives a public name's name in its module where they differ."""
    renamed = renamed or {}
    namespace = importlib.import_module(package).__dict__ if package != __name__ else globals()

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        loaded = importlib.import_module(module)
        value = loaded if module.rpartition(".")[2] == name else getattr(loaded, renamed.get(name, name))
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace.get("__all__", ()), *exports})

    return __getattr__, __dir__


#: public name -> module that defines it
_EXPORTS: dict[str, str] = {
    "registry": "contactnet.registry",
    "Robot": "contactnet.robots",
    "RobotDescription": "contactnet.robots",
    "RobotSpec": "contactnet.robots",
    "load_robot": "contactnet.robots",
    "GaitSpec": "contactnet.motion.gait",
    "Terrain": "contactnet.terrain",
    "TerrainError": "contactnet.terrain",
    "resolve_terrain": "contactnet.terrain",
    "Planner": "contactnet.planning.planner",
    "PlannedStep": "contactnet.planning.planner",
    "PlanningContext": "contactnet.planning.planner",
    "CostWeights": "contactnet.motion.cost_weights",
    "RankingCost": "contactnet.planning.cost",
    "TrajectoryOptimizer": "contactnet.motion.trajopt",
    "WholeBodyController": "contactnet.motion.controller",
    "Simulator": "contactnet.sim.pybullet_world",
    "SimConfig": "contactnet.sim.world",
    "Push": "contactnet.sim.world",
    "Locomotion": "contactnet.locomotion",
    "LocomotionConfig": "contactnet.locomotion",
}
_RENAMED = {"resolve_terrain": "resolve"}

__all__ = ["__version__", *_EXPORTS]


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, _RENAMED)
