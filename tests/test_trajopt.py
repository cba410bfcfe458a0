"""Tests of the SRBD trajectory optimizer (contactnet.motion.trajopt)."""

from __future__ import annotations

import dataclasses
import math
import pickle

import numpy as np
import pytest

from contactnet.bench import format_table
from contactnet.bench.trajopt import example_problem, trot_candidates, walk_candidates
from contactnet.motion import trajopt as T
from contactnet.motion.gait import horizon_schedule, step_schedule
from contactnet.motion.trajopt import (
    ProblemBatch,
    SrbdModel,
    TrajectoryOptimizer,
    TrajoptConfig,
    TrajoptProblem,
    TrajoptSolution,
    TrajoptWeights,
    dynamics_residual,
    reference_forces,
    srbd_step,
    trajectory_cost,
)
from contactnet.motion.trajopt.casadi_ref import _casadi_step
from contactnet.robots import RobotDescription

WALK = ((0,), (3,), (1,))
TROT = ((0, 3), (1, 2), (0, 3))
DT = 0.04


@pytest.fixture(scope="module")
def desc(robot) -> RobotDescription:
    return robot.description


@pytest.fixture(scope="module")
def model(desc: RobotDescription) -> SrbdModel:
    return SrbdModel.for_robot(desc)


@pytest.fixture(scope="module")
def optimizers(model: SrbdModel) -> dict[tuple[str, int], TrajectoryOptimizer]:
    """One optimizer per (solver, horizon), built once for the module."""
    return {
        (solver, n): TrajectoryOptimizer(model, TrajoptConfig(n_nodes=n, solver=solver))
        for solver in ("auto", "qp-ipm", "nlp-ipopt")
        for n in (8, 24)
    }


def moving_state(yaw: float = 0.0, tilt: float = 0.01) -> np.ndarray:
    """A walking state a little off the reference (position, velocity, tilt, angular velocity)."""
    x0 = np.zeros(12)
    x0[0:3] = (0.3, -0.2, 0.21)
    x0[3:6] = (0.08, 0.02, 0.01)
    x0[6:9] = (tilt, -tilt, yaw)
    x0[9:12] = (0.05, -0.05, 0.02)
    return x0


def typical_problems(desc: RobotDescription) -> list[TrajoptProblem]:
    """Typical walk and trot problems, one and three step horizons, at two headings."""
    problems = []
    for steps in (WALK, TROT, WALK[:1], TROT[:1]):
        for yaw in (0.0, 0.7):
            problems.append(example_problem(desc, steps, (0.1, 0.05), x0=moving_state(yaw)))
    return problems


def heading_forces(problem: TrajoptProblem, sol: TrajoptSolution) -> np.ndarray:
    """Forces in the heading frame (where the friction pyramids are aligned)."""
    c, s = math.cos(problem.yaw_ref_rad), math.sin(problem.yaw_ref_rad)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return sol.forces_world @ rot


def assert_force_constraints(
    model: SrbdModel, problem: TrajoptProblem, sol: TrajoptSolution, tol: float = 1e-6
) -> None:
    """Friction pyramid, unilateral and bounded normal force on stance feet; no force on swing feet."""
    f = heading_forces(problem, sol)
    stance = np.asarray(problem.contact, dtype=bool)
    fz = f[..., 2]
    assert np.all(np.abs(f[~stance]) <= tol)
    assert np.all(fz[stance] >= -tol)
    assert np.all(fz[stance] <= model.fz_max_n + tol)
    assert np.all(np.abs(f[..., 0]) <= model.mu * fz + tol)
    assert np.all(np.abs(f[..., 1]) <= model.mu * fz + tol)


# --- schedules and references --------------------------------------------------------------------


