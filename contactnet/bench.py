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


def walking_real_time_factor(gait_name: str, sim_seconds: float = 6.4, vx: float = 0.1,
                             planner_name: str = "heuristic", terrain_name: str = "flat") -> dict:
    """The whole stack (planner, optimizer, 1 kHz controller, PyBullet) walking on a terrain."""
    from contactnet.cli import make_planner
    from contactnet.gait import gait_by_name
    from contactnet.locomotion import Locomotion
    from contactnet.robot import Solo12
    from contactnet.terrain import resolve

    gait = gait_by_name(gait_name)
    robot = Solo12.load()
    planner = make_planner(planner_name, gait, robot)
    with Locomotion(robot, resolve(terrain_name), gait, planner, vel_cmd_xy=(vx, 0.0)) as loco:
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
    from contactnet.network import default_model_path

    stack_rows = []
    cases = [("walk", "heuristic", "flat", 0.1), ("trot", "heuristic", "flat", 0.1)]
    cases += [(gait, "contactnet", "stepping_stones", 0.05) for gait in ("walk", "trot")
              if default_model_path(gait).exists()]
    for gait_name, planner_name, terrain_name, vx in cases:
        results = [walking_real_time_factor(gait_name, vx=vx, planner_name=planner_name, terrain_name=terrain_name)
                   for _ in range(stack_runs)]
        values = [r["rtf"] for r in results]
        stack_rows.append(
            {
                "name": f"whole stack: {gait_name} {vx:g} m/s on {terrain_name}, {planner_name} planner",
                "median_rtf": float(np.median(values)),
                "min_rtf": float(np.min(values)),
                "max_rtf": float(np.max(values)),
                "vs_mesh_feet": float(np.median(values)) / reference,
                "runs": stack_runs,
                "sim_s_per_run": 6.4,
                "fell": any(r["fell"] for r in results),
                "trajopt_median_ms": float(np.median([r["trajopt_median_ms"] for r in results])),
                "planner_median_ms": float(np.median([r["planner_median_ms"] for r in results])),
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


def bench_cost() -> list[dict]:
    from contactnet.cost import benchmark
    from contactnet.robot import Solo12

    return benchmark(hip_ref_xy_base=Solo12.load().foot_nominal_base[:, :2])


def planning_contexts(gait, terrain, hip_ref_xy_base: np.ndarray, n: int, seed: int = 0) -> list:  # noqa: ANN001
    """``n`` walking states spread over the random field (x in 0.3..1.7 m), perturbed feet, random commands."""
    from contactnet.planner import PlanningContext, rotate_xy
    from contactnet.robot import FOOT_RADIUS_M

    rng = np.random.default_rng(seed)
    contexts = []
    for _ in range(n):
        base = np.array([rng.uniform(0.3, 1.7), rng.uniform(-0.05, 0.05)])
        yaw = float(rng.uniform(-0.1, 0.1))
        feet = np.zeros((4, 3))
        feet[:, :2] = base + rotate_xy(hip_ref_xy_base, yaw) + rng.uniform(-0.04, 0.04, (4, 2))
        feet[:, 2] = terrain.surface_z + FOOT_RADIUS_M
        cmd = rng.uniform(-0.1, 0.1, 2)
        vel = np.array([*rotate_xy(cmd, yaw), 0.0]) + rng.normal(0.0, 0.02, 3)
        contexts.append(PlanningContext(
            com_pos_world=np.array([base[0], base[1], terrain.surface_z + 0.215]), com_vel_world=vel,
            yaw_rad=yaw, foot_pos_world=feet, hip_ref_xy_base=np.asarray(hip_ref_xy_base, dtype=float),
            base_xy_world=base, vel_cmd_xy=cmd, terrain=terrain, gait=gait,
            rpy=np.array([0.0, 0.0, yaw]),
        ))
    return contexts


def bench_planner(repeats: int = 3000, n_contexts: int = 100, single_core: bool = False) -> list[dict]:
    """One planning call (3 network evaluations + safety checks) of ContactNet and the fixed gait, on the
    paper's random field with 0 and with 100 of its 300 squares removed; the ratio of the medians says
    whether planning time grows with terrain complexity. The network's forward pass alone is the
    reference in the same run. Uses the shipped models (random weights when a model is missing, said so
    in the ``model`` column). Planning is single-threaded; ``single_core`` also pins the process to CPU 0,
    which on this 2-core machine makes it slower whenever anything else runs there, so it is off."""
    from contactnet.cli import make_planner
    from contactnet.gait import TROT, WALK
    from contactnet.network import default_model_path, network_input
    from contactnet.robot import Solo12
    from contactnet.terrain import random_field
    from contactnet.trajopt import _pin_single_core

    robot = Solo12.load()
    hips = robot.foot_nominal_base[:, :2]
    restore = _pin_single_core() if single_core else None
    rows = []
    try:
        for gait in (WALK, TROT):
            path = default_model_path(gait.name)
            model = path if path.exists() else _random_model_file(gait)
            for name in ("contactnet", "fixed"):
                medians = {}
                for holes in (0, 100):
                    terrain = random_field(holes, 0)
                    contexts = planning_contexts(gait, terrain, hips, n_contexts)
                    planner = make_planner(name, gait, robot, model=model)
                    it = iter(range(10**9))
                    ranks: list[int] = []

                    def call(planner=planner, contexts=contexts, it=it, ranks=ranks) -> None:
                        steps = planner.plan(contexts[next(it) % len(contexts)])
                        if steps[0].rank is not None:
                            ranks.append(steps[0].rank)

                    times = np.asarray(time_calls(call, repeats)) * 1e6
                    medians[holes] = float(np.median(times))
                    rows.append({
                        "gait": gait.name, "planner": name, "holes": holes,
                        "median_us": medians[holes], "p99_us": float(np.percentile(times, 99)),
                        "vs_0_holes": medians[holes] / medians[0],
                        "mean_rank": float(np.mean(ranks)) if ranks else None,
                        "model": "shipped" if path.exists() else "random weights",
                    })
            net = planner.model  # the float32 network the planner calls
            u = network_input(planning_contexts(gait, random_field(0, 0), hips, 1)[0])
            times = np.asarray(time_calls(lambda net=net, u=u: net.scores(u), repeats)) * 1e6
            rows.append({"gait": gait.name, "planner": "network forward pass only (reference)", "holes": None,
                         "median_us": float(np.median(times)), "p99_us": float(np.percentile(times, 99))})
    finally:
        if restore is not None:
            restore()
    return rows


def _random_model_file(gait) -> str:  # noqa: ANN001
    """A model file with random weights (for timing only, when no trained model is shipped)."""
    import tempfile

    from contactnet.network import ContactNet, Normalizer, save_model

    rng = np.random.default_rng(0)
    folder = tempfile.mkdtemp(prefix="contactnet-bench-")
    u = np.column_stack([rng.uniform(-0.3, 0.3, (100, 8)), rng.uniform(0.18, 0.25, 100), rng.uniform(-0.1, 0.1, (100, 5))])
    path = f"{folder}/{gait.name}.pt"
    save_model(path, ContactNet(gait.n_actions), Normalizer.fit(u), {"gait": gait.name, "note": "random weights for timing"})
    return path


BENCHMARKS: dict[str, Callable[[], list[dict]]] = {
    "sim": bench_sim,
    "terrain": bench_terrain,
    "trajopt": bench_trajopt,
    "cost": bench_cost,
    "planner": bench_planner,
}
NOT_BUILT: dict[str, str] = {}


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
