"""A planner defined outside the package, registered by name, then used like the built-in ones.

    python examples/03_custom_planner.py [--duration 10]

`CautiousPlanner` wraps the shipped ContactNet ranking but never lands a foot within 3 cm of a hole:
it walks down the network's ranking with a larger safety margin. One file, one `register_planner`
call; nothing in contactnet/ is edited. After registration, `registry.planner_names()` (which the
CLI's and the web app's choices read) lists it.
"""

from __future__ import annotations

import argparse

from contactnet import Locomotion, registry, resolve_terrain
from contactnet.planning.planner import ContactNetPlanner, PlannedStep, PlanningContext


class CautiousPlanner:
    """ContactNet's ranking with a 3 cm edge margin instead of half the foot radius."""

    name = "cautious"

    def __init__(self, gait, robot, model) -> None:  # noqa: ANN001 - the registry's factory arguments
        self._inner = ContactNetPlanner(gait, robot, model, margin_m=0.03)
        self.last_candidates = None

    def reset(self) -> None:
        self._inner.reset()
        self.last_candidates = None

    def plan(self, ctx: PlanningContext) -> list[PlannedStep]:
        steps = self._inner.plan(ctx)
        self.last_candidates = self._inner.last_candidates
        return steps


registry.register_planner("cautious", CautiousPlanner, needs_model=True,
                          summary="ContactNet's ranking, 3 cm away from every edge")

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0)
    args = parser.parse_args()
    print("planners:", ", ".join(registry.planner_names()))
    terrain = resolve_terrain("stepping_stones")
    robot = registry.load_robot("solo12").for_terrain(terrain)  # its stance for this terrain (wider on one level)
    gait = registry.gait_by_name("walk")
    planner = registry.make_planner("cautious", gait, robot)
    with Locomotion(robot, terrain, gait, planner, vel_cmd_xy=(0.05, 0.0)) as loco:
        summary = loco.run(args.duration)
    print(f"cautious planner: fell={summary['fell']} reached_x={summary['reached_x']:.2f} m, "
          f"steps={summary['steps']}, mean rank {summary['rank_chosen']['mean']:.1f}")