def test_step_schedule_walk_and_trot() -> None:
    walk = step_schedule((2,))
    assert walk.shape == (8, 4)
    assert walk[:3].all() and walk[7].all()
    assert not walk[3:7, 2].any() and walk[3:7, [0, 1, 3]].all()
    trot = step_schedule((0, 3))
    assert (~trot).sum() == 8 and not trot[3:7, [0, 3]].any()
    horizon = horizon_schedule([(0,), (1, 2), (3,)])
    assert horizon.shape == (24, 4)
    assert (~horizon).sum(axis=0).tolist() == [4, 4, 4, 4]
    with pytest.raises(ValueError):
        step_schedule((4,))


def test_reference_forces_share_the_weight(model: SrbdModel) -> None:
    contact = horizon_schedule(WALK)
    contact[5] = False  # a flight node
    f = reference_forces(contact, model.mass_kg, model.gravity)
    total = f.sum(axis=1)
    assert np.allclose(total[contact.any(axis=1), 2], model.weight_n)
    assert np.allclose(total[5], 0.0)
    assert np.allclose(f[~contact], 0.0) and np.allclose(f[..., 0:2], 0.0)


# --- models ----------------------------------------------------------------------------------------


def test_model_comes_from_the_robot_description(desc: RobotDescription) -> None:
    model = SrbdModel.for_robot(desc, gravity=9.8, mu=0.5)
    assert model.mass_kg == desc.mass_kg and model.gravity == 9.8 and model.mu == 0.5
    assert np.array_equal(model.inertia_matrix(), desc.inertia_com_standing)
    assert model.fz_max_n == 2.0 * desc.mass_kg * 9.8  # twice the weight
    assert model.com_height_band_m == 0.1
    with pytest.raises(TypeError):
        SrbdModel()  # no robot defaults


def test_numpy_and_casadi_nonlinear_steps_agree(model: SrbdModel) -> None:
    import casadi as ca

    rng = np.random.default_rng(0)
    x, f = ca.SX.sym("x", 12), ca.SX.sym("f", 12)
    feet, ext = ca.SX.sym("r", 12), ca.SX.sym("ext", 3)
    step = ca.Function("step", [x, f, feet, ext], [_casadi_step(model, DT, x, f, feet, 1.0, ca.DM.zeros(3), ext)])
    for k in range(6):
        x0 = rng.normal(0.0, 0.3, 12)
        forces, footholds = rng.normal(5.0, 3.0, (4, 3)), rng.normal(0.0, 0.2, (4, 3))
        push = rng.normal(0.0, 5.0, 3) if k % 2 else None  # an external force at the CoM, or none
        expected = srbd_step(model, DT, x0, forces, footholds, push)
        got = np.asarray(step(x0, forces.ravel(), footholds.ravel(), np.zeros(3) if push is None else push)).ravel()
        assert np.allclose(got, expected, atol=1e-12)


def test_linearized_model_is_first_order_accurate(model: SrbdModel, desc: RobotDescription) -> None:
    """The condensed linear model matches the nonlinear step to second order around the reference."""
    rng = np.random.default_rng(1)
    base = example_problem(desc, [()], (0.0, 0.0))
    f_ref = reference_forces(base.contact, model.mass_kg, model.gravity)
    df, dx = rng.normal(size=f_ref.shape), rng.normal(size=12)
    errors = []
    for eps in (1e-2, 1e-3):
        problem = example_problem(desc, [()], (0.0, 0.0), x0=base.x0 + eps * dx)
        qp = T.build_condensed_qp(model, TrajoptWeights(), DT, [problem])
        forces = f_ref + eps * df
        linear = qp.states(forces[None])[0]
        x = [problem.x0]
        for k in range(8):
            x.append(srbd_step(model, DT, x[-1], forces[k], problem.foot_pos_world[k]))
        errors.append(np.abs(linear - np.array(x)).max())
    assert errors[1] < errors[0] / 50.0  # quadratic: 100x smaller for 10x smaller deviations


# --- solutions -------------------------------------------------------------------------------------


