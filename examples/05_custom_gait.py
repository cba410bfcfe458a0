"""A new gait, the pace (both legs of a side swing together), defined and registered outside the package.

    python examples/05_custom_gait.py [--duration 10]

A gait is one `GaitSpec`: which legs swing together, the candidate grid, the step timing, the fixed
cyclic order and the ranking cost's weights. Registered in this process, the heuristic planner walks it at
once. For `contactnet datagen/train --gait pace` (and `serve`, and the worker processes) to know it, register it
from an installed package's entry point (group `contactnet.gaits`, see examples/plugin and docs/robots.md).
"""

from __future__ import annotations

import argparse

from contactnet import Locomotion, registry, resolve_terrain
from contactnet.motion.cost_weights import TROT_WEIGHTS
from contactnet.motion.gait import FL, FR, HL, HR, GaitSpec

PACE = registry.register_gait(GaitSpec(
    name="pace",
    swing_groups=((FL, HL), (FR, HR)),
    grid_n=3,
    cyclic_order=(0, 1),
    cost_weights=TROT_WEIGHTS,
))

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0)
    args = parser.parse_args()
    print("gaits:", ", ".join(registry.gait_names()))
    terrain = resolve_terrain("flat")
    robot = registry.load_robot("solo12").for_terrain(terrain)  # its stance for this terrain (wider on one level)
    planner = registry.make_planner("heuristic", PACE, robot)
    with Locomotion(robot, terrain, PACE, planner, vel_cmd_xy=(0.05, 0.0)) as loco:
        summary = loco.run(args.duration, stop_at_goal=False)
    print(f"pace: fell={summary['fell']} ({summary['fall_reason']}), mean vx {summary['mean_velocity_xy'][0]:.3f} m/s, "
          f"{summary['steps']} steps, first: {summary['gait_sequence'][:4]}")
