"""Build a terrain in code: a start slab, three stones and an end slab; check it, draw it, walk it.

    python examples/02_terrain_in_code.py [--duration 30] [--out my_stones.png]

A terrain is the union of 2D regions (rect, circle, star, polygon, grid); everything else is a hole.
`Terrain.from_dict` validates like a terrain file does (a bad field is one clear error); `save` writes
the JSON that `contactnet simulate --terrain my_stones.json` and the web tool read.
"""

from __future__ import annotations

import argparse

from contactnet import Locomotion, Terrain, registry

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--duration", type=float, default=30.0)
parser.add_argument("--out", default=None, help="also draw the terrain to this PNG")
args = parser.parse_args()

terrain = Terrain.from_dict({
    "name": "three_stones", "start": [0.0, 0.0], "goal_x": 1.05,
    "regions": [
        {"shape": "rect", "center": [0.0, 0.0], "size": [0.6, 0.5]},       # start slab
        {"shape": "rect", "center": [0.42, 0.0], "size": [0.14, 0.5]},      # a long bar
        {"shape": "circle", "center": [0.58, 0.12], "radius": 0.07},        # two round stones
        {"shape": "circle", "center": [0.58, -0.12], "radius": 0.07},
        {"shape": "rect", "center": [1.05, 0.0], "size": [0.7, 0.5]},      # end slab
    ],
})
print(terrain.summary())
if args.out:
    terrain.render_png(args.out)
    print("drew", args.out)

robot = registry.load_robot("solo12").for_terrain(terrain)  # its stance for this terrain (wider on one level)
gait = registry.gait_by_name("walk")
planner = registry.make_planner("contactnet", gait, robot)
with Locomotion(robot, terrain, gait, planner, vel_cmd_xy=(0.05, 0.0)) as loco:
    summary = loco.run(args.duration)
print(f"success={summary['success']} reached_x={summary['reached_x']:.2f} m steps={summary['steps']} "
      f"unsafe_landings={summary['unsafe_landings']}")
