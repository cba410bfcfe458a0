"""Whole-body controller: swing trajectories hit their ends at rest, forces stay in the friction
pyramid, torques are saturated, and the controller holds Solo12 up in PyBullet."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from contactnet.frames import quat_to_matrix, rotation_rpy
from contactnet.motion.controller import (
    ControllerGains,
    ControlTarget,
    SwingTrajectory,
    WholeBodyController,
    clip_to_friction_pyramid,
)
from contactnet.robots import Robot
from contactnet.sim.engines import make_simulator
from contactnet.sim.world import ENGINES, Push, SimConfig
from contactnet.terrain import flat


@pytest.fixture
def swing():
    return SwingTrajectory(
        start_world=np.array([0.2, 0.15, 0.016]), end_world=np.array([0.3, 0.1, 0.036]), t0_s=1.0, t1_s=1.16, height_m=0.05
    )


def test_swing_hits_liftoff_and_touchdown_at_rest(swing):
    for t, point in ((swing.t0_s, swing.start_world), (swing.t1_s, swing.end_world)):
        pos, vel, acc = swing.sample(t)
        np.testing.assert_allclose(pos, point, atol=1e-12)
        np.testing.assert_allclose(vel, 0.0, atol=1e-9)
        assert abs(acc[2]) < 1e-6  # the height polynomial also starts and ends without acceleration
    # Clamped outside the swing.
    np.testing.assert_allclose(swing.sample(0.0)[0], swing.start_world)
    np.testing.assert_allclose(swing.sample(5.0)[0], swing.end_world)


def test_swing_apex_and_derivatives(swing):
    mid = swing.sample(0.5 * (swing.t0_s + swing.t1_s))[0]
    assert mid[2] == pytest.approx(max(swing.start_world[2], swing.end_world[2]) + swing.height_m)
    np.testing.assert_allclose(mid[:2], 0.5 * (swing.start_world[:2] + swing.end_world[:2]), atol=1e-12)
    # Velocity is the derivative of position (central differences), acceleration of velocity.
    dt = 1e-6
    for t in np.linspace(1.001, 1.159, 17):
        p0, v0, a0 = swing.sample(t - dt)
        p1, v1, a1 = swing.sample(t + dt)
        _, v, a = swing.sample(t)
        np.testing.assert_allclose((p1 - p0) / (2 * dt), v, atol=1e-4)
        np.testing.assert_allclose((v1 - v0) / (2 * dt), a, atol=1e-2)
    # Never below the straight line between the ends.
    heights = [swing.sample(t)[0][2] for t in np.linspace(1.0, 1.16, 50)]
    assert min(heights) >= swing.start_world[2] - 1e-12


def test_friction_pyramid_projection():
    forces = np.array([[10.0, -10.0, 5.0], [0.1, 0.2, 10.0], [1.0, 1.0, -3.0], [0.0, 0.0, 100.0]])
    out = clip_to_friction_pyramid(forces, mu=0.6, fz_min=0.5, fz_max=25.0)
    assert np.all(out[:, 2] >= 0.5) and np.all(out[:, 2] <= 25.0)
    assert np.all(np.abs(out[:, :2]) <= 0.6 * out[:, 2:3] + 1e-12)
    np.testing.assert_allclose(out[1], forces[1])  # inside: untouched


def test_rpy_matrix_matches_quaternion():
    rng = np.random.default_rng(0)
    import pinocchio as pin

    for _ in range(10):
        rpy = rng.uniform(-1, 1, 3)
        matrix = rotation_rpy(rpy)
        quat = pin.Quaternion(pin.rpy.rpyToMatrix(rpy)).coeffs()  # x, y, z, w
        np.testing.assert_allclose(matrix, quat_to_matrix(quat), atol=1e-12)


def standing_target(controller: WholeBodyController, q, v, mass):
    com, _, feet, _ = controller.kinematics(q, v)
    return ControlTarget(
        com_pos=com,
        com_vel=np.zeros(3),
        rpy=np.zeros(3),
        ang_vel=np.zeros(3),
        forces=np.tile([0.0, 0.0, mass * 9.81 / 4], (4, 1)),
        stance=np.ones(4, dtype=bool),
        swing_pos=feet,
        swing_vel=np.zeros((4, 3)),
    )


def test_torques_are_saturated(robot):
    limited = dataclasses.replace(robot.description, torque_limit_nm=np.full(12, 0.5))
    controller = WholeBodyController(Robot(robot.spec, robot.files, robot.model, limited))
    q = robot.q_standing.copy()
    v = np.zeros(18)
    target = standing_target(controller, q, v, robot.mass_kg)
    target.com_pos = target.com_pos + np.array([0.3, 0.0, 0.2])  # a huge error
    tau = controller.torques(q, v, target)
    assert np.abs(tau).max() == pytest.approx(0.5)


def test_stance_forces_balance_gravity_at_rest(robot):
    controller = WholeBodyController(robot)
    q = robot.q_standing.copy()
    v = np.zeros(18)
    target = standing_target(controller, q, v, robot.mass_kg)
    controller.torques(q, v, target)
    np.testing.assert_allclose(controller.last_forces.sum(axis=0), [0, 0, robot.mass_kg * 9.81], atol=1e-6)


@pytest.mark.parametrize("engine", ENGINES)
def test_holds_the_robot_up_and_recovers_from_a_push(robot, engine):
    controller = WholeBodyController(robot)
    with make_simulator(robot, flat(), SimConfig(engine=engine)) as sim:
        state = sim.state(with_contacts=False)
        target = standing_target(controller, state.q_pinocchio(), state.v_pinocchio(), robot.mass_kg)
        sim.add_push(Push(0.5, 0.5, (5.0, 0.0, 0.0)))
        max_pitch = 0.0
        for _ in range(2000):
            sim.step(controller.torques(state.q_pinocchio(), state.v_pinocchio(), target))
            state = sim.state(with_contacts=False)
            max_pitch = max(max_pitch, abs(state.rpy[1]))
        assert sim.fall_reason() is None
        assert max_pitch < 0.15
        np.testing.assert_allclose(controller.last_com[:2], target.com_pos[:2], atol=0.01)


def test_unloading_keeps_the_wrench_where_clipping_adds_a_push(robot):
    """A roll correction that asks the left feet to pull: spread once and clipped, their pull becomes a push (the
    net vertical force grows and the moment is lost); with the unloading rounds they are held at the minimum load
    and the right feet carry the wrench: the net vertical force is the one asked for."""
    def forces(rounds: int) -> np.ndarray:
        gains = dataclasses.replace(ControllerGains.for_robot(robot.description), unload_rounds=rounds)
        controller = WholeBodyController(robot, gains)
        q, v = robot.q_standing.copy(), np.zeros(18)
        target = standing_target(controller, q, v, robot.mass_kg)
        target.rpy = np.array([0.6, 0.0, 0.0])  # roll the body: the feet on one side must unload hard
        controller.torques(q, v, target)
        return controller.last_forces, target.forces

    plain, reference = forces(0)
    unloaded, _ = forces(3)
    fz_min = ControllerGains().fz_min_n
    assert (plain[:, 2] <= fz_min + 1e-9).any()  # some feet clipped at the minimum ...
    assert plain[:, 2].sum() > reference[:, 2].sum() + 1.0  # ... and their pull became a push
    assert unloaded[:, 2].sum() == pytest.approx(reference[:, 2].sum(), abs=0.05 * reference[:, 2].sum())
    assert unloaded[:, 2].min() >= fz_min - 1e-9


def test_swing_over_an_obstacle_rises_above_it_and_leaves_vertically(swing):
    """Terrain with heights: the apex clears ``clear_z_m`` by ``height_m``; with vertical fractions the foot
    neither leaves nor lands with horizontal motion; ``height_at_progress`` is the trajectory's own height."""
    tall = dataclasses.replace(swing, clear_z_m=0.12, liftoff_fraction=0.2, touchdown_fraction=0.2)
    assert tall.apex_z == pytest.approx(0.17)
    assert tall.sample(0.5 * (tall.t0_s + tall.t1_s))[0][2] == pytest.approx(0.17)
    for t in np.linspace(tall.t0_s, tall.t0_s + 0.2 * 0.16, 5):
        pos, vel, _ = tall.sample(t)
        np.testing.assert_allclose(pos[:2], tall.start_world[:2], atol=1e-12)
        np.testing.assert_allclose(vel[:2], 0.0, atol=1e-12)
    for t in np.linspace(tall.t1_s - 0.2 * 0.16, tall.t1_s, 5):
        np.testing.assert_allclose(tall.sample(t)[0][:2], tall.end_world[:2], atol=1e-12)
    length = np.linalg.norm(tall.end_world[:2] - tall.start_world[:2])
    for t in np.linspace(1.04, 1.12, 9):
        pos = tall.sample(t)[0]
        progress = np.linalg.norm(pos[:2] - tall.start_world[:2]) / length
        assert tall.height_at_progress(np.array([progress]))[0] == pytest.approx(pos[2], abs=1e-9)
    # Velocity is still the derivative of position.
    dt = 1e-6
    for t in np.linspace(1.001, 1.159, 13):
        np.testing.assert_allclose((tall.sample(t + dt)[0] - tall.sample(t - dt)[0]) / (2 * dt), tall.sample(t)[1],
                                   atol=1e-4)
    # Different fractions at the two ends: still continuous, still its own height at each progress.
    lopsided = dataclasses.replace(swing, liftoff_fraction=0.0, touchdown_fraction=0.3)
    np.testing.assert_allclose(lopsided.sample(lopsided.t1_s - 0.25 * 0.16)[0][:2], lopsided.end_world[:2], atol=1e-12)
    assert abs(lopsided.sample(lopsided.t0_s + 0.05 * 0.16)[1][0]) > 0  # moves forward right after lift-off
    for t in np.linspace(1.04, 1.10, 5):
        pos = lopsided.sample(t)[0]
        progress = np.linalg.norm(pos[:2] - lopsided.start_world[:2]) / length
        assert lopsided.height_at_progress(np.array([progress]))[0] == pytest.approx(pos[2], abs=1e-9)
    # Without an obstacle or vertical fractions it is today's swing, to the bit.
    plain = dataclasses.replace(swing, clear_z_m=None)
    for t in np.linspace(1.0, 1.16, 7):
        for a, b in zip(plain.sample(t), swing.sample(t), strict=True):
            np.testing.assert_array_equal(a, b)


