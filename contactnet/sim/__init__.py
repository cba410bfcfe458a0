"""Simulation: the physics engines the robot walks in.

- ``world``: what every engine shares: `SimConfig`, `SimState` (what the sensors read), `Push`, the links that touch
  the terrain, the standing controller, and the referee (falls and the goal, the same rules for every engine).
- ``engines``: `make_simulator` (the backend of ``SimConfig.engine``) and the engines' versions.
- ``pybullet_world``: `Simulator`, the PyBullet world at 1 kHz (the default engine).
- ``mujoco_world``: `MujocoSimulator`, the MuJoCo world at 1 kHz: the same robot, terrain and interface.
- ``mismatch``: `ModelMismatch`, how the simulated robot differs from the model the planner and controller use.
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "Simulator": "contactnet.sim.pybullet_world",
    "MujocoSimulator": "contactnet.sim.mujoco_world",
    "make_simulator": "contactnet.sim.engines",
    "ENGINES": "contactnet.sim.world",
    "SimConfig": "contactnet.sim.world",
    "SimState": "contactnet.sim.world",
    "Push": "contactnet.sim.world",
    "StandingGains": "contactnet.sim.world",
    "ModelMismatch": "contactnet.sim.mismatch",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
