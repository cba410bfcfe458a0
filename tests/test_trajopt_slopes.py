"""Issue 30, item 2: the trajectory optimizer's friction pyramids about the ground's normal under each stance foot
(``TrajoptProblem.contact_normals_world``), in every solver: the fast paths (the batched interior-point method on
the condensed QP, piqp on the forces in contact coordinates) against the plain casadi reference (rows written with
the normals), on feet standing on a 15 degree ramp."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from contactnet.bench.trajopt import example_problem
from contactnet.motion.trajopt import (
    ProblemBatch,
    SrbdModel,
    TrajectoryOptimizer,
    TrajoptConfig,
    TrajoptProblem,
    TrajoptSolution,
    TrajoptWeights,
    dynamics_residual,
    trajectory_cost,
)
from contactnet.motion.trajopt.model import contact_frames
from contactnet.robots import RobotDescription

SLOPE_RAD = math.radians(15.0)
#: The ramp rises along +x: its normal leans back, towards -x.
RAMP_NORMAL = np.array([-math.sin(SLOPE_RAD), 0.0, math.cos(SLOPE_RAD)])
DT = 0.04


@pytest.fixture(scope="module")
def desc(robot) -> RobotDescription:
    return robot.description


@pytest.fixture(scope="module")
def model(desc: RobotDescription) -> SrbdModel:
    return SrbdModel.for_robot(desc)


@pytest.fixture(scope="module")
def optimizers(model: SrbdModel) -> dict[tuple[str, int], TrajectoryOptimizer]:
    return {(solver, n): TrajectoryOptimizer(model, TrajoptConfig(n_nodes=n, solver=solver))
            for solver in ("auto", "qp-ipm", "qp-piqp", "nlp-ipopt") for n in (8, 24)}


def on_ramp(problem: TrajoptProblem, push_x_n: float = 0.0) -> TrajoptProblem:
    """``problem`` with every foothold on the ramp (z = x tan 15 degrees, the ramp's normal under every foot) and the
    CoM as high over it; ``push_x_n`` a known force on the body along +x."""
    rise = math.tan(SLOPE_RAD)
    feet = problem.foot_pos_world.copy()
    feet[..., 2] = feet[..., 0] * rise
    x0 = problem.x0.copy()
    x0[2] += x0[0] * rise
    return dataclasses.replace(
        problem, x0=x0, foot_pos_world=feet, com_height_ref_m=problem.com_height_ref_m + x0[0] * rise,
        contact_normals_world=np.broadcast_to(RAMP_NORMAL, feet.shape).copy(),
        external_force_world=np.array([push_x_n, 0.0, 0.0]) if push_x_n else None)


def ramp_problems(desc: RobotDescription, model: SrbdModel) -> list[TrajoptProblem]:
    """Walk and trot on the ramp, one and three steps, at rest and pushed forward by 0.7 of the weight (the feet must
    push back harder than mu allows about +z)."""
    problems = []
    for steps in (((0,),), ((0, 3),), ((0,), (3,), (1,))):
        base = example_problem(desc, steps, (0.1, 0.0))
        problems += [on_ramp(base), on_ramp(base, 0.7 * model.weight_n)]
    return problems


def contact_coordinates(problem: TrajoptProblem, sol: TrajoptSolution) -> np.ndarray:
    """The solution's forces (N, 4, 3) in each foot's contact coordinates (t1, t2, n), from the normals plainly:
    ``n`` the normal, ``t1`` world x projected onto the ground, ``t2 = n x t1`` (yaw 0 here)."""
    n = np.asarray(problem.contact_normals_world, dtype=float)
    t1 = np.array([1.0, 0.0, 0.0]) - n[..., 0:1] * n
    t1 /= np.linalg.norm(t1, axis=-1, keepdims=True)
    t2 = np.cross(n, t1)
    f = sol.forces_world
    return np.stack([(f * t1).sum(-1), (f * t2).sum(-1), (f * n).sum(-1)], axis=-1)


def assert_pyramid_about_normals(model: SrbdModel, problem: TrajoptProblem, sol: TrajoptSolution,
                                 tol: float = 1e-6) -> None:
    f = contact_coordinates(problem, sol)
    stance = np.asarray(problem.contact, dtype=bool)
    assert np.all(np.abs(sol.forces_world[~stance]) <= tol)
    fn = f[..., 2][stance]
    assert np.all(fn >= -tol) and np.all(fn <= model.fz_max_n + tol)
    assert np.all(np.abs(f[..., 0][stance]) <= model.mu * fn + tol)
    assert np.all(np.abs(f[..., 1][stance]) <= model.mu * fn + tol)


def test_contact_frames_are_right_handed_about_the_normal() -> None:
    """The identity exactly for +z; otherwise orthonormal, right-handed, the normal its third column, t1 in the
    plane of x and the normal (the controller's convention)."""
    np.testing.assert_array_equal(contact_frames(np.array([0.0, 0.0, 1.0])), np.eye(3))
    rng = np.random.default_rng(3)
    normals = rng.normal(size=(50, 3)) + [0.0, 0.0, 2.0]
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    frames = contact_frames(normals)
    np.testing.assert_allclose(np.swapaxes(frames, 1, 2) @ frames, np.broadcast_to(np.eye(3), frames.shape),
                               atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(frames), 1.0, atol=1e-12)
    np.testing.assert_allclose(frames[..., 2], normals, atol=1e-15)
    t1 = frames[..., 0]  # x projected onto the plane: in the plane of x and the normal, along +x
    assert np.abs((np.cross([1.0, 0.0, 0.0], normals) * t1).sum(axis=1)).max() < 1e-12 and np.all(t1[:, 0] > 0.0)


def test_sloped_fast_paths_match_the_casadi_reference(optimizers, model: SrbdModel, desc: RobotDescription) -> None:
    """On the ramp the MPC solve (piqp on contact coordinates) and the batched interior-point method find the
    optimum of the casadi QP whose pyramid rows are written with the normals (qp-piqp): the same cost to solver
    tolerance, the same forces, inside the pyramids about the normals; the cost is ``trajectory_cost``'s."""
    for problem in ramp_problems(desc, model):
        n = len(problem.contact)
        ref = optimizers[("qp-piqp", n)].solve(problem, warm_start=False)
        assert ref.success, ref.status
        assert_pyramid_about_normals(model, problem, ref)
        for solver in ("auto", "qp-ipm"):
            fast = optimizers[(solver, n)].solve(problem, warm_start=False)
            assert fast.success, (solver, fast.status)
            assert math.isclose(fast.cost, ref.cost, rel_tol=1e-6), (solver, fast.cost, ref.cost)
            np.testing.assert_allclose(fast.forces_world, ref.forces_world, atol=5e-3)
            np.testing.assert_allclose(fast.x, ref.x, atol=1e-5)
            assert_pyramid_about_normals(model, problem, fast)
            assert math.isclose(fast.cost, trajectory_cost(TrajoptWeights(), problem, model, DT, fast.x,
                                                           fast.forces_world), rel_tol=1e-9)
            res = dynamics_residual(model, DT, fast.x, fast.forces_world, problem.foot_pos_world,
                                    problem.external_force_world)
            assert np.abs(res[:, 0:6]).max() < 1e-9


def test_the_nonlinear_reference_keeps_the_tilted_pyramids(optimizers, model: SrbdModel,
                                                           desc: RobotDescription) -> None:
    for problem in ramp_problems(desc, model)[:4]:
        sol = optimizers[("nlp-ipopt", len(problem.contact))].solve(problem, warm_start=False)
        assert sol.success, sol.status
        res = dynamics_residual(model, DT, sol.x, sol.forces_world, problem.foot_pos_world,
                                problem.external_force_world)
        assert np.abs(res).max() < 1e-7
        assert_pyramid_about_normals(model, problem, sol)


def test_tilted_normals_allow_forces_outside_the_vertical_pyramid(optimizers, model: SrbdModel,
                                                                  desc: RobotDescription) -> None:
    """Pushed forward by 0.7 of its weight on the ramp, the robot holds on with forces leaning back by more than
    atan(mu) from vertical: inside the pyramids about the ramp's normal (they reach atan(mu) + 15 degrees back),
    outside the vertical ones. With the normals left at +z the same problem keeps every force in the vertical
    pyramid and costs more (it cannot hold the push)."""
    for problem in ramp_problems(desc, model)[1::2]:
        n = len(problem.contact)
        stance = np.asarray(problem.contact, dtype=bool)
        vertical = dataclasses.replace(problem, contact_normals_world=None)
        for solver in ("auto", "qp-ipm", "qp-piqp"):
            tilted = optimizers[(solver, n)].solve(problem, warm_start=False)
            assert tilted.success, tilted.status
            assert_pyramid_about_normals(model, problem, tilted)
            f = tilted.forces_world[stance]
            assert np.max(-f[:, 0] / f[:, 2]) > model.mu + 0.05  # leaning back: outside the pyramid about +z
            flat = optimizers[(solver, n)].solve(vertical, warm_start=False)
            assert flat.success, flat.status
            f = flat.forces_world[stance]
            assert np.all(np.abs(f[:, 0:2]) <= model.mu * f[:, 2:3] + 1e-6)
            assert flat.cost > 1.2 * tilted.cost


def test_vertical_normals_are_the_flat_problem(optimizers, desc: RobotDescription) -> None:
    """Normals given as +z (as ``Terrain.normal_at`` gives them on a flat top) are no normals: the same batch and
    bit-for-bit the same solution; a normal of any length is made unit; a batch may mix problems with and without
    normals; a non-finite normal is a non-finite input."""
    problem = example_problem(desc, ((0,),), (0.1, 0.05))
    up = dataclasses.replace(problem, contact_normals_world=np.tile([-0.0, 0.0, 1.0], (8, 4, 1)))
    assert ProblemBatch.of([up], 8).normals is None
    for solver in ("auto", "qp-ipm"):
        a, b = optimizers[(solver, 8)].solve(problem), optimizers[(solver, 8)].solve(up)
        np.testing.assert_array_equal(a.forces_world, b.forces_world)
        assert a.cost == b.cost
    ramp = on_ramp(problem)
    longer = dataclasses.replace(ramp, contact_normals_world=3.0 * ramp.contact_normals_world)
    a, b = optimizers[("qp-ipm", 8)].solve(ramp), optimizers[("qp-ipm", 8)].solve(longer)
    np.testing.assert_allclose(a.forces_world, b.forces_world, atol=1e-9)
    batch = optimizers[("qp-ipm", 8)].solve_batch([problem, ramp])  # one without normals, one with
    for sol, alone in zip(batch, (optimizers[("qp-ipm", 8)].solve(problem), a), strict=True):
        np.testing.assert_allclose(sol.forces_world, alone.forces_world, atol=1e-7)
    bad = ramp.contact_normals_world.copy()
    bad[0, 0] = np.nan
    assert optimizers[("auto", 8)].solve(dataclasses.replace(ramp, contact_normals_world=bad)).status == (
        "error: non-finite input")
    with pytest.raises(ValueError, match="contact_normals_world"):
        optimizers[("auto", 8)].solve(dataclasses.replace(ramp, contact_normals_world=np.ones((4, 3))))


def test_sloped_solution_turns_with_the_heading(optimizers, model: SrbdModel, desc: RobotDescription) -> None:
    """The ramp, its normals and the robot turned by a yaw about the origin: the forces turn with them (the normals
    are taken into the heading frame), the cost stays."""
    yaw = 0.8
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    for problem in ramp_problems(desc, model)[:2]:
        x0 = problem.x0.copy()
        x0[0:3], x0[3:6], x0[8] = rot @ x0[0:3], rot @ x0[3:6], yaw
        turned = dataclasses.replace(
            problem, x0=x0, foot_pos_world=problem.foot_pos_world @ rot.T, yaw_ref_rad=yaw,
            com_vel_ref_xy=rot[0:2, 0:2] @ problem.com_vel_ref_xy,
            contact_normals_world=problem.contact_normals_world @ rot.T,
            external_force_world=None if problem.external_force_world is None else rot @ problem.external_force_world)
        for solver in ("auto", "qp-ipm"):
            a = optimizers[(solver, 8)].solve(problem, warm_start=False)
            b = optimizers[(solver, 8)].solve(turned, warm_start=False)
            assert a.success and b.success
            assert math.isclose(a.cost, b.cost, rel_tol=1e-7)
            np.testing.assert_allclose(b.forces_world, a.forces_world @ rot.T, atol=1e-5)


def test_the_loop_takes_the_normals_under_the_footholds() -> None:
    """``ground_normals`` (what the loop gives the MPC solve): the ramp's normal under a foot on it, +z on its flat
    landing; None on a terrain without sloped tops."""
    from contactnet.motion.ground import ground_normals
    from contactnet.terrain import resolve

    feet = np.array([[[1.8, 0.1, 0.04], [0.75, 0.0, 0.05]]])  # on the 15 degree ramp up, on the 10 degree landing
    normals = ground_normals(resolve("ramps"), feet)
    assert normals.shape == (1, 2, 3)
    np.testing.assert_allclose(normals[0, 0], RAMP_NORMAL, atol=1e-9)
    np.testing.assert_array_equal(np.abs(normals[0, 1]), [0.0, 0.0, 1.0])
    assert ground_normals(resolve("stepping_stones"), feet) is None


def test_an_optimizer_built_for_slopes_pickles_and_solves_alike(model: SrbdModel, desc: RobotDescription) -> None:
    """``tilted_normals=True`` (the loop on a terrain with sloped tops) builds the tilted MPC problem up front; the
    optimizer still pickles (a worker's copy) and the copy solves a ramp problem to the very same numbers."""
    import pickle

    opt = TrajectoryOptimizer(model, TrajoptConfig(n_nodes=8), tilted_normals=True)
    problem = on_ramp(example_problem(desc, ((0,),), (0.1, 0.0)))
    copy = pickle.loads(pickle.dumps(opt))
    a, b = opt.solve(problem), copy.solve(problem)
    assert a.success and b.success
    np.testing.assert_array_equal(a.forces_world, b.forces_world)


def test_the_ranking_cost_takes_the_normals_under_the_candidates(robot) -> None:
    """On a terrain with sloped tops (``CostState.normals_at``, from the planning context's terrain) every
    candidate's problem carries the normals under its footholds and its optimal cost is about them; a predicted
    state keeps them; on flat tops there are none (the problems of before)."""
    from contactnet.planning.cost import RankingCost, nominal_state, predicted_state
    from contactnet.registry import gait_for

    gait = gait_for("walk", robot)
    cost = RankingCost(gait, robot.description)
    flat = nominal_state(robot.description, vel_cmd_world=(0.1, 0.0))
    ramp = dataclasses.replace(flat, normals_at=lambda xy: np.tile(RAMP_NORMAL, (len(xy), 1)))
    assert all(p.contact_normals_world is None for p in cost.problems(flat))
    problems = cost.problems(ramp)
    assert len(problems) == cost.n_choices
    for problem in problems:
        np.testing.assert_array_equal(problem.contact_normals_world,
                                      np.broadcast_to(RAMP_NORMAL, problem.foot_pos_world.shape))
    v_flat, v_ramp = cost.evaluate(flat).terms[:, 0], cost.evaluate(ramp).terms[:, 0]
    assert np.all(np.isfinite(v_ramp)) and np.abs(v_ramp - v_flat).max() > 1e-6
    assert predicted_state(ramp, np.zeros(2), (0,), 0.32).normals_at is ramp.normals_at
