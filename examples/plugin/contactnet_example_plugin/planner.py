"""``wide_margin``: ContactNet's ranking, but no foot within 3 cm of an edge (the shipped planner keeps half a foot
radius, 8 mm on Solo12)."""

from __future__ import annotations

from contactnet import registry
from contactnet.planning.planner import ContactNetPlanner


def wide_margin(gait, robot, model) -> ContactNetPlanner:  # noqa: ANN001 - the registry's factory arguments
    planner = ContactNetPlanner(gait, robot, model, margin_m=0.03)
    planner.name = "wide_margin"
    return planner


def register() -> None:
    registry.register_planner("wide_margin", wide_margin, needs_model=True,
                              summary="ContactNet's ranking, 3 cm away from every edge (examples/plugin)")
