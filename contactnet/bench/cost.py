"""`contactnet bench cost`: the ranking cost V of all candidates of a state (walk 100, trot 162)."""

from __future__ import annotations

import numpy as np


def benchmark(n_states: int = 20, seed: int = 0, single_core: bool = True, robot_name: str = "solo12") -> list[dict]:
    """Time ``RankingCost.evaluate`` for walk (100 candidates) and trot (162) on perturbed walking states:
    rows of gait, total_ms, optimizer_ms, rest_ms (medians per state). ``single_core`` pins the process to
    one CPU and torch to one thread while timing (as the trajopt benchmark)."""
    from contactnet.bench.timing import pin_single_core
    from contactnet.motion.gait import TROT, WALK
    from contactnet.planning.cost import RankingCost, nominal_state
    from contactnet.robots import load_robot

    robot = load_robot(robot_name).description
    rng = np.random.default_rng(seed)
    restore = pin_single_core() if single_core else None
    rows = []
    try:
        for gait in (WALK.scaled(robot.size_scale), TROT.scaled(robot.size_scale)):  # sized to the robot
            cost = RankingCost(gait, robot)
            times = []
            for i in range(n_states + 1):
                vel = rng.uniform(-0.1, 0.1, 2)
                state = nominal_state(robot, vel, foot_offsets_xy=rng.uniform(-0.04, 0.04, (4, 2)))
                result = cost.evaluate(state)
                if i > 0:  # the first evaluation pays one-time imports
                    times.append((result.total_s, result.optimizer_s))
            t = 1e3 * np.asarray(times)
            rows.append({
                "gait": gait.name,
                "candidates": gait.n_actions,
                "total_ms": float(np.median(t[:, 0])),
                "optimizer_ms": float(np.median(t[:, 1])),
                "rest_ms": float(np.median(t[:, 0] - t[:, 1])),
            })
    finally:
        if restore is not None:
            restore()
    return rows