def _reference_cop_line(com, feet, stance, forces_ref, wrench):
    """The centre of pressure p(alpha) (2,) of the planned forces plus the feedback wrench with its horizontal
    force scaled by alpha, from the resultant's force and moment about the CoM (numpy cross products), and the
    height h of the CoM above the stance feet; None when there is no upward force."""
    lever = feet[stance] - com
    force = forces_ref[stance].sum(axis=0) + wrench[:3]
    moment = np.cross(lever, forces_ref[stance]).sum(axis=0) + wrench[3:]
    height = com[2] - feet[stance, 2].mean()
    if force[2] <= 1e-6 or height <= 0.0:
        return None

    def cop(alpha: float) -> np.ndarray:
        fx, fy = force[:2] - (1.0 - alpha) * wrench[:2]
        return com[:2] + np.array([-moment[1] - height * fx, moment[0] - height * fy]) / force[2]

    return cop


def reference_cop_share(com, feet, stance, forces_ref, wrench, margin_m) -> float:
    """``cop_scale`` from shapely's hull of the stance feet, edge by edge: the largest alpha in [0, 1] with every
    edge's slack (margin taken off) at p(alpha) at least min(its slack at p(0), 0)."""
    from shapely.geometry import MultiPoint
    from shapely.geometry.polygon import orient

    if stance.sum() < 3:
        return 1.0
    hull = MultiPoint([tuple(f) for f in feet[stance, :2]]).convex_hull
    cop = _reference_cop_line(com, feet, stance, forces_ref, wrench)
    if hull.geom_type != "Polygon" or hull.area < 5e-9 or cop is None:
        return 1.0
    corners = np.array(orient(hull, 1.0).exterior.coords)  # counter-clockwise, closed
    p0, d = cop(0.0), cop(1.0) - cop(0.0)
    alpha = 1.0
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        edge = b - a
        inward = np.array([-edge[1], edge[0]]) / np.linalg.norm(edge)
        slack, rate = inward @ (p0 - a) - margin_m, inward @ d
        if rate < 0.0:
            alpha = 0.0 if slack <= 0.0 else min(alpha, slack / -rate)
    return max(alpha, 0.0)


