"""The physics engines (``SimConfig.engine``, ``--sim``): make the simulator of one, and say which version runs.

PyBullet (``contactnet.sim.pybullet_world``) is the default and made every result before issue 28; MuJoCo
(``contactnet.sim.mujoco_world``) is the second engine. Both take the same ``SimConfig`` and are driven alike
(``contactnet.sim.world``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from contactnet.sim.world import ENGINE_PACKAGES, ENGINES, SimConfig, default_engine, engine_installed
from contactnet.terrain import Terrain

if TYPE_CHECKING:
    from contactnet.robots.description import Robot


class EngineMissing(ImportError):
    """The physics engine asked for is not installed here: one line saying what to do instead."""


def engine_version(engine: str) -> str:
    """The installed version of ``engine``'s Python package (``pybullet``, ``mujoco-core``), or "not installed"."""
    from importlib import metadata

    try:
        return metadata.version(ENGINE_PACKAGES[engine])
    except metadata.PackageNotFoundError:
        return "not installed"


def make_simulator(robot: Robot, terrain: Terrain, config: SimConfig | None = None):  # noqa: ANN201 - a backend
    """The simulator of ``config.engine`` with ``robot`` on ``terrain`` (``config`` None: the defaults, PyBullet)."""
    config = SimConfig() if config is None else config
    if not engine_installed(config.engine):
        other = next(e for e in ENGINES if e != config.engine)
        raise EngineMissing(f"the physics engine {config.engine} is not installed here (pip install "
                            f"{ENGINE_PACKAGES[config.engine]}; pybullet has wheels up to Python 3.11 only): "
                            f"use --sim {other}")
    if config.engine == "mujoco":
        from contactnet.sim.mujoco_world import MujocoSimulator

        return MujocoSimulator(robot, terrain, config)
    from contactnet.sim.pybullet_world import Simulator

    return Simulator(robot, terrain, config)


__all__ = ["ENGINES", "EngineMissing", "default_engine", "engine_installed", "engine_version", "make_simulator"]
