"""The Unitree Go2 (about 16 kg) walks and trots on flat ground: the same code, another robot.

    python examples/04_go2_walks.py [--duration 20]

`contactnet/robots/go2.py` is the whole robot: where its URDF and SRDF lie in example-robot-data, its
leg and joint names, foot radius, contact-force cap and a few controller gains. Everything else (mass,
inertia, hips, stance, torque limits) is read from its files. This uses the heuristic planner on flat ground;
Go2's own ContactNet models (`--planner contactnet`, contactnet/models/go2_*.pt) are described in docs/robots.md.
"""

from __future__ import annotations

import argparse

from contactnet import Locomotion, registry, resolve_terrain

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--duration", type=float, default=20.0)
parser.add_argument("--vx", type=float, default=0.1)
args = parser.parse_args()

robot = registry.load_robot("go2")
d = robot.description
print(f"{d.name}: {d.mass_kg:.2f} kg, CoM {d.com_height_nominal_m:.3f} m high, legs reach {d.leg_reach_m:.3f} m, "
      f"torque limits {sorted(set(d.torque_limit_nm.round(2).tolist()))} N m")
for gait_name in ("walk", "trot"):
    gait = registry.gait_by_name(gait_name)
    planner = registry.make_planner("heuristic", gait, robot)
    with Locomotion(robot, resolve_terrain("flat"), gait, planner, vel_cmd_xy=(args.vx, 0.0)) as loco:
        summary = loco.run(args.duration, stop_at_goal=False)
    progress = summary["mean_velocity_xy"][0] / args.vx
    print(f"go2 {gait_name}: fell={summary['fell']} after {summary['sim_time_s']:.1f} s, "
          f"mean vx {summary['mean_velocity_xy'][0]:.3f} m/s ({100 * progress:.0f} % of the command), "
          f"{summary['sim_time_s'] / summary['wall_time_s']:.1f}x real time")