def test_nonlinear_reference_is_dynamically_exact(optimizers, model: SrbdModel, desc: RobotDescription) -> None:
    for problem in typical_problems(desc)[:4]:
        sol = optimizers[("nlp-ipopt", len(problem.contact))].solve(problem, warm_start=False)
        assert sol.success, sol.status
        res = dynamics_residual(model, DT, sol.x, sol.forces_world, problem.foot_pos_world)
        assert np.abs(res).max() < 1e-7
        assert_force_constraints(model, problem, sol)


@pytest.mark.parametrize("solver", ["auto", "qp-ipm"])
def test_fast_path_constraints_and_dynamics(
    optimizers, model: SrbdModel, desc: RobotDescription, solver: str
) -> None:
    for problem in typical_problems(desc):
        sol = optimizers[(solver, len(problem.contact))].solve(problem)
        assert sol.success, sol.status
        assert sol.x.shape == (len(problem.contact) + 1, 12) and sol.forces_world.shape == (
            len(problem.contact),
            4,
            3,
        )
        assert_force_constraints(model, problem, sol)
        res = np.abs(dynamics_residual(model, DT, sol.x, sol.forces_world, problem.foot_pos_world))
        assert res[:, 0:6].max() < 1e-9  # translation is exact in the linearized model
        assert res[:, 6:9].max() < 1e-3  # rad, rotation linearized about level orientation
        assert res[:, 9:12].max() < 0.05  # rad/s
        assert math.isclose(
            sol.cost,
            trajectory_cost(TrajoptWeights(), problem, model, DT, sol.x, sol.forces_world),
            rel_tol=1e-9,
        )


def test_fast_path_agrees_with_nonlinear_reference(optimizers, desc: RobotDescription) -> None:
    for problem in typical_problems(desc):
        n = len(problem.contact)
        ref = optimizers[("nlp-ipopt", n)].solve(problem, warm_start=False)
        for solver in ("auto", "qp-ipm"):
            fast = optimizers[(solver, n)].solve(problem)
            assert np.abs(fast.x[:, 0:3] - ref.x[:, 0:3]).max() < 3e-3  # CoM within 3 mm
            assert abs(fast.cost - ref.cost) < 0.03 * ref.cost  # cost within 3 %


def test_a_known_push_enters_every_solver_alike(optimizers, model: SrbdModel, desc: RobotDescription) -> None:
    """A known external force at the CoM (TrajoptProblem.external_force_world): the nonlinear reference is exact
    with it, the fast paths agree with the reference and with each other, the cost is the same function, and the
    plan holds the body against the push (the stance feet push back; without it the body drifts away)."""
    push = np.array([1.0, 5.0, 0.0])  # N, mostly sideways (Solo12 weighs ~25 N)
    for base in typical_problems(desc)[:4]:
        problem = dataclasses.replace(base, external_force_world=push)
        n = len(problem.contact)
        ref = optimizers[("nlp-ipopt", n)].solve(problem, warm_start=False)
        assert ref.success, ref.status
        assert np.abs(dynamics_residual(model, DT, ref.x, ref.forces_world, problem.foot_pos_world, push)).max() < 1e-7
        assert np.abs(dynamics_residual(model, DT, ref.x, ref.forces_world, problem.foot_pos_world)).max() > 1e-5
        for solver in ("auto", "qp-ipm"):
            fast = optimizers[(solver, n)].solve(problem)
            assert fast.success, fast.status
            assert_force_constraints(model, problem, fast)
            assert np.abs(dynamics_residual(model, DT, fast.x, fast.forces_world, problem.foot_pos_world,
                                            push)[:, 0:6]).max() < 1e-9
            assert np.abs(fast.x[:, 0:3] - ref.x[:, 0:3]).max() < 3e-3
            assert math.isclose(fast.cost, trajectory_cost(TrajoptWeights(), problem, model, DT, fast.x,
                                                           fast.forces_world), rel_tol=1e-9)
            unaware = optimizers[(solver, n)].solve(base)
            end_ref = base.x0[0:2] + DT * n * base.com_vel_ref_xy  # where the CoM reference ends (xy)
            assert np.sum(fast.forces_world[..., 1]) < np.sum(unaware.forces_world[..., 1]) - 2.0 * n  # pushes back
            # the unaware plan, simulated with the push, ends farther from the reference than the aware one
            x = base.x0
            for k in range(n):
                x = srbd_step(model, DT, x, unaware.forces_world[k], base.foot_pos_world[k], push)
            assert np.linalg.norm(fast.x[-1, 0:2] - end_ref) < np.linalg.norm(x[0:2] - end_ref)
    with pytest.raises(ValueError, match="external_force_world"):
        optimizers[("auto", 8)].solve(dataclasses.replace(typical_problems(desc)[4], external_force_world=np.ones(2)))