def reference_torques(controller: WholeBodyController, q: np.ndarray, v: np.ndarray,
                      target: ControlTarget) -> tuple[np.ndarray, np.ndarray]:
    """The controller's steps 1-5 written plainly in numpy (the form the compiled kernel replaced): torques and
    stance forces."""
    import pinocchio as pin

    g, model, data = controller.gains, controller.model, controller.model.createData()
    com = pin.centerOfMass(model, data, q, v).copy()
    vcom = data.vcom[0].copy()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    feet = np.array([data.oMf[f].translation for f in controller.foot_ids])
    jac = np.array([pin.getFrameJacobian(model, data, f, pin.LOCAL_WORLD_ALIGNED)[:3] for f in controller.foot_ids])
    rot = data.oMi[1].rotation
    stance = np.asarray(target.stance, dtype=bool)
    mass, inertia = controller.mass, controller.inertia_diag
    force_fb = np.array(g.kp_com) * mass * (target.com_pos - com) + np.array(g.kd_com) * mass * (target.com_vel - vcom)
    if target.external_force_world is not None:
        force_fb = force_fb - target.external_force_world
    rot_err = pin.log3(pin.rpy.rpyToMatrix(target.rpy) @ rot.T)
    torque_fb = (np.array(g.kp_base_rot) * inertia * rot_err
                 + np.array(g.kd_base_rot) * inertia * (target.ang_vel - rot @ v[3:6]))
    grasp = np.zeros((6, 12))
    for leg in range(4):
        lever = feet[leg] - com
        grasp[:3, 3 * leg:3 * leg + 3] = np.eye(3)
        grasp[3:, 3 * leg:3 * leg + 3] = np.array([[0, -lever[2], lever[1]], [lever[2], 0, -lever[0]],
                                                    [-lever[1], lever[0], 0]])
    wrench = np.concatenate([force_fb, torque_fb])
    if g.cop_margin_m is not None:
        force_fb[:2] *= reference_cop_share(com, feet, stance, target.forces, wrench, g.cop_margin_m)
        wrench = np.concatenate([force_fb, torque_fb])
    held = np.zeros(4, dtype=bool)  # the unloading rounds' feet held at fz_min, with their forces
    held_forces = np.zeros((4, 3))
    for round_ in range(g.unload_rounds + 1):
        weighted = grasp * np.repeat(stance & ~held, 3)
        delta = (weighted.T @ np.linalg.solve(weighted @ grasp.T + g.force_regularization * np.eye(6), wrench))
        wanted = target.forces + delta.reshape(4, 3)
        pulling = stance & ~held & (wanted[:, 2] < g.fz_min_n)
        if round_ == g.unload_rounds or not pulling.any():
            break
        limit = g.mu * g.fz_min_n
        held_forces[pulling] = np.column_stack([np.clip(wanted[pulling, :2], -limit, limit),
                                                np.full(pulling.sum(), g.fz_min_n)])
        held |= pulling
        fixed = (held_forces - target.forces) * held[:, None]
        wrench = np.concatenate([force_fb, torque_fb]) - grasp @ fixed.ravel()
    forces = clip_to_friction_pyramid(np.where(held[:, None], held_forces, wanted), g.mu, g.fz_min_n, g.fz_max_n)
    forces[~stance] = 0.0
    swing = np.array(g.kp_swing) * (target.swing_pos - feet) + np.array(g.kd_swing) * (target.swing_vel - jac @ v)
    push = np.where(stance[:, None], -forces, swing)
    tau = sum(jac[leg][:, 6:].T @ push[leg] for leg in range(4)) - g.kd_joint * v[6:]
    tau = tau + g.leg_gravity * pin.computeGeneralizedGravity(model, data, q)[6:]  # the legs' weight (a share of it)
    return np.clip(tau, -controller.torque_limit_nm, controller.torque_limit_nm), forces


