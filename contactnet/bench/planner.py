"""`contactnet bench planner`: one planning call of ContactNet and the fixed gait, with and without holes, on the
paper's random field and on the same field with heights (``random_heights``, tops within +-3 cm)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from contactnet.bench.timing import pin_single_core, time_calls
from contactnet.registry import DEFAULT_ROBOT, load_robot, make_planner, model_path
from contactnet.robots import RobotDescription

#: The terrains of the benchmark, in the order of the table: the paper's flat random field first (the rows this
#: benchmark always had), then the same field with each square's top within +-3 cm.
TERRAINS = ("random", "random_heights")
HOLES = (0, 100)


def planning_contexts(gait, terrain, robot: RobotDescription, n: int, seed: int = 0) -> list:  # noqa: ANN001
    """``n`` walking states spread over the random field (x in 0.3..1.7 m), perturbed feet, random commands.

    Each foot stands on the top under it (``Terrain.ground_z``: the nominal ground over a hole) and the CoM at
    the nominal height over the feet's support (``contactnet.motion.ground.support_height``), as the locomotion loop
    holds it; on a flat terrain both are ``surface_z``."""
    from contactnet.frames import rotate_xy
    from contactnet.motion.ground import support_height
    from contactnet.planning.planner import PlanningContext

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
        com_z = support_height(terrain, feet[:, :2]) + robot.com_height_nominal_m
        contexts.append(PlanningContext(
            com_pos_world=np.array([base[0], base[1], com_z]), com_vel_world=vel,
            yaw_rad=yaw, foot_pos_world=feet, hip_ref_xy_base=np.asarray(hip_ref_xy_base, dtype=float),
            base_xy_world=base, vel_cmd_xy=cmd, terrain=terrain, gait=gait,
            rpy=np.array([0.0, 0.0, yaw]), com_height_ref_m=robot.com_height_nominal_m,
        ))
    return contexts


#: Calls of one configuration timed in a row before the next configuration's turn (``bench_planner``).
CHUNK = 25


#: The row of ContactNet with ``roll=None`` (``contactnet.planning.roll``).
NO_ROLL = "contactnet, roll room off"
#: The row of ContactNet making each step in Python (``contactnet.planning.plan_kernel`` off): the same plans.
IN_PYTHON = "contactnet, steps in Python"


def bench_planner(repeats: int = 3000, n_contexts: int = 100, single_core: bool = False,
                  robot_name: str = DEFAULT_ROBOT, terrains: tuple[str, ...] = TERRAINS) -> list[dict]:
    """One planning call (3 network evaluations + safety checks) of ContactNet and the fixed gait, on the
    paper's random field with 0 and with 100 of its 300 squares removed; the ratio of the medians says
    whether planning time grows with terrain complexity. The network's forward pass alone is the
    reference in the same run. Then the same on ``random_heights`` (the field with each square's top within
    +-3 cm), where the planner adds the height checks (``contactnet.planning.footholds``); its ``vs_0_holes`` is against
    ``random_heights`` with 0 removed, its ``vs_flat`` against the flat field with as many removed (same gait and
    planner). Uses the shipped models (random weights when a model is missing, said so in the ``model`` column).

    Every configuration is timed in turns of ``CHUNK`` calls, round after round, so that a change of the machine's
    load during the run weighs on all of them alike and the ratios stay meaningful. Planning is single-threaded;
    ``single_core`` also pins the process to CPU 0, which on this 2-core machine makes it slower whenever anything
    else runs there, so it is off."""
    from contactnet.motion.gait import TROT, WALK
    from contactnet.planning.network_input import network_input_of_context
    from contactnet.terrain import random_field, resolve

    robot = load_robot(robot_name)
    description = robot.description
    restore = pin_single_core() if single_core else None
    rows: list[dict] = []
    timed: list[tuple[dict, Callable[[], object]]] = []  # (row, one call) in the table's order
    try:
        for terrain_name in terrains:
            for gait in (WALK.scaled(description.size_scale), TROT.scaled(description.size_scale)):  # sized
                path = model_path(robot_name, gait.name)
                model = path if path.exists() else _random_model_file(gait, robot_name)
                # and, on the flat field, ContactNet without the room for the foot's roll and with its steps made in
                # Python (the costs of each, as ratios)
                names = ("contactnet", "fixed", *((NO_ROLL, IN_PYTHON) if terrain_name == TERRAINS[0] else ()))
                for name in names:
                    for holes in HOLES:
                        terrain = resolve(terrain_name, removed=holes, seed=0)
                        contexts = planning_contexts(gait, terrain, description, n_contexts)
                        planner = make_planner("contactnet" if name in (NO_ROLL, IN_PYTHON) else name, gait, robot,
                                               model=model)
                        if name == NO_ROLL:
                            planner.roll = None
                        if name == IN_PYTHON:
                            planner._one_level = None
                        row = {"gait": gait.name, "planner": name, "terrain": terrain_name, "holes": holes,
                               "model": "shipped" if path.exists() else "random weights", "ranks": []}
                        timed.append((row, _plan_call(planner, contexts, row["ranks"])))
                        rows.append(row)
                if terrain_name == TERRAINS[0]:
                    net = planner.model  # the float32 network the planner calls
                    u = network_input_of_context(planning_contexts(gait, random_field(0, 0), description, 1)[0])
                    row = {"gait": gait.name, "planner": "network forward pass only (reference)", "holes": None}
                    timed.append((row, lambda net=net, u=u: net.scores(u)))
                    rows.append(row)
        times = _time_in_turns([call for _, call in timed], repeats)
    finally:
        if restore is not None:
            restore()
    medians = {}
    for (row, _), row_times in zip(timed, times, strict=True):
        row["median_us"] = median = float(np.median(row_times))
        row["p99_us"] = float(np.percentile(row_times, 99))
        medians[row.get("terrain"), row["gait"], row["planner"], row["holes"]] = median
    for row in rows:
        if row["holes"] is None:
            continue
        key = (row["terrain"], row["gait"], row["planner"])
        row["vs_0_holes"] = row["median_us"] / medians[(*key, HOLES[0])]
        flat = medians.get((TERRAINS[0], *key[1:], row["holes"]), math.nan)
        row["vs_flat"] = None if row["terrain"] == TERRAINS[0] else row["median_us"] / flat
        ranks = row.pop("ranks")
        row["mean_rank"] = float(np.mean(ranks)) if ranks else None
        row["model"] = row.pop("model")
    return rows


def _plan_call(planner, contexts: list, ranks: list[int]) -> Callable[[], None]:  # noqa: ANN001
    """One ``plan`` call, cycling through ``contexts``; the rank of each first step goes to ``ranks``."""
    it = iter(range(10**12))

    def call() -> None:
        steps = planner.plan(contexts[next(it) % len(contexts)])
        if steps[0].rank is not None:
            ranks.append(steps[0].rank)

    return call


def _time_in_turns(calls: list[Callable[[], object]], repeats: int, warmup: int = 10) -> list[np.ndarray]:
    """Wall times (us) of ``repeats`` calls of each of ``calls`` (after ``warmup`` untimed ones each), ``CHUNK`` calls
    of each in turn."""
    for call in calls:
        for _ in range(warmup):
            call()
    times: list[list[float]] = [[] for _ in calls]
    done = 0
    while done < repeats:
        chunk = min(CHUNK, repeats - done)
        for call, call_times in zip(calls, times, strict=True):
            call_times += time_calls(call, chunk, warmup=0)
        done += chunk
    return [np.asarray(call_times) * 1e6 for call_times in times]


def _random_model_file(gait, robot_name: str) -> str:  # noqa: ANN001
    """A model file with random weights (for timing only, when no trained model is shipped)."""
    import tempfile

    from contactnet.planning.network import ContactNet, Normalizer, save_model

    rng = np.random.default_rng(0)
    folder = tempfile.mkdtemp(prefix="contactnet-bench-")
    u = np.column_stack([rng.uniform(-0.3, 0.3, (100, 8)), rng.uniform(0.18, 0.25, 100), rng.uniform(-0.1, 0.1, (100, 5))])
    path = f"{folder}/{gait.name}.pt"
    save_model(path, ContactNet(gait.n_actions), Normalizer.fit(u), {"gait": gait.name, "robot": robot_name, "note": "random weights for timing"})
    return path
