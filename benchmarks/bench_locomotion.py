"""Locomotion quality on flat ground with the heuristic planner: the locomotion issue's target matrix.

    python benchmarks/bench_locomotion.py [--duration 60] [--workers 2]

Rows: walk and trot at (vx, vy) = (0.1, 0), (-0.1, 0), (0, 0.1), (0.05, -0.05) for `--duration`
simulated seconds; walking at 0.05 m/s with a 5 N push for 1 s along +x, -x, +y, -y; and walking
and trotting with joint-velocity noise of variance 0.01. Each row: fell, mean velocity vs command,
yaw drift, real-time factor, optimizer median.
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from contactnet.bench import format_table  # noqa: E402


def run_case(case: dict) -> dict:
    from contactnet.gait import gait_by_name
    from contactnet.locomotion import Locomotion
    from contactnet.planner import HeuristicPlanner
    from contactnet.robot import Solo12
    from contactnet.sim import Push, SimConfig
    from contactnet.terrain import flat

    gait = gait_by_name(case["gait"])
    vx, vy = case["vel"]
    with Locomotion(
        Solo12.load(),
        flat(),
        gait,
        HeuristicPlanner(gait),
        SimConfig(joint_vel_noise_var=case.get("noise", 0.0), seed=case.get("seed", 0)),
        vel_cmd_xy=(vx, vy),
    ) as loco:
        if "push" in case:
            loco.push(Push.parse(case["push"]))
        result = loco.run(case["duration"])
    mean_v = result["mean_velocity_xy"]
    speed_cmd = (vx**2 + vy**2) ** 0.5
    err = ((mean_v[0] - vx) ** 2 + (mean_v[1] - vy) ** 2) ** 0.5
    return {
        "case": case["name"],
        "fell": result["fell"],
        "sim_s": round(result["sim_time_s"], 2),
        "cmd": f"({vx:+.2f}, {vy:+.2f})",
        "mean_v": f"({mean_v[0]:+.3f}, {mean_v[1]:+.3f})",
        "vel_err_pct": 100 * err / speed_cmd if speed_cmd > 0 else 0.0,
        "yaw_drift_rad": result["max_abs_yaw_rad"],
        "rtf": result["sim_time_s"] / max(result["wall_time_s"], 1e-9),
        "trajopt_med_ms": result["trajopt_ms"]["median"],
        "trajopt_fail": result["trajopt_failures"],
        "fall_reason": result["fall_reason"] or "",
    }


def cases(duration: float) -> list[dict]:
    out = []
    for gait in ("walk", "trot"):
        for vel in ((0.1, 0.0), (-0.1, 0.0), (0.0, 0.1), (0.05, -0.05)):
            out.append({"name": f"{gait} {vel}", "gait": gait, "vel": vel, "duration": duration})
    for gait in ("walk", "trot"):
        for label, fx, fy in (("+x", 5, 0), ("-x", -5, 0), ("+y", 0, 5), ("-y", 0, -5)):
            out.append(
                {"name": f"{gait} push {label} 5N 1s", "gait": gait, "vel": (0.05, 0.0), "duration": 8.0,
                 "push": f"3.0,1.0,{fx},{fy}"}
            )
    for gait in ("walk", "trot"):
        out.append({"name": f"{gait} noise var 0.01", "gait": gait, "vel": (0.1, 0.0), "duration": duration,
                    "noise": 0.01, "seed": 1})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--only", default="", help="run only cases whose name contains this text")
    args = parser.parse_args()
    todo = [c for c in cases(args.duration) if args.only in c["name"]]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(run_case, todo))
    print(format_table(rows))


if __name__ == "__main__":
    main()