def test_interior_point_matches_casadi_qp(model: SrbdModel, desc: RobotDescription) -> None:
    """The batched interior-point method and piqp on the sparse QP solve the same problem."""
    ipm = TrajectoryOptimizer(model, TrajoptConfig(n_nodes=8, solver="qp-ipm"))
    piqp = TrajectoryOptimizer(model, TrajoptConfig(n_nodes=8, solver="qp-piqp"))
    rng = np.random.default_rng(2)
    problems = []
    for _ in range(12):  # harder than typical: fast, tilted, spinning, far footholds (constraints active)
        vel = rng.uniform(-0.4, 0.4, 2)
        x0 = moving_state(yaw=rng.uniform(-3, 3), tilt=0.05)
        x0[3:6] += rng.normal(0.0, 0.3, 3)
        x0[9:12] += rng.normal(0.0, 1.0, 3)
        legs = [(int(rng.integers(4)),)] if rng.random() < 0.5 else [((0, 3), (1, 2))[int(rng.integers(2))]]
        problems.append(
            example_problem(desc, legs, vel, x0=x0, foothold_offsets=rng.uniform(-0.15, 0.15, (1, 4, 2)))
        )
    batch = ipm.solve_batch(problems)
    for problem, sol in zip(problems, batch, strict=True):
        ref = piqp.solve(problem)
        assert sol.success and ref.success, (sol.status, ref.status)
        assert math.isclose(sol.cost, ref.cost, rel_tol=1e-5)
        assert np.abs(sol.forces_world - ref.forces_world).max() < 0.05  # N
        assert_force_constraints(model, problem, sol)


def test_batch_equals_single_solves(optimizers, desc: RobotDescription) -> None:
    problems = typical_problems(desc)
    candidates = walk_candidates(desc, moving_state(0.3), (0.05, 0.0))
    problems = [p for p in problems if len(p.contact) == 8] + candidates[::9]
    opt = optimizers[("qp-ipm", 8)]
    batch = opt.solve_batch(problems)
    assert len(batch) == len(problems)
    for problem, sol in zip(problems, batch, strict=True):
        single = opt.solve(problem)
        assert math.isclose(sol.cost, single.cost, rel_tol=1e-7)
        assert np.allclose(sol.x, single.x, atol=1e-7)


def test_cost_grows_with_a_harder_reference(optimizers, desc: RobotDescription) -> None:
    for solver in ("auto", "qp-ipm", "nlp-ipopt"):
        opt = optimizers[(solver, 24)]
        for steps in (WALK, TROT):
            x0 = np.zeros(12)
            x0[2] = desc.com_height_nominal_m
            still = opt.solve(example_problem(desc, steps, (0.0, 0.0), x0=x0), warm_start=False)
            moving = opt.solve(example_problem(desc, steps, (0.3, 0.0), x0=x0), warm_start=False)
            assert still.success and moving.success
            assert still.cost < moving.cost


