"""Models of motion: what a gait is and how the body follows a plan.

- ``gait``: `GaitSpec` (timing, candidate grid, action index, contact schedule) and the table of gaits;
- ``cost_weights``: the weights of each gait's ranking cost;
- ``trajopt/``: the single-rigid-body trajectory optimizer (model, QP, solvers);
- ``controller`` (+ ``controller_kernel``, compiled): the 1 kHz whole-body controller;
- ``swing``: swing paths that clear the tops they cross; ``ground``: CoM height and pitch references
  from the tops under the feet; ``support_polygon``: support-polygon geometry.
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "GaitSpec": "contactnet.motion.gait",
    "gait_by_name": "contactnet.motion.gait",
    "register_gait": "contactnet.motion.gait",
    "CostWeights": "contactnet.motion.cost_weights",
    "TrajectoryOptimizer": "contactnet.motion.trajopt",
    "TrajoptConfig": "contactnet.motion.trajopt",
    "WholeBodyController": "contactnet.motion.controller",
    "ControllerGains": "contactnet.motion.controller",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
