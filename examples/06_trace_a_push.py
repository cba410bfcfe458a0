"""Trace a run: push Solo12 sideways while it walks, sample the loop, and read what happened from the samples.

    python examples/06_trace_a_push.py [--duration 4] [--force 5] [--csv push.csv] [--plot push.png]

`LoopTrace.run` drives the loop exactly as `Locomotion.run` does and samples it (every 10 ms here): the body
against its plan, the push, the observer's estimate of it, and each foot's force as planned, commanded and measured
(`contactnet.jobs.trace`; the same as `contactnet simulate --trace`). The table's columns are `columns()`.
"""

from __future__ import annotations

import argparse

import numpy as np

from contactnet import Locomotion, registry
from contactnet.jobs.trace import LEGS, LoopTrace, TraceConfig, columns
from contactnet.sim.world import Push
from contactnet.terrain import flat

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--duration", type=float, default=4.0)
parser.add_argument("--force", type=float, default=5.0, help="N, toward the robot's left, for 0.5 s from 1 s")
parser.add_argument("--csv", default=None, help="also write the samples to this CSV file")
parser.add_argument("--plot", default=None, help="also draw them to this PNG file")
args = parser.parse_args()

robot = registry.load_robot("solo12")
gait = registry.gait_by_name("walk")
trace = LoopTrace(TraceConfig(every_ms=10))
with Locomotion(robot, flat(), gait, registry.make_planner("heuristic", gait, robot), vel_cmd_xy=(0.1, 0.0)) as loco:
    loco.push(Push(1.0, 0.5, (0.0, args.force, 0.0)))
    summary = trace.run(loco, args.duration)

table = trace.table()
col = {name: i for i, name in enumerate(columns())}
t = table[:, col["t_s"]]
print(f"trace: {len(table)} samples over {t[-1]:.2f} s; fell={summary['fell']}")
pushed = table[:, col["push_fy_n"]] > 0
estimate = table[:, col["push_estimate_fy_n"]]
reached = t[pushed & (estimate >= 0.63 * args.force)]
if reached.size:
    print(f"the observer's estimate reached 63 % of the {args.force:g} N push {reached[0] - 1.0:.3f} s after it began")
print(f"largest roll {np.abs(table[:, col['base_roll_rad']]).max():.3f} rad")
for leg in LEGS:
    lost = (table[:, col[f"{leg}_stance"]] == 1) & (table[:, col[f"{leg}_contact"]] == 0)
    print(f"{leg}: planned in stance but off the ground in {int(lost.sum())} samples, "
          f"measured force up to {table[:, col[f'{leg}_meas_fz_n']].max():.1f} N")
if args.csv:
    print("wrote", trace.write_csv(args.csv))
if args.plot:
    print("drew", trace.plot(args.plot, "Solo12 walks, pushed from the right"))