@pytest.mark.parametrize("solver", ["auto", "nlp-ipopt"])
def test_warm_start_gives_the_cold_optimum(optimizers, desc: RobotDescription, solver: str) -> None:
    opt = optimizers[(solver, 24)]
    first = example_problem(desc, WALK, (0.1, 0.0), x0=moving_state())
    x0 = moving_state()
    x0[0:3] += 0.002
    x0[9:12] += 0.03
    second = example_problem(desc, WALK, (0.11, 0.01), x0=x0)
    opt.solve(first, warm_start=False)
    warm = opt.solve(second, warm_start=True)
    cold = opt.solve(second, warm_start=False)
    assert warm.success and cold.success
    assert math.isclose(warm.cost, cold.cost, rel_tol=1e-6)
    assert np.allclose(warm.x, cold.x, atol=1e-5)


def test_solution_is_invariant_to_the_heading(optimizers, desc: RobotDescription) -> None:
    """Rotating the whole problem about z rotates the solution and keeps the cost."""
    opt = optimizers[("auto", 24)]
    base = example_problem(desc, TROT, (0.1, 0.05), x0=moving_state(yaw=0.0))
    turned = example_problem(desc, TROT, (0.1, 0.05), x0=moving_state(yaw=0.0))
    yaw = 1.1
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    turned.x0 = turned.x0.copy()
    turned.x0[0:3], turned.x0[3:6], turned.x0[9:12] = (
        rot @ base.x0[0:3],
        rot @ base.x0[3:6],
        rot @ base.x0[9:12],
    )
    turned.x0[8] += yaw
    turned.foot_pos_world = base.foot_pos_world @ rot.T
    turned.com_vel_ref_xy = rot[0:2, 0:2] @ base.com_vel_ref_xy
    turned.yaw_ref_rad = yaw
    a, b = opt.solve(base, warm_start=False), opt.solve(turned, warm_start=False)
    assert math.isclose(a.cost, b.cost, rel_tol=1e-6)
    assert np.allclose(a.x[:, 0:3] @ rot.T, b.x[:, 0:3], atol=1e-6)
    assert np.allclose(a.forces_world @ rot.T, b.forces_world, atol=1e-4)


# --- failures --------------------------------------------------------------------------------------


@pytest.mark.parametrize("solver", ["auto", "qp-ipm", "nlp-ipopt"])
def test_no_support_is_infeasible_without_raising(optimizers, desc: RobotDescription, solver: str) -> None:
    problem = example_problem(desc, WALK[:1], (0.0, 0.0))
    problem.contact = np.zeros_like(problem.contact)
    sol = optimizers[(solver, 8)].solve(problem, warm_start=False)
    assert not sol.success
    assert sol.status == "infeasible"
    assert sol.cost == math.inf


def test_buffered_qp_call_gives_the_casadi_call_numbers(model: SrbdModel, desc: RobotDescription) -> None:
    """A casadi qpsol plugin's QP is evaluated through casadi's Function.buffer (no DM conversions): the very
    numbers of calling the function, and its statistics."""
    ocp = TrajectoryOptimizer(model, TrajoptConfig(n_nodes=24, solver="qp-piqp"))._ocp
    for problem in typical_problems(desc)[:4]:  # the three-step (24-node) ones
        args = ocp._arguments(ProblemBatch.of([problem], 24).in_heading_frame())
        buffered = ocp._call(**args)
        status = ocp._call.stats()["return_status"]
        direct = ocp.cold(**args)
        for name in ("x", "f", "lam_x", "lam_g"):
            np.testing.assert_array_equal(buffered[name], np.asarray(direct[name]).ravel())
        assert status == ocp.cold.stats()["return_status"] == "solved"


