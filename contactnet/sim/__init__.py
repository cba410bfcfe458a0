"""Simulation: the physics engine the robot walks in.

- ``pybullet_world``: `Simulator` (the PyBullet world at 1 kHz: robot, terrain, pushes, sensor noise),
  `SimConfig`, `Push`, and the standing controller.
- ``mismatch``: `ModelMismatch`, how the simulated robot differs from the model the planner and controller use.
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "Simulator": "contactnet.sim.pybullet_world",
    "SimConfig": "contactnet.sim.pybullet_world",
    "SimState": "contactnet.sim.pybullet_world",
    "Push": "contactnet.sim.pybullet_world",
    "StandingGains": "contactnet.sim.pybullet_world",
    "ModelMismatch": "contactnet.sim.mismatch",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
