"""`contactnet bench locomotion`: walking quality on flat ground with the heuristic planner.

Rows: walk and trot at (vx, vy) = (0.1, 0), (-0.1, 0), (0, 0.1), (0.05, -0.05) for ``duration_s``
simulated seconds; walking at 0.05 m/s with a 5 N push for 1 s along +x, -x, +y, -y; and walking
and trotting with joint-velocity noise of variance 0.01. Each row: fell, mean velocity vs command,
yaw drift, real-time factor, optimizer median. Cases run in a process pool (``workers``).
"""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor

from contactnet.robots import DEFAULT_ROBOT


def run_case(case: dict) -> dict:
    from contactnet.locomotion import Locomotion
    from contactnet.planning.heuristic import HeuristicPlanner
    from contactnet.registry import gait_for, load_robot
    from contactnet.sim.world import Push, SimConfig
    from contactnet.terrain import flat

    terrain = flat()
    robot = load_robot(case.get("robot", DEFAULT_ROBOT)).for_terrain(terrain, case["gait"])
    gait = gait_for(case["gait"], robot)
    vx, vy = case["vel"]
    with Locomotion(
        robot,
        terrain,
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
        "case": f"{case.get('robot', DEFAULT_ROBOT)} {case['name']}",
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


def bench_locomotion(duration_s: float = 60.0, workers: int = 2, robot_name: str = DEFAULT_ROBOT,
                     only: str = "") -> list[dict]:
    """Every case of ``cases`` whose name contains ``only``, for one robot."""
    todo = [dict(c, robot=robot_name) for c in cases(duration_s) if only in c["name"]]
    with ProcessPoolExecutor(workers) as pool:
        return list(pool.map(run_case, todo))