def test_the_mpc_solve_with_piqp_directly_is_the_casadi_qp(optimizers, model: SrbdModel,
                                                           desc: RobotDescription) -> None:
    """``"auto"`` hands the QP to piqp directly (``piqp_direct``): the optimum of the same QP solved through
    casadi's piqp plugin (the same cost to 1e-6, forces within 0.01 N on these nearly flat problems), one solver
    updated from problem to problem; and the optimizer still pickles and solves the same."""
    auto = optimizers[("auto", 24)]
    through_casadi = TrajectoryOptimizer(model, TrajoptConfig(n_nodes=24, solver="qp-piqp"))
    for problem in typical_problems(desc)[:4] * 2:
        a, b = auto.solve(problem, warm_start=False), through_casadi.solve(problem, warm_start=False)
        assert a.status == b.status == "ok"
        assert math.isclose(a.cost, b.cost, rel_tol=1e-6)
        np.testing.assert_allclose(a.forces_world, b.forces_world, atol=1e-2)
        np.testing.assert_allclose(a.x, b.x, atol=1e-5)
    problem = typical_problems(desc)[0]
    copy = pickle.loads(pickle.dumps(auto))
    np.testing.assert_array_equal(copy.solve(problem, warm_start=False).x, auto.solve(problem, warm_start=False).x)


def test_non_finite_input_returns_an_error_status(optimizers, desc: RobotDescription) -> None:
    bad = example_problem(desc, WALK[:1], (0.1, 0.0))
    bad.x0 = bad.x0.copy()
    bad.x0[3] = np.nan
    for solver in ("auto", "qp-ipm", "nlp-ipopt"):
        sol = optimizers[(solver, 8)].solve(bad)
        assert not sol.success and sol.status == "error: non-finite input"
    good = example_problem(desc, WALK[:1], (0.1, 0.0))
    results = optimizers[("qp-ipm", 8)].solve_batch([good, bad, good])
    assert [r.success for r in results] == [True, False, True]


def test_swing_foot_positions_may_be_nan(optimizers, desc: RobotDescription) -> None:
    problem = example_problem(desc, WALK[:1], (0.1, 0.0))
    problem.foot_pos_world = problem.foot_pos_world.copy()
    problem.foot_pos_world[~problem.contact] = np.nan
    assert ProblemBatch.of([problem], 8).finite()[0]
    assert optimizers[("qp-ipm", 8)].solve(problem).success


def test_wrong_shapes_raise(model: SrbdModel, desc: RobotDescription) -> None:
    opt = TrajectoryOptimizer(model, TrajoptConfig(n_nodes=8, solver="qp-ipm"))
    with pytest.raises(ValueError):
        opt.solve(example_problem(desc, WALK, (0.1, 0.0)))  # 24 nodes for an 8-node optimizer
    with pytest.raises(ValueError):
        TrajectoryOptimizer(model, TrajoptConfig(solver="magic"))


def test_format_table() -> None:
    """The benchmark's rows (some with extra columns) format as one table (``contactnet.bench``)."""
    rows = [
        {"name": "a", "median_ms": 1.0, "p99_ms": 2.0},
        {"name": "b", "median_ms": 0.3, "p99_ms": 0.4, "candidates_per_s": 3000.0},
    ]
    header, _, row_a, row_b = format_table(rows).splitlines()
    assert header.split() == ["name", "median_ms", "p99_ms", "candidates_per_s"]
    assert row_a.split() == ["a", "1", "2"] and row_b.split() == ["b", "0.3", "0.4", "3000"]


def test_candidate_batches_of_a_state(model: SrbdModel, desc: RobotDescription) -> None:
    """All 100 walking and 162 trotting candidates of a state solve; tol 1e-6 ranks like tol 1e-8."""
    x0 = moving_state()
    tight = TrajectoryOptimizer(model, TrajoptConfig(n_nodes=8, solver="qp-ipm"))
    fast = TrajectoryOptimizer(model, TrajoptConfig.for_candidates())
    for make, size in ((walk_candidates, 100), (trot_candidates, 162)):
        problems = make(desc, x0, (0.05, 0.0))
        assert len(problems) == size
        a, b = fast.solve_batch(problems), tight.solve_batch(problems)
        assert all(s.success for s in a) and all(s.success for s in b)
        ca, cb = np.array([s.cost for s in a]), np.array([s.cost for s in b])
        assert np.allclose(ca, cb, rtol=1e-5)
        assert np.allclose(cb[np.argsort(ca)[:5]], np.sort(cb)[:5], rtol=1e-5)  # same best five


