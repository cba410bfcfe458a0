"""`contactnet bench planner`: one planning call of ContactNet and the fixed gait, with and without holes."""

from __future__ import annotations

import numpy as np

from contactnet.bench.timing import pin_single_core, time_calls
from contactnet.registry import DEFAULT_ROBOT, load_robot, make_planner, model_path
from contactnet.robots import RobotDescription


def planning_contexts(gait, terrain, robot: RobotDescription, n: int, seed: int = 0) -> list:  # noqa: ANN001
    """``n`` walking states spread over the random field (x in 0.3..1.7 m), perturbed feet, random commands."""
    from contactnet.frames import rotate_xy
    from contactnet.planner import PlanningContext

    hip_ref_xy_base = robot.foot_nominal_base[:, :2]
    rng = np.random.default_rng(seed)
    contexts = []
    for _ in range(n):
        base = np.array([rng.uniform(0.3, 1.7), rng.uniform(-0.05, 0.05)])
        yaw = float(rng.uniform(-0.1, 0.1))
        feet = np.zeros((4, 3))
        feet[:, :2] = base + rotate_xy(hip_ref_xy_base, yaw) + rng.uniform(-0.04, 0.04, (4, 2))
        feet[:, 2] = terrain.ground_z(feet[:, :2]) + robot.foot_radius_m
        cmd = rng.uniform(-0.1, 0.1, 2)
        vel = np.array([*rotate_xy(cmd, yaw), 0.0]) + rng.normal(0.0, 0.02, 3)
        contexts.append(PlanningContext(
            com_pos_world=np.array([base[0], base[1], terrain.ground_z(base) + robot.com_height_nominal_m]), com_vel_world=vel,
            yaw_rad=yaw, foot_pos_world=feet, hip_ref_xy_base=np.asarray(hip_ref_xy_base, dtype=float),
            base_xy_world=base, vel_cmd_xy=cmd, terrain=terrain, gait=gait,
            rpy=np.array([0.0, 0.0, yaw]), com_height_ref_m=robot.com_height_nominal_m,
        ))
    return contexts


def bench_planner(repeats: int = 3000, n_contexts: int = 100, single_core: bool = False,
                  robot_name: str = DEFAULT_ROBOT) -> list[dict]:
    """One planning call (3 network evaluations + safety checks) of ContactNet and the fixed gait, on the
    paper's random field with 0 and with 100 of its 300 squares removed; the ratio of the medians says
    whether planning time grows with terrain complexity. The network's forward pass alone is the
    reference in the same run. Uses the shipped models (random weights when a model is missing, said so
    in the ``model`` column). Planning is single-threaded; ``single_core`` also pins the process to CPU 0,
    which on this 2-core machine makes it slower whenever anything else runs there, so it is off."""
    from contactnet.gait import TROT, WALK
    from contactnet.network_input import network_input_of_context
    from contactnet.terrain import random_field

    robot = load_robot(robot_name)
    description = robot.description
    restore = pin_single_core() if single_core else None
    rows = []
    try:
        for gait in (WALK, TROT):
            path = model_path(robot_name, gait.name)
            model = path if path.exists() else _random_model_file(gait, robot_name)
            for name in ("contactnet", "fixed"):
                medians = {}
                for holes in (0, 100):
                    terrain = random_field(holes, 0)
                    contexts = planning_contexts(gait, terrain, description, n_contexts)
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
            u = network_input_of_context(planning_contexts(gait, random_field(0, 0), description, 1)[0])
            times = np.asarray(time_calls(lambda net=net, u=u: net.scores(u), repeats)) * 1e6
            rows.append({"gait": gait.name, "planner": "network forward pass only (reference)", "holes": None,
                         "median_us": float(np.median(times)), "p99_us": float(np.percentile(times, 99))})
    finally:
        if restore is not None:
            restore()
    return rows


def _random_model_file(gait, robot_name: str) -> str:  # noqa: ANN001
    """A model file with random weights (for timing only, when no trained model is shipped)."""
    import tempfile

    from contactnet.network import ContactNet, Normalizer, save_model

    rng = np.random.default_rng(0)
    folder = tempfile.mkdtemp(prefix="contactnet-bench-")
    u = np.column_stack([rng.uniform(-0.3, 0.3, (100, 8)), rng.uniform(0.18, 0.25, 100), rng.uniform(-0.1, 0.1, (100, 5))])
    path = f"{folder}/{gait.name}.pt"
    save_model(path, ContactNet(gait.n_actions), Normalizer.fit(u), {"gait": gait.name, "robot": robot_name, "note": "random weights for timing"})
    return path
