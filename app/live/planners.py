"""How the live session gets its planner: `contactnet.registry.make_planner`, with a fallback.

A planner that ranks with a trained model (registry entry ``needs_model``: ``contactnet``, ``fixed``)
loads ``registry.model_path(robot, gait, models_dir)``; when that file is missing or cannot be used, the
session runs `FALLBACK_PLANNER` instead and says why, so the tool stays usable without trained models.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, Protocol

from contactnet import registry
from contactnet.motion.gait import GaitSpec
from contactnet.robots import Robot

log = logging.getLogger("contactnet.app.planners")

#: What the session runs when the asked planner's model cannot be used.
FALLBACK_PLANNER = "heuristic"


class PlannerFactory(Protocol):
    """(planner name, gait, robot) -> (planner, name of the planner actually used, note or None)."""

    def __call__(self, name: str, gait: GaitSpec, robot: Robot | None = None) -> tuple[Any, str, str | None]: ...


def default_planner_factory(
    name: str, gait: GaitSpec, robot: Robot | None = None, model_dir: str | Path | None = None
) -> tuple[Any, str, str | None]:
    """(planner, name of the planner actually used, note).

    Planners with a model load ``registry.model_path(robot, gait, model_dir)``, by default the shipped
    model (``contactnet/models/{gait}.pt`` for Solo12). When that file is missing or cannot be used, the
    session runs the heuristic planner instead and the note says why (shown in the status panel and the
    API). ``robot`` defaults to the registry's default robot."""
    from contactnet.planning.network import ModelFileError

    if robot is None:
        robot = registry.load_robot(registry.DEFAULT_ROBOT)
    if not registry.planner_entry(name).needs_model:
        return registry.make_planner(name, gait, robot), name, None
    model = registry.model_path(robot.name, gait.name, None if model_dir is None else Path(model_dir))
    try:
        return registry.make_planner(name, gait, robot, model=model), name, None
    except ModelFileError as exc:
        if model.exists():
            log.warning("the %s model cannot be used: %s", gait.name, exc)
            note = f"{name} planner unavailable, {exc}: using {FALLBACK_PLANNER}"
        else:
            note = (
                f"{name} planner: no trained {gait.name} model yet ({model.name} not found): "
                f"using {FALLBACK_PLANNER}"
            )
    except Exception as exc:  # noqa: BLE001 - keep the tool usable whatever went wrong
        log.exception("could not build the %s planner", name)
        note = f"the {name} planner could not be built ({exc}): using {FALLBACK_PLANNER}"
    return registry.make_planner(FALLBACK_PLANNER, gait, robot), FALLBACK_PLANNER, note
