"""Simulate Solo12 walking across the paper's stepping stones with ContactNet, and print the summary.

    python examples/01_simulate_stepping_stones.py [--duration 40]

The same as `contactnet simulate --terrain stepping_stones --gait walk --planner contactnet --json`,
spelled out: a robot, a terrain, a gait and a planner, all by name, then the locomotion loop.
"""

from __future__ import annotations

import argparse
import json

from contactnet import Locomotion, registry, resolve_terrain

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--duration", type=float, default=40.0, help="simulated seconds (stops at the goal)")
args = parser.parse_args()

terrain = resolve_terrain("stepping_stones")
robot = registry.load_robot("solo12").for_terrain(terrain)  # its stance for this terrain (wider on one level)
gait = registry.gait_by_name("walk")
planner = registry.make_planner("contactnet", gait, robot)  # the shipped contactnet/models/walk.pt

with Locomotion(robot, terrain, gait, planner, vel_cmd_xy=(0.05, 0.0)) as loco:
    summary = loco.run(args.duration)

print(json.dumps({key: summary[key] for key in ("success", "fell", "reached_x", "steps", "rank_chosen",
                                                "planner_ms", "unsafe_landings")}, indent=1))
print("gait sequence:", " ".join("+".join(legs) for legs in summary["gait_sequence"][:20]), "...")
