"""`contactnet bench sim`: real-time factors of both physics engines (PyBullet, MuJoCo) standing, and of the whole
stack walking in each (the MuJoCo rows give their ratio to PyBullet's in the same run, ``vs_pybullet``)."""

from __future__ import annotations

import time

import numpy as np

from contactnet.registry import DEFAULT_ROBOT, gait_for, load_robot, make_planner, model_path

#: Simulated seconds of each whole-stack run.
STACK_SECONDS = 6.4


def standing_real_time_factor(
    sim_seconds: float = 4.0, sphere_feet: bool = True, terrain_name: str = "flat", with_contacts: bool = False,
    robot_name: str = DEFAULT_ROBOT, engine: str = "pybullet",
) -> dict:
    """Simulate a robot standing under a joint PD at 1 kHz in ``engine``; return the real-time factor and the result.

    The loop reads the sensors a joint PD needs (and the foot contacts too with `with_contacts`).
    """
    from contactnet.sim.engines import make_simulator
    from contactnet.sim.world import SimConfig, standing_torques
    from contactnet.terrain import resolve

    robot = load_robot(robot_name)
    terrain = resolve(terrain_name)
    with make_simulator(robot, terrain, SimConfig(sphere_feet=sphere_feet, engine=engine)) as sim:
        target = robot.joint_standing
        n = round(sim_seconds / sim.config.dt_s)
        state = sim.state(with_contacts)
        start = time.perf_counter()
        for _ in range(n):
            sim.step(standing_torques(state, target))
            state = sim.state(with_contacts)
        wall = time.perf_counter() - start
        fell = sim.fallen()
        height = float(state.base_pos_world[2] - terrain.ground_z(state.base_pos_world[:2]))
    return {"rtf": sim_seconds / wall, "wall_s": wall, "fell": fell, "base_height_m": height}


def walking_real_time_factor(gait_name: str, sim_seconds: float = STACK_SECONDS, vx: float = 0.1,
                             planner_name: str = "heuristic", terrain_name: str = "flat",
                             robot_name: str = DEFAULT_ROBOT, engine: str = "pybullet") -> dict:
    """The whole stack (planner, optimizer, 1 kHz controller, the physics of ``engine``) walking on a terrain."""
    from contactnet.locomotion import Locomotion
    from contactnet.sim.world import SimConfig
    from contactnet.terrain import resolve

    terrain = resolve(terrain_name)
    robot = load_robot(robot_name).for_terrain(terrain, gait_name)
    gait = gait_for(gait_name, robot)
    planner = make_planner(planner_name, gait, robot)
    with Locomotion(robot, terrain, gait, planner, SimConfig(engine=engine), vel_cmd_xy=(vx, 0.0)) as loco:
        result = loco.run(sim_seconds)
    return {"rtf": result["sim_time_s"] / result["wall_time_s"], "fell": result["fell"],
            "trajopt_median_ms": result["trajopt_ms"]["median"], "planner_median_ms": result["planner_ms"]["median"]}


def bench_sim(runs: int | None = None, sim_seconds: float = 4.0, robot_name: str = DEFAULT_ROBOT) -> list[dict]:
    """Real-time factors of both engines: standing (joint PD at 1 kHz on `flat`) and the whole stack walking;
    ``runs`` of each row (None: 5 standing, 3 of the whole stack).

    Standing rows: PyBullet with sphere feet (ours), with foot-contact sensing every step, and the URDF's mesh feet
    as the reference measured in the same run (`vs_mesh_feet` is the ratio of medians); MuJoCo with sphere feet,
    with and without contact sensing. Whole-stack rows: each case in PyBullet, then in MuJoCo with its ratio to
    PyBullet's median (`vs_pybullet`). Runs are interleaved so that machine noise hits every variant alike.
    """
    variants = {
        "sphere feet": {"sphere_feet": True},
        "sphere feet + contact sensing": {"sphere_feet": True, "with_contacts": True},
        "mesh feet (reference)": {"sphere_feet": False},
        "MuJoCo, sphere feet": {"sphere_feet": True, "engine": "mujoco"},
        "MuJoCo, sphere feet + contact sensing": {"sphere_feet": True, "with_contacts": True, "engine": "mujoco"},
    }
    stand_runs, stack_runs = (5, 3) if runs is None else (runs, runs)
    rtfs: dict[str, list[float]] = {name: [] for name in variants}
    fell = dict.fromkeys(variants, False)
    for _ in range(stand_runs):
        for name, kwargs in variants.items():
            result = standing_real_time_factor(sim_seconds, robot_name=robot_name, **kwargs)
            rtfs[name].append(result["rtf"])
            fell[name] |= result["fell"]
    reference = float(np.median(rtfs["mesh feet (reference)"]))
    stack_rows = []
    cases = [("walk", "heuristic", "flat", 0.1), ("trot", "heuristic", "flat", 0.1)]
    cases += [(gait, "contactnet", "stepping_stones", 0.05) for gait in ("walk", "trot")
              if model_path(robot_name, gait).exists()]
    for gait_name, planner_name, terrain_name, vx in cases:
        results: dict[str, list[dict]] = {"pybullet": [], "mujoco": []}
        for _ in range(stack_runs):
            for engine, runs_of in results.items():
                runs_of.append(walking_real_time_factor(gait_name, vx=vx, planner_name=planner_name,
                                                        terrain_name=terrain_name, robot_name=robot_name,
                                                        engine=engine))
        what = f"{gait_name} {vx:g} m/s on {terrain_name}, {planner_name} planner"
        pybullet_median = float(np.median([r["rtf"] for r in results["pybullet"]]))
        for engine, engine_results in results.items():
            values = [r["rtf"] for r in engine_results]
            name = f"{robot_name} whole stack: {what}" if engine == "pybullet" else f"{robot_name} whole stack in MuJoCo: {what}"
            stack_rows.append({
                **_rtf_row(name, values, reference, STACK_SECONDS),
                "vs_pybullet": float(np.median(values)) / pybullet_median,
                "fell": any(r["fell"] for r in engine_results),
                "trajopt_median_ms": float(np.median([r["trajopt_median_ms"] for r in engine_results])),
                "planner_median_ms": float(np.median([r["planner_median_ms"] for r in engine_results])),
            })
    return stack_rows + [
        {**_rtf_row(f"{robot_name} standing on flat, {name}, 1 kHz", values, reference, sim_seconds), "fell": fell[name]}
        for name, values in rtfs.items()
    ]


def _rtf_row(name: str, rtfs: list[float], reference: float, sim_seconds: float) -> dict:
    """A table row of real-time factors: median, range, ratio to the reference, runs and their length."""
    return {"name": name, "median_rtf": float(np.median(rtfs)), "min_rtf": float(np.min(rtfs)),
            "max_rtf": float(np.max(rtfs)), "vs_mesh_feet": float(np.median(rtfs)) / reference, "runs": len(rtfs),
            "sim_s_per_run": sim_seconds}
