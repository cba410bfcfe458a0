"""Planning: which feet step where next.

- ``cost``: the ranking cost V of every candidate action (``cost_study``: how its weights were chosen);
- ``footholds``: the foothold checks on terrain with heights;
- ``planner``: the `Planner` protocol and the heuristic, ContactNet and fixed-gait planners
  (``oracle``: the cost evaluated online);
- ``ranking`` (+ ``safe_walk``, compiled): the walk down a ranking to the first safe action; on terrain with
  heights compiled with the height checks (``heights_walk``, its point lookups ``heights_lookup``, what they read
  ``heights_tables``);
- ``stand``, ``capture``, ``retarget``, ``observer``: standing, the capture step, swing retargeting and
  the disturbance observer;
- ``network``, ``network_input``, ``normalizer``, ``model_file``: the network's numpy inference, its
  input, and the torch-free model-file reader (``network_torch``: the torch network, training only).
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "Planner": "contactnet.planning.planner",
    "PlannedStep": "contactnet.planning.planner",
    "PlanningContext": "contactnet.planning.planner",
    "ContactNetPlanner": "contactnet.planning.planner",
    "FixedGaitPlanner": "contactnet.planning.planner",
    "HeuristicPlanner": "contactnet.planning.heuristic",
    "RankingCost": "contactnet.planning.cost",
    "load_model": "contactnet.planning.network",
    "ModelFileError": "contactnet.planning.network",
    "DisturbanceObserver": "contactnet.planning.observer",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
