"""Example problems of the SRBD trajectory optimizer and its benchmark (``contactnet bench trajopt``).

The example problems (a robot walking or trotting on flat ground, the feet landing under the hips) serve
the tests and the benchmark; the robot enters through its description.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from contactnet.bench.timing import pin_single_core
from contactnet.frames import rotation_z
from contactnet.motion.gait import horizon_schedule
from contactnet.motion.trajopt import (
    NX,
    SrbdModel,
    TrajectoryOptimizer,
    TrajoptConfig,
    TrajoptProblem,
)
from contactnet.motion.trajopt.model import N_LEGS
from contactnet.robots import DEFAULT_ROBOT, RobotDescription, load_robot

# ----------------------------------------------------------------------------------------------------
# Example problems (tests, benchmark)
# ----------------------------------------------------------------------------------------------------


def feet_under_hips(description: RobotDescription, com_pos: np.ndarray, yaw_rad: float = 0.0) -> np.ndarray:
    """Foot positions (4, 3) on the ground (z = 0) under the hips of a level robot with its CoM at
    ``com_pos`` (world) and heading ``yaw_rad``."""
    feet = np.asarray(com_pos, dtype=float) + description.hip_offsets_com @ rotation_z(yaw_rad).T
    feet[:, 2] = 0.0
    return feet


def example_problem(
    description: RobotDescription,
    swing_legs_per_step: Sequence[Sequence[int]],
    com_vel_ref_xy: Sequence[float] = (0.1, 0.0),
    x0: np.ndarray | None = None,
    com_height_m: float | None = None,
    foothold_offsets: np.ndarray | None = None,
    n_stance_pre: int = 3,
) -> TrajoptProblem:
    """A typical walking or trotting problem: the feet start under the hips; each swinging leg lands
    under its hip at the CoM position predicted (by the reference velocity) for the end of its step
    horizon, plus ``foothold_offsets[step, leg]`` (xy, optional). ``com_height_m`` (the reference CoM
    height, and that of the default ``x0``) defaults to the robot's nominal standing height."""
    if com_height_m is None:
        com_height_m = description.com_height_nominal_m
    contact = horizon_schedule(swing_legs_per_step, n_stance_pre=n_stance_pre)
    n_step = len(contact) // len(swing_legs_per_step)
    if x0 is None:
        x0 = np.zeros(NX)
        x0[2] = com_height_m
        x0[3:5] = com_vel_ref_xy
    x0 = np.asarray(x0, dtype=float)
    vel = np.asarray(com_vel_ref_xy, dtype=float)
    feet_now = feet_under_hips(description, x0[0:3], x0[8])
    feet = np.repeat(feet_now[None], len(contact), axis=0)
    for step, legs in enumerate(swing_legs_per_step):
        com_end = x0[0:3].copy()
        com_end[0:2] += vel * (step + 1) * n_step * 0.04
        landing = feet_under_hips(description, com_end, x0[8])
        for leg in legs:
            target = landing[leg].copy()
            if foothold_offsets is not None:
                target[0:2] += foothold_offsets[step, leg]
            touchdown = step * n_step + n_stance_pre  # first swing node: the foot is in the air from here
            feet[touchdown:, leg] = target
    return TrajoptProblem(
        x0=x0,
        contact=contact,
        foot_pos_world=feet,
        com_vel_ref_xy=vel,
        com_height_ref_m=com_height_m,
        yaw_ref_rad=float(x0[8]),
    )


def walk_candidates(
    description: RobotDescription, x0: np.ndarray, com_vel_ref_xy: Sequence[float], spacing_m: float = 0.05
) -> list[TrajoptProblem]:
    """The 100 walking candidates of a state (paper: 4 legs x 5 x 5 footholds, 5 cm apart, around the
    nominal landing point under the hip), one step horizon each."""
    grid = spacing_m * np.arange(-2, 3)
    problems = []
    for leg in range(N_LEGS):
        for dx in grid:
            for dy in grid:
                offsets = np.zeros((1, N_LEGS, 2))
                offsets[0, leg] = (dx, dy)
                problems.append(
                    example_problem(description, [(leg,)], com_vel_ref_xy, x0=x0, foothold_offsets=offsets)
                )
    return problems


def trot_candidates(
    description: RobotDescription, x0: np.ndarray, com_vel_ref_xy: Sequence[float], spacing_m: float = 0.05
) -> list[TrajoptProblem]:
    """The 162 trotting candidates of a state (paper: 2 diagonal pairs x 9 x 9 footholds, 3 x 3 per leg)."""
    grid = [(dx, dy) for dx in spacing_m * np.arange(-1, 2) for dy in spacing_m * np.arange(-1, 2)]
    problems = []
    for pair in ((0, 3), (1, 2)):
        for first in grid:
            for second in grid:
                offsets = np.zeros((1, N_LEGS, 2))
                offsets[0, pair[0]], offsets[0, pair[1]] = first, second
                problems.append(
                    example_problem(description, [pair], com_vel_ref_xy, x0=x0, foothold_offsets=offsets)
                )
    return problems


# ----------------------------------------------------------------------------------------------------
# Benchmark
# ----------------------------------------------------------------------------------------------------

WALK_STEPS = ((0,), (3,), (1,))
TROT_STEPS = ((0, 3), (1, 2), (0, 3))