@pytest.mark.parametrize("seed, unload_rounds, cop_margin_m, leg_gravity",
                         [(0, 0, None, 0.0), (1, 0, None, 0.0), (2, 0, None, 1.0), (3, 0, None, 0.0),
                          (4, 3, None, 0.0), (5, 3, None, 0.5), (6, 0, 0.01, 0.0), (7, 3, 0.02, 1.0)])
def test_the_compiled_controller_is_the_plain_formulas(robot, seed, unload_rounds, cop_margin_m, leg_gravity):
    """Random configurations, velocities and targets (stance sets, pushes): the compiled steps 1-5 give the plain
    numpy form's torques and forces to rounding, and some torques saturate; with and without the unloading
    rounds, the centre-of-pressure limit and the legs' weight."""
    rng = np.random.default_rng(seed)
    controller = WholeBodyController(robot, dataclasses.replace(ControllerGains.for_robot(robot.description),
                                                                unload_rounds=unload_rounds, cop_margin_m=cop_margin_m,
                                                                leg_gravity=leg_gravity))
    saturated = unloaded = 0
    for k in range(50):
        q = robot.q_standing.copy()
        q[:3] += rng.normal(0.0, 0.02, 3)
        quat = np.array([*rng.normal(0.0, 0.1, 3), 1.0])
        q[3:7] = quat / np.linalg.norm(quat)
        q[7:] += rng.normal(0.0, 0.2, 12)
        v = rng.normal(0.0, 0.5, 18)
        target = standing_target(controller, q, v, robot.mass_kg)
        target.com_pos = target.com_pos + rng.normal(0.0, 0.03, 3)
        target.com_vel, target.ang_vel = rng.normal(0.0, 0.2, 3), rng.normal(0.0, 0.5, 3)
        target.rpy = rng.normal(0.0, 0.2, 3)
        target.stance = rng.random(4) < 0.7
        target.forces = rng.normal(0.0, 3.0, (4, 3)) + [0.0, 0.0, 6.0]
        target.swing_pos = target.swing_pos + rng.normal(0.0, 0.03, (4, 3))
        target.swing_vel = rng.normal(0.0, 0.3, (4, 3))
        target.external_force_world = None if k % 2 else rng.normal(0.0, 5.0, 3)
        tau = controller.torques(q, v, target)
        expected_tau, expected_forces = reference_torques(controller, q, v, target)
        np.testing.assert_allclose(tau, expected_tau, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(controller.last_forces, expected_forces, rtol=1e-9, atol=1e-9)
        saturated += bool(np.isclose(np.abs(tau), controller.torque_limit_nm).any())
        unloaded += bool(np.isclose(controller.last_forces[target.stance, 2], controller.gains.fz_min_n).any())
    assert saturated > 0
    assert unloaded > 0  # feet at the minimum load: the unloading rounds (or the clip) were exercised


def test_the_cop_share_keeps_the_centre_of_pressure_in_the_stance_polygon():
    """cop_scale against its definition, on random walk-like stances: where the planned forces' centre of
    pressure lies inside the shrunk polygon, alpha is the largest share whose whole path stays in shapely's
    buffered hull (scanned on a fine grid), and the CoP at alpha lies on its edge when alpha < 1; where it lies
    outside, the feedback never takes the CoP further from the polygon. Both kinds and clipped shares occur."""
    import shapely
    from shapely.geometry import MultiPoint, Point

    from contactnet.motion.controller_kernel import cop_scale

    rng = np.random.default_rng(3)
    margin = 0.01
    grid = np.linspace(0.0, 1.0, 2001)
    kinds = {"inside": 0, "clipped": 0, "outside": 0}
    for _ in range(300):
        feet = np.array([[0.2, 0.15, 0.0], [0.2, -0.15, 0.0], [-0.2, 0.15, 0.0], [-0.2, -0.15, 0.0]])
        feet += rng.normal(0.0, [0.04, 0.03, 0.005], (4, 3))
        stance = np.ones(4, dtype=bool)
        stance[rng.integers(0, 4)] = rng.random() < 0.7  # mostly a walk's three feet
        com = np.array([*rng.normal(0.0, 0.05, 2), 0.24])
        forces_ref = np.where(stance[:, None], [0.0, 0.0, 25.0 / stance.sum()], 0.0) + rng.normal(0.0, 0.5, (4, 3))
        # moments of up to a few N m put p(0) outside the polygon at times
        wrench = np.concatenate([rng.normal(0.0, 8.0, 2), rng.normal(0.0, 2.0, 1), rng.normal(0.0, 1.5, 3)])
        alpha = cop_scale(com, feet, stance, forces_ref, wrench, margin)
        assert 0.0 <= alpha <= 1.0
        assert alpha == pytest.approx(reference_cop_share(com, feet, stance, forces_ref, wrench, margin), abs=1e-12)
        cop = _reference_cop_line(com, feet, stance, forces_ref, wrench)
        region = MultiPoint([tuple(f) for f in feet[stance, :2]]).convex_hull.buffer(-margin)
        if region.contains(Point(cop(0.0))):
            path = np.array([cop(a) for a in grid])
            inside = shapely.contains_xy(region.buffer(1e-9), path[:, 0], path[:, 1])
            allowed = grid[np.cumprod(inside).astype(bool)].max()  # the path's first exit
            assert alpha == pytest.approx(allowed, abs=1e-3)
            if alpha < 1.0:
                assert region.exterior.distance(Point(cop(alpha))) < 1e-9
            kinds["clipped" if alpha < 1.0 else "inside"] += 1
        else:
            assert region.distance(Point(cop(alpha))) <= region.distance(Point(cop(0.0))) + 1e-9
            kinds["outside"] += 1
    assert min(kinds.values()) >= 10, kinds


@pytest.mark.parametrize("margin", [-0.01, float("nan"), float("inf"), "1cm"])
def test_a_bad_cop_margin_is_refused_by_name(margin):
    with pytest.raises(ValueError, match="cop_margin_m"):
        ControllerGains(cop_margin_m=margin)


@pytest.mark.parametrize("share", [-0.1, 1.5, float("nan"), "all"])
def test_a_bad_leg_gravity_share_is_refused_by_name(share):
    with pytest.raises(ValueError, match="leg_gravity"):
        ControllerGains(leg_gravity=share)


def test_with_the_legs_weight_held_a_still_leg_gives_the_ground_the_commanded_force(robot):
    """``leg_gravity`` = 1: each still stance leg's static balance, ``tau_leg = g_leg - J_leg^T f`` solved for ``f``
    (numpy, undamped), is the commanded force; without it the ground also gets the leg's weight (``J^-T g_leg``),
    more than a tenth of a newton on some leg."""
    import pinocchio as pin

    rng = np.random.default_rng(3)
    errors = {}
    for share in (0.0, 1.0):
        controller = WholeBodyController(robot, dataclasses.replace(ControllerGains.for_robot(robot.description),
                                                                    leg_gravity=share))
        data, worst = controller.model.createData(), 0.0
        for _ in range(20):
            q = robot.q_standing.copy()
            q[7:] += rng.normal(0.0, 0.1, 12)
            tau = controller.torques(q, np.zeros(18), standing_target(controller, q, np.zeros(18), robot.mass_kg))
            assert (np.abs(tau) < controller.torque_limit_nm).all()
            gravity = pin.computeGeneralizedGravity(controller.model, data, q)[6:]
            pin.computeJointJacobians(controller.model, data, q)
            pin.updateFramePlacements(controller.model, data)
            for leg, frame in enumerate(controller.foot_ids):
                jac = pin.getFrameJacobian(controller.model, data, frame, pin.LOCAL_WORLD_ALIGNED)[:3]
                legs = slice(3 * leg, 3 * leg + 3)
                given = np.linalg.solve(jac[:, 6 + 3 * leg:9 + 3 * leg].T, gravity[legs] - tau[legs])
                worst = max(worst, float(np.abs(given - controller.last_forces[leg]).max()))
        errors[share] = worst
    assert errors[1.0] < 1e-6 and errors[0.0] > 0.1, errors


def reference_delivered_forces(controller: WholeBodyController, q: np.ndarray, tau: np.ndarray,
                               damping_m2: float) -> tuple[np.ndarray, np.ndarray]:
    """The plain form of ``delivered_forces``: per leg, damped least squares of ``J_leg^T f = g_leg - tau_leg`` with
    numpy's solver, and the smallest singular value from numpy's SVD."""
    import pinocchio as pin

    model, data = controller.model, controller.model.createData()
    gravity = pin.computeGeneralizedGravity(model, data, q)[6:]
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    forces, sigma = np.zeros((4, 3)), np.zeros(4)
    for leg, frame in enumerate(controller.foot_ids):
        jac = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)[:3, 6 + 3 * leg:9 + 3 * leg]
        rhs = gravity[3 * leg:3 * leg + 3] - tau[3 * leg:3 * leg + 3]
        forces[leg] = np.linalg.solve(jac @ jac.T + damping_m2 * np.eye(3), jac @ rhs)
        sigma[leg] = np.linalg.svd(jac, compute_uv=False)[-1]
    return forces, sigma


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_delivered_forces_are_the_plain_formulas(robot, seed):
    """Random configurations (some legs stretched straight) and torques: the compiled ``delivered_forces`` gives the
    plain numpy form's forces and smallest singular values to rounding; a straight leg's is near zero."""
    from contactnet.motion.controller import LEG_FORCE_DAMPING_M2

    rng = np.random.default_rng(seed)
    controller = WholeBodyController(robot)
    stretched = 0
    for k in range(30):
        q = robot.q_standing.copy()
        quat = np.array([*rng.normal(0.0, 0.1, 3), 1.0])
        q[3:7] = quat / np.linalg.norm(quat)
        q[7:] += rng.normal(0.0, 0.3, 12)
        if k % 3 == 0:
            q[7 + 3 * (k % 4) + 2] = 0.0  # a knee straight
        controller.torques(q, np.zeros(18), standing_target(controller, q, np.zeros(18), robot.mass_kg))
        tau = rng.normal(0.0, 1.0, 12)
        forces, sigma = controller.delivered_forces(q, tau)
        expected_forces, expected_sigma = reference_delivered_forces(controller, q, tau, LEG_FORCE_DAMPING_M2)
        np.testing.assert_allclose(forces, expected_forces, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(sigma, expected_sigma, rtol=1e-6, atol=1e-7)
        stretched += int(sigma.min() < 0.005)
    assert stretched >= 10  # every straight knee's leg: singular to within 5 mm


@pytest.mark.parametrize("engine", ENGINES)
def test_the_delivered_forces_are_what_the_ground_gives(robot, engine):
    """Walking 2 s on flat ground, each foot on the ground: the forces ``delivered_forces`` reads from the applied
    torques (with the legs' weight) are nearer the engine's contact forces than the commanded ones (``last_forces``,
    which leave the legs' weight out): in PyBullet median errors measured 0.03 against 0.36 N along x, 0.29 against
    0.69 N along z."""
    from contactnet.locomotion import Locomotion
    from contactnet.motion.gait import WALK
    from contactnet.planning.heuristic import HeuristicPlanner

    with Locomotion(robot, flat(), WALK, HeuristicPlanner(WALK), SimConfig(engine=engine),
                    vel_cmd_xy=(0.1, 0.0)) as loco:
        loco.run(1.0)
        delivered_err, commanded_err = [], []
        for _ in range(2000):
            loco.advance(1)  # the forces of this tick's torques against the contact forces of the step they drove
            contact, measured = loco.sim._foot_contacts()
            delivered_err.append((loco._delivered - measured)[contact])
            commanded_err.append((loco.controller.last_forces - measured)[contact])
    delivered_median = np.median(np.abs(np.concatenate(delivered_err)), axis=0)
    commanded_median = np.median(np.abs(np.concatenate(commanded_err)), axis=0)
    assert delivered_median[0] < commanded_median[0] / 3.0, (delivered_median, commanded_median)
    assert delivered_median[2] < 0.7 * commanded_median[2], (delivered_median, commanded_median)