def test_reference_states_integrate_the_user_velocity(desc: RobotDescription) -> None:
    problem = example_problem(desc, WALK, (0.2, -0.1), x0=moving_state(yaw=0.4))
    ref = T.reference_states(problem, 24, DT)
    assert np.allclose(ref, ProblemBatch.of([problem], 24).reference_states(DT)[0])
    assert np.allclose(ref[-1, 0:2], problem.x0[0:2] + 24 * DT * np.array([0.2, -0.1]))
    assert np.allclose(ref[:, 2], problem.com_height_ref_m) and np.allclose(ref[:, 8], 0.4)
    assert np.allclose(ref[:, [6, 7, 9, 10, 11]], 0.0)


def test_reference_start_pulls_the_com_back_to_its_path(optimizers, desc: RobotDescription) -> None:
    """A reference path 4 cm to the left: every solver moves the CoM left, and the fast paths agree."""
    x0 = moving_state(yaw=0.4)
    base = example_problem(desc, WALK, (0.05, 0.0), x0=x0)
    left_world = x0[0:2] + np.array([-np.sin(0.4), np.cos(0.4)]) * 0.04
    shifted = dataclasses.replace(base, com_xy_ref_start=left_world)
    ends = {}
    for solver in ("auto", "qp-ipm", "nlp-ipopt"):
        opt = optimizers[(solver, 24)]
        plain, pulled = opt.solve(base, warm_start=False), opt.solve(shifted, warm_start=False)
        assert plain.success and pulled.success
        moved = pulled.x[-1, 0:2] - plain.x[-1, 0:2]
        assert np.dot(moved, left_world - x0[0:2]) / 0.04 > 0.02  # more than half-way to the new path
        ends[solver] = pulled.x[:, 0:3]
    np.testing.assert_allclose(ends["qp-ipm"], ends["auto"], atol=1e-5)
    np.testing.assert_allclose(ends["auto"], ends["nlp-ipopt"], atol=3e-3)
    batch = optimizers[("qp-ipm", 24)].solve_batch([base, shifted])
    np.testing.assert_allclose(batch[1].x[:, 0:3], ends["qp-ipm"], atol=1e-6)


def test_height_and_pitch_references_per_node(optimizers, desc: RobotDescription) -> None:
    """Terrain with heights: the CoM height and pitch references may change node by node. A constant array
    is the scalar bit for bit; a rising height and a nose-up pitch pull the solution up and nose up."""
    base = example_problem(desc, WALK, (0.05, 0.0), x0=moving_state())
    n = 24
    constant = dataclasses.replace(base, com_height_ref_m=np.full(n + 1, base.com_height_ref_m),
                                   pitch_ref_rad=np.zeros(n + 1))
    ref = T.reference_states(constant, n, DT)
    np.testing.assert_array_equal(ref, T.reference_states(base, n, DT))
    np.testing.assert_array_equal(ProblemBatch.of([constant], n).reference_states(DT)[0], ref)
    climbing = dataclasses.replace(base, com_height_ref_m=base.com_height_ref_m + np.linspace(0.0, 0.05, n + 1),
                                   pitch_ref_rad=np.full(n + 1, -0.12))
    ref = T.reference_states(climbing, n, DT)
    assert ref[-1, 2] == pytest.approx(base.com_height_ref_m + 0.05) and np.allclose(ref[:, 7], -0.12)
    for solver in ("auto", "qp-ipm"):
        opt = optimizers[(solver, n)]
        plain, same, up = (opt.solve(p, warm_start=False) for p in (base, constant, climbing))
        assert plain.success and same.success and up.success
        np.testing.assert_array_equal(same.x, plain.x)
        assert up.x[-1, 2] > plain.x[-1, 2] + 0.03  # follows the rising reference
        assert up.x[-1, 7] < -0.08  # nose up (negative pitch)
    with pytest.raises(ValueError, match="com_height_ref_m"):
        ProblemBatch.of([dataclasses.replace(base, com_height_ref_m=np.zeros(n))], n)
