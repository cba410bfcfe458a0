"""Benchmarks behind `contactnet bench ...` and `benchmarks/`: each returns rows (dicts) for a table.

Machines here are noisy: every figure is a median over repeats, and each benchmark measures a
reference in the same run so that ratios stay meaningful.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np


def median_p(values: list[float], p: float = 90) -> tuple[float, float]:
    arr = np.asarray(values, dtype=float)
    return float(np.median(arr)), float(np.percentile(arr, p))


def standing_real_time_factor(
    sim_seconds: float = 4.0, sphere_feet: bool = True, terrain_name: str = "flat", with_contacts: bool = False
) -> dict:
    """Simulate Solo12 standing under a joint PD at 1 kHz; return the real-time factor and the result.

    The loop reads the sensors a joint PD needs (and the foot contacts too with `with_contacts`).
    """
    from contactnet.robot import Solo12
    from contactnet.sim import SimConfig, Simulator, standing_torques
    from contactnet.terrain import resolve

    robot = Solo12.load()
    terrain = resolve(terrain_name)
    with Simulator(robot, terrain, SimConfig(sphere_feet=sphere_feet)) as sim:
        target = robot.joint_standing
        n = round(sim_seconds / sim.config.dt_s)
        state = sim.state(with_contacts)
        start = time.perf_counter()
        for _ in range(n):
            sim.step(standing_torques(state, target))
            state = sim.state(with_contacts)
        wall = time.perf_counter() - start
        fell = sim.fallen()
        height = float(state.base_pos_world[2] - terrain.surface_z)
    return {"rtf": sim_seconds / wall, "wall_s": wall, "fell": fell, "base_height_m": height}


def walking_real_time_factor(gait_name: str, sim_seconds: float = 6.4, vx: float = 0.1) -> dict:
    """The whole stack (heuristic planner, optimizer, 1 kHz controller, PyBullet) walking on flat."""
    from contactnet.gait import gait_by_name
    from contactnet.locomotion import Locomotion
    from contactnet.planner import HeuristicPlanner
    from contactnet.robot import Solo12
    from contactnet.terrain import resolve

    gait = gait_by_name(gait_name)
    with Locomotion(Solo12.load(), resolve("flat"), gait, HeuristicPlanner(gait), vel_cmd_xy=(vx, 0.0)) as loco:
        result = loco.run(sim_seconds)
    return {"rtf": result["sim_time_s"] / result["wall_time_s"], "fell": result["fell"],
            "trajopt_median_ms": result["trajopt_ms"]["median"], "planner_median_ms": result["planner_ms"]["median"]}


def bench_sim(runs: int = 5, sim_seconds: float = 4.0, stack_runs: int = 3) -> list[dict]:
    """Real-time factor of the standing simulation (joint PD at 1 kHz on `flat`).

    Rows: sphere feet (ours), sphere feet with foot-contact sensing every step, and the URDF's
    mesh feet as the reference measured in the same run (`vs_mesh_feet` is the ratio of medians).
    Runs are interleaved so that machine noise hits every variant alike.
    """
    variants = {
        "sphere feet": {"sphere_feet": True},
        "sphere feet + contact sensing": {"sphere_feet": True, "with_contacts": True},
        "mesh feet (reference)": {"sphere_feet": False},
    }
    rtfs: dict[str, list[float]] = {name: [] for name in variants}
    fell = dict.fromkeys(variants, False)
    for _ in range(runs):
        for name, kwargs in variants.items():
            result = standing_real_time_factor(sim_seconds, **kwargs)
            rtfs[name].append(result["rtf"])
            fell[name] |= result["fell"]
    reference = float(np.median(rtfs["mesh feet (reference)"]))
    stack_rows = []
    for gait_name in ("walk", "trot"):
        results = [walking_real_time_factor(gait_name) for _ in range(stack_runs)]
        values = [r["rtf"] for r in results]
        stack_rows.append(
            {
                "name": f"whole stack: {gait_name} 0.1 m/s on flat, heuristic planner",
                "median_rtf": float(np.median(values)),
                "min_rtf": float(np.min(values)),
                "max_rtf": float(np.max(values)),
                "vs_mesh_feet": float(np.median(values)) / reference,
                "runs": stack_runs,
                "sim_s_per_run": 6.4,
                "fell": any(r["fell"] for r in results),
                "trajopt_median_ms": float(np.median([r["trajopt_median_ms"] for r in results])),
            }
        )
    return stack_rows + [
        {
            "name": f"standing on flat, {name}, 1 kHz",
            "median_rtf": float(np.median(values)),
            "min_rtf": float(np.min(values)),
            "max_rtf": float(np.max(values)),
            "vs_mesh_feet": float(np.median(values)) / reference,
            "runs": runs,
            "sim_s_per_run": sim_seconds,
            "fell": fell[name],
        }
        for name, values in rtfs.items()
    ]


def bench_trajopt() -> list[dict]:
    from contactnet.trajopt import benchmark

    return benchmark()


def time_calls(fn: Callable[[], object], repeats: int, warmup: int = 10) -> list[float]:
    """Wall times (s) of `repeats` calls of fn after `warmup` untimed ones."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return times


def bench_terrain(repeats: int = 2000) -> list[dict]:
    from contactnet.terrain import benchmark_is_safe

    return benchmark_is_safe(repeats=repeats)


BENCHMARKS: dict[str, Callable[[], list[dict]]] = {
    "sim": bench_sim,
    "terrain": bench_terrain,
    "trajopt": bench_trajopt,
}
NOT_BUILT = {
    "planner": "the ContactNet planner (issue: ContactNet ranking, data generation, training)",
    "cost": "the ranking cost (issue: ContactNet ranking, data generation, training)",
}


def format_table(rows: list[dict]) -> str:
    """A plain aligned text table of rows with the union of their keys."""
    keys: list[str] = []
    for row in rows:
        keys += [k for k in row if k not in keys]

    def fmt(value: object) -> str:
        if isinstance(value, float):
            return f"{value:.4g}"
        return "" if value is None else str(value)

    cells = [[fmt(row.get(k)) for k in keys] for row in rows]
    widths = [max(len(k), *(len(c[i]) for c in cells)) for i, k in enumerate(keys)]
    lines = ["  ".join(k.ljust(w) for k, w in zip(keys, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in cells]
    return "\n".join(lines)