def _perturbed_state(rng: np.random.Generator, vel: np.ndarray, height: float) -> np.ndarray:
    """A state near steady walking, as a running robot would measure it."""
    x0 = np.zeros(NX)
    x0[0:3] = rng.normal(0.0, 0.003, 3) + (0.0, 0.0, height)
    x0[3:5] = vel + rng.normal(0.0, 0.02, 2)
    x0[5] = rng.normal(0.0, 0.02)
    x0[6:9] = rng.normal(0.0, 0.01, 3)
    x0[9:12] = rng.normal(0.0, 0.05, 3)
    return x0


def _timing_row(name: str, times_s: Sequence[float], **extra: float) -> dict:
    t = 1e3 * np.asarray(times_s)
    return {"name": name, "median_ms": float(np.median(t)), "p99_ms": float(np.percentile(t, 99)), **extra}


def _bench_mpc(
    description: RobotDescription,
    steps: Sequence[Sequence[int]],
    solver: str,
    n_solves: int,
    rng: np.random.Generator,
) -> list[float]:
    """Warm-started solves of one horizon with the state and the velocity reference perturbed each time."""
    n = 8 * len(steps)
    opt = TrajectoryOptimizer(SrbdModel.for_robot(description), TrajoptConfig(n_nodes=n, solver=solver))
    height = description.com_height_nominal_m
    times = []
    for i in range(n_solves + 1):
        vel = np.array([0.1, 0.0]) + rng.normal(0.0, 0.01, 2)
        problem = example_problem(description, steps, vel, x0=_perturbed_state(rng, vel, height))
        t0 = time.perf_counter()
        sol = opt.solve(problem, warm_start=True)
        if i > 0:  # the first solve pays one-time imports
            times.append(time.perf_counter() - t0)
        if not sol.success:
            raise RuntimeError(f"benchmark solve failed: {sol.status}")
    return times


def _bench_batch(
    description: RobotDescription, gait: str, n_states: int, rng: np.random.Generator
) -> tuple[int, list[float]]:
    """Batched solves of all the candidates of ``n_states`` perturbed states."""
    opt = TrajectoryOptimizer(SrbdModel.for_robot(description), TrajoptConfig.for_candidates())
    make = walk_candidates if gait == "walk" else trot_candidates
    height = description.com_height_nominal_m
    times, size = [], 0
    for i in range(n_states + 1):
        vel = np.array([0.05, 0.0]) + rng.normal(0.0, 0.01, 2)
        problems = make(description, _perturbed_state(rng, vel, height), vel)
        t0 = time.perf_counter()
        sols = opt.solve_batch(problems)
        if i > 0:
            times.append(time.perf_counter() - t0)
        size = len(problems)
        if not all(s.success for s in sols):
            raise RuntimeError(f"benchmark batch failed: {[s.status for s in sols if not s.success][:3]}")
    return size, times


def benchmark(
    n_solves: int = 50, seed: int = 0, single_core: bool = True, robot_name: str = DEFAULT_ROBOT
) -> list[dict]:
    """Time the MPC-like solves and the candidate solves of a robot; rows of name, median_ms, p99_ms.

    24-node solves (walk and trot schedules) and single 8-node candidate solves are warm-started with the
    state and the velocity reference perturbed at every solve; the batched rows time all the candidates
    of a state at once and report per-candidate times (``batch_ms``, ``candidates_per_s``). With
    ``single_core`` the process is pinned to one CPU and torch to one thread while timing (both restored).
    """
    desc = load_robot(robot_name).description
    rng = np.random.default_rng(seed)
    restore = pin_single_core() if single_core else None
    try:
        rows = [
            _timing_row("24-node walk, auto (piqp QP)", _bench_mpc(desc, WALK_STEPS, "auto", n_solves, rng)),
            _timing_row("24-node trot, auto (piqp QP)", _bench_mpc(desc, TROT_STEPS, "auto", n_solves, rng)),
            _timing_row("24-node walk, qp-ipm", _bench_mpc(desc, WALK_STEPS, "qp-ipm", n_solves, rng)),
            _timing_row(
                "24-node walk, nlp-ipopt (reference)",
                _bench_mpc(desc, WALK_STEPS, "nlp-ipopt", n_solves, rng),
            ),
            _timing_row(
                "8-node candidate, auto (piqp QP)", _bench_mpc(desc, WALK_STEPS[:1], "auto", n_solves, rng)
            ),
            _timing_row(
                "8-node candidate, qp-proxqp", _bench_mpc(desc, WALK_STEPS[:1], "qp-proxqp", n_solves, rng)
            ),
            _timing_row(
                "8-node candidate, qp-ipm", _bench_mpc(desc, WALK_STEPS[:1], "qp-ipm", n_solves, rng)
            ),
        ]
        for gait in ("walk", "trot"):
            size, times = _bench_batch(desc, gait, max(3, n_solves // 10), rng)
            per = np.asarray(times) / size
            rows.append(
                _timing_row(
                    f"8-node {gait} candidates, batch of {size} (qp-ipm, tol 1e-6), per candidate",
                    per,
                    batch_ms=float(1e3 * np.median(times)),
                    candidates_per_s=float(1.0 / np.median(per)),
                )
            )
    finally:
        if restore is not None:
            restore()
    return rows
