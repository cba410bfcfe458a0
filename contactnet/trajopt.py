"""Single-rigid-body trajectory optimization (SRBD) for the Solo12 quadruped.

Model (Orin 2013, as in the ContactNet paper): the robot is one rigid body with the whole mass at the
CoM; the inputs are the 3D ground reaction forces of the four feet (order FL, FR, HL, HR). State
``x = [p (3), v (3), rpy (3), omega (3)]``: CoM position and velocity in the world, base orientation as
roll-pitch-yaw (ZYX) angles, angular velocity in the world frame.

Continuous dynamics::

    p' = v
    v' = sum_i f_i / m + g
    rpy' = E(rpy)^-1 omega
    omega' = I_w^-1 (sum_i (r_i - p) x f_i - omega x I_w omega),   I_w = R I_body R^T

Discretization (forces constant over a node of ``dt``): positions and angles use the constant-acceleration
update ``q+ = q + dt q' + dt^2/2 q''`` (angle rate map frozen at the start of the node), velocities
``v+ = v + dt v'``.

Every solver works in the *heading frame* (rotated by the reference yaw about z, origin at the current
CoM xy) and returns world-frame trajectories and forces. The friction pyramids and the xy weights are
aligned with that frame (flat ground, normal +z): ``|f_x|, |f_y| <= mu f_z``, ``0 <= f_z <= fz_max`` on
stance feet, no force on swing feet. The CoM height stays within ``com_height_band_m`` of the reference
(the robot must neither fall nor jump: this is what makes a plan without support infeasible).

Cost (sum of squares, no 1/2): tracking over the nodes 1..N of the CoM reference (the user velocity
integrated from the current CoM xy, nominal height), level orientation at the reference yaw, zero angular
velocity, and of the reference forces (weight shared by the stance legs, vertical; zero in swing). The
returned ``cost`` is this value at the optimum (``trajectory_cost`` recomputes it).

Fast path: the SRBD linearized about the reference (translation exact; rotation about level orientation
at the reference yaw and zero angular velocity, moments about the reference CoM plus the first-order
tipping term ``(p - p_ref) x F_ref``). It is a convex QP, solved

* one at a time (``TrajectoryOptimizer.solve``, the MPC solve) as a sparse multiple-shooting QP built once
  in casadi and solved with parameters by piqp;
* many at a time (``TrajectoryOptimizer.solve_batch``, the candidate actions of one state) condensed onto
  the forces and solved by a batched Mehrotra interior-point method written for this structure
  (``solve_condensed_ipm``): the Newton system reduces, by the Woodbury identity, to one 6N x 6N Cholesky
  factorization per candidate and iteration (torch's batched LAPACK), everything else is vectorized
  numpy over the batch.

Reference: ``solver="nlp-ipopt"`` solves the nonlinear SRBD (multiple shooting, ipopt, warm-started).
``benchmark`` (and ``benchmarks/bench_trajopt.py``) times all of them.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

N_LEGS = 4
NX = 12
NU = 3 * N_LEGS
LEG_NAMES = ("FL", "FR", "HL", "HR")


# ----------------------------------------------------------------------------------------------------
# Parameters
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SrbdModel:
    """Physical parameters of the single rigid body (Solo12 defaults)."""

    mass_kg: float = 2.5
    inertia_body: tuple[float, ...] = (0.0300, 0.0, 0.0, 0.0, 0.0515, 0.0, 0.0, 0.0, 0.0681)
    gravity: float = 9.81
    mu: float = 0.6
    #: Upper bound on each foot's normal force: twice the robot weight (a single leg may carry the
    #: whole robot through a push with margin; Solo12's motors saturate about there).
    fz_max_n: float = 2.0 * 2.5 * 9.81
    #: The CoM height may deviate at most this much from the reference (nodes 1..N).
    com_height_band_m: float = 0.1

    def inertia_matrix(self) -> np.ndarray:
        """Body-frame inertia as a 3x3 array."""
        return np.asarray(self.inertia_body, dtype=float).reshape(3, 3)

    @property
    def weight_n(self) -> float:
        """Robot weight in newtons."""
        return self.mass_kg * self.gravity


@dataclass(frozen=True)
class TrajoptWeights:
    """Cost weights (per squared unit, summed over nodes; no 1/2)."""

    com_pos: tuple[float, float, float] = (100.0, 100.0, 300.0)
    com_vel: tuple[float, float, float] = (10.0, 10.0, 10.0)
    rpy: tuple[float, float, float] = (100.0, 100.0, 30.0)
    ang_vel: tuple[float, float, float] = (1.0, 1.0, 1.0)
    #: Weight of the force tracking, per N^2 (x, y, z).
    force: tuple[float, float, float] = (1e-3, 1e-3, 1e-3)
    #: The last node's state weight is multiplied by this.
    terminal_factor: float = 1.0

    def __post_init__(self) -> None:
        # the condensed QP needs a positive definite wrench-space Hessian and force Hessian
        positive = (*self.com_vel, *self.ang_vel, *self.force, self.terminal_factor)
        if min(positive) <= 0.0 or min(*self.com_pos, *self.rpy) < 0.0:
            raise ValueError("velocity, angular velocity and force weights must be > 0, the others >= 0")

    def state_weights(self) -> np.ndarray:
        """Diagonal state weight (12,)."""
        return np.array([*self.com_pos, *self.com_vel, *self.rpy, *self.ang_vel], dtype=float)

    def node_state_weights(self, n_nodes: int) -> np.ndarray:
        """State weights of nodes 1..N as (N, 12) (the terminal node scaled)."""
        q = np.tile(self.state_weights(), (n_nodes, 1))
        q[-1] *= self.terminal_factor
        return q


@dataclass(frozen=True)
class TrajoptConfig:
    """Horizon and solver choice."""

    n_nodes: int = 24
    dt_s: float = 0.04
    #: ``"auto"`` (fast paths), ``"qp-ipm"``, ``"qp-<casadi qpsol plugin>"`` or ``"nlp-ipopt"`` (nonlinear
    #: reference); see ``TrajectoryOptimizer``.
    solver: str = "auto"
    max_iter: int = 50
    #: Convergence tolerance (ipopt ``tol``; scaled residuals and relative gap of the interior-point method).
    tol: float = 1e-8

    @classmethod
    def for_candidates(cls, n_nodes: int = 8, tol: float = 1e-6) -> TrajoptConfig:
        """The configuration for ranking candidate actions: one step horizon, batched interior-point
        method, costs accurate to about ``tol`` relative (plenty to sort candidates)."""
        return cls(n_nodes=n_nodes, solver="qp-ipm", tol=tol)


@dataclass
class TrajoptProblem:
    """Parameters of one solve."""

    x0: np.ndarray  #: (12,) [com_pos_world, com_vel_world, rpy, ang_vel_world]
    contact: np.ndarray  #: (N, 4) bool, True = the leg is in stance at node k
    foot_pos_world: np.ndarray  #: (N, 4, 3) foot positions (meaningful where in stance)
    com_vel_ref_xy: np.ndarray  #: (2,) user velocity, world frame
    com_height_ref_m: float
    yaw_ref_rad: float = 0.0
    #: (2,) where the CoM xy reference starts (world); None: at the current CoM xy. A caller that
    #: keeps a reference path (e.g. the commanded velocity integrated over time) passes it here so
    #: that a push that moved the robot is also undone, not only stopped.
    com_xy_ref_start: np.ndarray | None = None

    def ref_xy_start(self) -> np.ndarray:
        return np.asarray(self.x0 if self.com_xy_ref_start is None else self.com_xy_ref_start, dtype=float)[0:2]


@dataclass
class TrajoptSolution:
    """Result of one solve. ``cost`` is the optimal objective value (what the ranking cost uses); it is
    ``inf`` when ``success`` is False (the value at exit, if any, is in ``info["cost_at_exit"]``)."""

    status: str  #: "ok", "max_iter", "infeasible" or "error: ..."
    success: bool
    cost: float
    x: np.ndarray  #: (N+1, 12), x[0] = x0
    forces_world: np.ndarray  #: (N, 4, 3)
    solve_time_s: float
    iterations: int
    info: dict = field(default_factory=dict)


# ----------------------------------------------------------------------------------------------------
# Contact schedules and references
# ----------------------------------------------------------------------------------------------------


def step_schedule(
    swing_legs: Sequence[int], n_stance_pre: int = 3, n_swing: int = 4, n_stance_post: int = 1
) -> np.ndarray:
    """Contact schedule of one step horizon, (n_stance_pre + n_swing + n_stance_post, 4) bool.

    All legs are in stance except ``swing_legs`` during the ``n_swing`` middle nodes.
    """
    n = n_stance_pre + n_swing + n_stance_post
    contact = np.ones((n, N_LEGS), dtype=bool)
    for leg in swing_legs:
        if not 0 <= leg < N_LEGS:
            raise ValueError(f"leg index {leg} not in 0..3")
        contact[n_stance_pre : n_stance_pre + n_swing, leg] = False
    return contact


def horizon_schedule(swing_legs_per_step: Sequence[Sequence[int]], **step_kwargs: int) -> np.ndarray:
    """Concatenate the step schedules of successive step horizons, (sum of nodes, 4) bool."""
    return np.concatenate([step_schedule(s, **step_kwargs) for s in swing_legs_per_step], axis=0)


def reference_forces(contact: np.ndarray, mass_kg: float, gravity: float) -> np.ndarray:
    """Reference forces (..., N, 4, 3): weight shared by the stance legs, vertical; zero in swing."""
    c = np.asarray(contact, dtype=float)
    n_stance = c.sum(axis=-1, keepdims=True)
    fz = np.divide(mass_kg * gravity * c, n_stance, out=np.zeros_like(c), where=n_stance > 0)
    f = np.zeros((*c.shape, 3))
    f[..., 2] = fz
    return f


def reference_states(problem: TrajoptProblem, n_nodes: int, dt_s: float) -> np.ndarray:
    """Reference state trajectory (N+1, 12).

    CoM xy integrates the user velocity from the reference start (default: the current CoM xy), CoM
    z is the nominal height, the velocity is the user velocity, the orientation is level at the
    reference yaw, no angular velocity.
    """
    v = np.asarray(problem.com_vel_ref_xy, dtype=float)
    t = dt_s * np.arange(n_nodes + 1)
    ref = np.zeros((n_nodes + 1, NX))
    ref[:, 0:2] = problem.ref_xy_start() + t[:, None] * v
    ref[:, 2] = problem.com_height_ref_m
    ref[:, 3:5] = v
    ref[:, 8] = problem.yaw_ref_rad
    return ref


# ----------------------------------------------------------------------------------------------------
# Nonlinear SRBD in numpy (reference for tests)
# ----------------------------------------------------------------------------------------------------


def _skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices (..., 3, 3) of vectors (..., 3)."""
    v = np.asarray(v, dtype=float)
    s = np.zeros((*v.shape[:-1], 3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def rotation_rpy(rpy: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of ZYX roll-pitch-yaw angles (..., 3): R = Rz(y) Ry(p) Rx(r)."""
    rpy = np.asarray(rpy, dtype=float)
    cr, sr = np.cos(rpy[..., 0]), np.sin(rpy[..., 0])
    cp, sp = np.cos(rpy[..., 1]), np.sin(rpy[..., 1])
    cy, sy = np.cos(rpy[..., 2]), np.sin(rpy[..., 2])
    r = np.empty((*rpy.shape[:-1], 3, 3))
    r[..., 0, 0], r[..., 0, 1], r[..., 0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    r[..., 1, 0], r[..., 1, 1], r[..., 1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    r[..., 2, 0], r[..., 2, 1], r[..., 2, 2] = -sp, cp * sr, cp * cr
    return r


def euler_rate_map(rpy: np.ndarray) -> np.ndarray:
    """Matrices T (..., 3, 3) with d(rpy)/dt = T(rpy) omega_world (ZYX angles, singular at pitch +-90 deg)."""
    rpy = np.asarray(rpy, dtype=float)
    cp, sp = np.cos(rpy[..., 1]), np.sin(rpy[..., 1])
    cy, sy = np.cos(rpy[..., 2]), np.sin(rpy[..., 2])
    t = np.zeros((*rpy.shape[:-1], 3, 3))
    t[..., 0, 0], t[..., 0, 1] = cy / cp, sy / cp
    t[..., 1, 0], t[..., 1, 1] = -sy, cy
    t[..., 2, 0], t[..., 2, 1], t[..., 2, 2] = cy * sp / cp, sy * sp / cp, 1.0
    return t


def srbd_step(
    model: SrbdModel, dt_s: float, x: np.ndarray, forces_world: np.ndarray, foot_pos_world: np.ndarray
) -> np.ndarray:
    """One discrete nonlinear SRBD step, vectorized over leading axes.

    ``x`` (..., 12), ``forces_world`` and ``foot_pos_world`` (..., 4, 3).
    """
    x = np.asarray(x, dtype=float)
    f = np.asarray(forces_world, dtype=float)
    p, v, rpy, w = x[..., 0:3], x[..., 3:6], x[..., 6:9], x[..., 9:12]
    acc = f.sum(axis=-2) / model.mass_kg + np.array([0.0, 0.0, -model.gravity])
    tau = np.cross(np.asarray(foot_pos_world, dtype=float) - p[..., None, :], f).sum(axis=-2)
    rot = rotation_rpy(rpy)
    inertia_w = rot @ model.inertia_matrix() @ np.swapaxes(rot, -1, -2)
    gyro = np.cross(w, (inertia_w @ w[..., None])[..., 0])
    w_dot = np.linalg.solve(inertia_w, (tau - gyro)[..., None])[..., 0]
    rate = (euler_rate_map(rpy) @ (w + 0.5 * dt_s * w_dot)[..., None])[..., 0]
    return np.concatenate(
        [p + dt_s * v + 0.5 * dt_s**2 * acc, v + dt_s * acc, rpy + dt_s * rate, w + dt_s * w_dot], axis=-1
    )


def dynamics_residual(
    model: SrbdModel, dt_s: float, x: np.ndarray, forces_world: np.ndarray, foot_pos_world: np.ndarray
) -> np.ndarray:
    """Residuals x[k+1] - step(x[k], f[k]) of a trajectory under the nonlinear SRBD, (N, 12).

    ``x`` is (N+1, 12), ``forces_world`` and ``foot_pos_world`` are (N, 4, 3).
    """
    x = np.asarray(x, dtype=float)
    return x[1:] - srbd_step(model, dt_s, x[:-1], forces_world, foot_pos_world)


def trajectory_cost(
    weights: TrajoptWeights,
    problem: TrajoptProblem,
    model: SrbdModel,
    dt_s: float,
    x: np.ndarray,
    forces_world: np.ndarray,
) -> float:
    """Objective value of a world-frame trajectory (N+1, 12) with forces (N, 4, 3), as every solver
    defines it: the errors are weighted in the heading frame (reference yaw)."""
    n = np.shape(forces_world)[0]
    batch = ProblemBatch.of([problem], n)
    rot = batch.rotations()
    x_local = _states_to_frame(np.asarray(x, dtype=float)[None], rot, batch.origins(), batch.yaw)[0]
    err = x_local[1:] - batch.in_heading_frame().reference_states(dt_s)[0, 1:]
    forces = np.asarray(forces_world, dtype=float) @ rot[0]
    f_err = forces - reference_forces(batch.contact[0], model.mass_kg, model.gravity)
    return float(
        np.sum(weights.node_state_weights(n) * err**2) + np.sum(np.asarray(weights.force) * f_err**2)
    )


# ----------------------------------------------------------------------------------------------------
# Linearized SRBD, condensed onto the forces (numpy, batched over candidates)
# ----------------------------------------------------------------------------------------------------


@dataclass
class CondensedQp:
    """Batch of B condensed QPs in the foot forces f (B, N, 4, 3)::

        min  1/2 f' H f + g' f + const,   H = diag(h_force) + J' Q_w J,   g = J' g_w + g_force
        s.t. friction pyramid and 0 <= f_z <= fz_max on stance feet, f = 0 on swing feet,
             z_lo <= Gz J f <= z_hi          (CoM height band, relative to the free response)

    ``J`` maps the forces of node k to the node wrench (total force, moment about the linearization
    point ``pbar_k``): ``w_k = sum_i J_ki f_ki`` with ``J_ki = [I; [r_ki - pbar_k]x]``. The states of
    nodes 1..N are ``x_free + G w``; ``G`` depends only on the reference yaw and on which nodes have
    support, so it is shared by the candidates of one state (``gamma[group]``).
    """

    x0: np.ndarray  #: (B, 12)
    contact: np.ndarray  #: (B, N, 4) bool
    arm: np.ndarray  #: (B, N, 4, 3) moment arms r_ki - pbar_k
    group: np.ndarray  #: (B,) index into gamma
    gamma: np.ndarray  #: (G, 12N, 6N) state sensitivity to the wrenches
    q_w: np.ndarray  #: (B, 6N, 6N) wrench-space Hessian 2 G' W G (positive definite)
    q_w_inv: np.ndarray  #: (B, 6N, 6N) its inverse
    g_w: np.ndarray  #: (B, 6N) wrench-space gradient 2 G' W (x_free - x_ref)
    h_force: np.ndarray  #: (3,) diagonal force Hessian 2 W_f
    g_force: np.ndarray  #: (B, N, 4, 3) force gradient -2 W_f f_ref
    const: np.ndarray  #: (B,) constant term of the cost
    x_free: np.ndarray  #: (B, N, 12) states of nodes 1..N under zero wrenches
    z_lo: np.ndarray  #: (B, N) lower bound of Gz J f
    z_hi: np.ndarray  #: (B, N) upper bound of Gz J f
    mu: float
    fz_max: float

    @property
    def batch(self) -> int:
        return self.contact.shape[0]

    @property
    def n_nodes(self) -> int:
        return self.contact.shape[1]

    def take(self, keep: np.ndarray) -> CondensedQp:
        """The QPs of a subset of the candidates (boolean mask or indices)."""
        fields = {k: getattr(self, k) for k in self.__dataclass_fields__}
        for k, v in fields.items():
            if isinstance(v, np.ndarray) and k not in ("gamma", "h_force"):
                fields[k] = v[keep]
        return CondensedQp(**fields)

    def wrenches(self, forces: np.ndarray) -> np.ndarray:
        """Node wrenches (B, N, 6) of forces (B, N, 4, 3)."""
        return np.concatenate([forces.sum(axis=2), np.cross(self.arm, forces).sum(axis=2)], axis=-1)

    def states(self, forces: np.ndarray) -> np.ndarray:
        """State trajectories (B, N+1, 12) of the linearized model under forces (B, N, 4, 3)."""
        w = self.wrenches(forces).reshape(self.batch, -1, 1)
        x = self.x_free + (self.gamma[self.group] @ w).reshape(self.x_free.shape)
        return np.concatenate([self.x0[:, None], x], axis=1)


def _linear_node_matrices(
    model: SrbdModel, dt_s: float, yaw: np.ndarray, support: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linearized node dynamics ``x+ = A x + B w + c``, w = (total force, moment about ``pbar``).

    ``yaw`` (G,), ``support`` (G, N) bool (some leg in stance: the reference forces carry the weight
    ``F_ref``). ``A`` includes the tipping term ``d(omega')/dp = I^-1 [F_ref]x`` (returned separately as
    ``tipping``: with gravity it makes ``c = -tipping pbar + gravity terms``, see ``_free_response``).
    Returns A (G, N, 12, 12), B (G, N, 12, 6), tipping (G, N, 12, 3).
    """
    g, n = support.shape
    rz = rotation_rpy(np.stack([np.zeros_like(yaw), np.zeros_like(yaw), yaw], axis=-1))  # (G, 3, 3)
    i_inv = rz @ np.linalg.inv(model.inertia_matrix()) @ np.swapaxes(rz, -1, -2)  # world inverse inertia
    t_map = np.swapaxes(rz, -1, -2)  # Euler rate map at level orientation
    f_ref = np.zeros((g, n, 3))
    f_ref[..., 2] = model.weight_n * support
    omega_dot_p = i_inv[:, None] @ _skew(f_ref)  # d(omega')/dp = I^-1 [F_ref]x, (G, N, 3, 3)
    tipping = np.zeros((g, n, NX, 3))
    tipping[..., 6:9, :] = 0.5 * dt_s**2 * t_map[:, None] @ omega_dot_p
    tipping[..., 9:12, :] = dt_s * omega_dot_p
    a = np.zeros((g, n, NX, NX))
    a[..., range(NX), range(NX)] = 1.0
    a[..., 0:3, 3:6] = dt_s * np.eye(3)
    a[..., 6:9, 9:12] = dt_s * t_map[:, None]
    a[..., 0:3] += tipping
    bw = np.zeros((g, n, NX, 6))
    bw[..., 0:3, 0:3] = 0.5 * dt_s**2 / model.mass_kg * np.eye(3)
    bw[..., 3:6, 0:3] = dt_s / model.mass_kg * np.eye(3)
    bw[..., 6:9, 3:6] = (0.5 * dt_s**2 * t_map @ i_inv)[:, None]
    bw[..., 9:12, 3:6] = dt_s * i_inv[:, None]
    return a, bw, tipping


def _wrench_sensitivity(a: np.ndarray, bw: np.ndarray) -> np.ndarray:
    """G (G, 12N, 6N): states of nodes 1..N as linear functions of the node wrenches."""
    g, n = a.shape[:2]
    gamma = np.zeros((g, n, NX, n * 6))
    prev = np.zeros((g, NX, n * 6))
    for k in range(n):
        prev = a[:, k] @ prev
        prev[:, :, 6 * k : 6 * k + 6] = bw[:, k]
        gamma[:, k] = prev
    return gamma.reshape(g, n * NX, n * 6)


def _free_response(
    model: SrbdModel, dt_s: float, a: np.ndarray, tipping: np.ndarray, x0: np.ndarray, p_bar: np.ndarray
) -> np.ndarray:
    """States (B, N, 12) of nodes 1..N under zero wrenches (gravity and tipping terms only)."""
    b, n = p_bar.shape[:2]
    c = -(tipping @ p_bar[..., None])[..., 0]
    c[..., 0:3] += 0.5 * dt_s**2 * np.array([0.0, 0.0, -model.gravity])
    c[..., 3:6] += dt_s * np.array([0.0, 0.0, -model.gravity])
    x_free = np.zeros((b, n, NX))
    x = x0
    for k in range(n):
        x = (a[:, k] @ x[..., None])[..., 0] + c[:, k]
        x_free[:, k] = x
    return x_free


@dataclass(frozen=True)
class _SharedMatrices:
    """Condensing matrices that depend only on the reference yaw and on which nodes have support."""

    a: np.ndarray  #: (N, 12, 12) node transition
    tipping: np.ndarray  #: (N, 12, 3) tipping term
    gamma: np.ndarray  #: (12N, 6N) state sensitivity G
    gamma_w: np.ndarray  #: (6N, 12N) G' W
    q_w: np.ndarray  #: (6N, 6N) 2 G' W G
    q_w_inv: np.ndarray  #: (6N, 6N)

    @classmethod
    def build(
        cls, model: SrbdModel, weights: TrajoptWeights, dt_s: float, yaw: float, support: np.ndarray
    ) -> _SharedMatrices:
        a, bw, tipping = _linear_node_matrices(model, dt_s, np.array([yaw]), support[None])
        gamma = _wrench_sensitivity(a, bw)[0]
        gamma_w = gamma.T * weights.node_state_weights(len(support)).reshape(-1)
        q_w = 2.0 * gamma_w @ gamma
        q_w = 0.5 * (q_w + q_w.T)
        return cls(
            a=a[0], tipping=tipping[0], gamma=gamma, gamma_w=gamma_w, q_w=q_w, q_w_inv=np.linalg.inv(q_w)
        )


@dataclass
class ProblemBatch:
    """Problems of one horizon stacked into arrays (B leading)."""

    x0: np.ndarray  #: (B, 12)
    contact: np.ndarray  #: (B, N, 4) bool
    feet: np.ndarray  #: (B, N, 4, 3)
    ref_xy: np.ndarray  #: (B, 2) start of the CoM xy reference
    vel: np.ndarray  #: (B, 2)
    height: np.ndarray  #: (B,)
    yaw: np.ndarray  #: (B,)

    @classmethod
    def of(cls, problems: Sequence[TrajoptProblem], n_nodes: int) -> ProblemBatch:
        """Stack problems; raise ValueError on a wrong shape (a programming error)."""
        for problem in problems:
            _check_shapes(problem, n_nodes)
        contact = np.array([p.contact for p in problems], dtype=bool).reshape(-1, n_nodes, N_LEGS)
        feet = np.array([p.foot_pos_world for p in problems], dtype=float).reshape(-1, n_nodes, N_LEGS, 3)
        return cls(
            x0=np.array([p.x0 for p in problems], dtype=float).reshape(-1, NX),
            contact=contact,
            feet=np.where(contact[..., None], feet, 0.0),  # swing-foot positions are irrelevant (may be NaN)
            ref_xy=np.array([p.ref_xy_start() for p in problems], dtype=float).reshape(-1, 2),
            vel=np.array([p.com_vel_ref_xy for p in problems], dtype=float).reshape(-1, 2),
            height=np.array([p.com_height_ref_m for p in problems], dtype=float),
            yaw=np.array([p.yaw_ref_rad for p in problems], dtype=float),
        )

    def __len__(self) -> int:
        return len(self.x0)

    def take(self, keep: np.ndarray) -> ProblemBatch:
        return ProblemBatch(*(getattr(self, f)[keep] for f in self.__dataclass_fields__))

    def finite(self) -> np.ndarray:
        """(B,) True where every number is finite."""
        scalars = np.isfinite(np.c_[self.x0, self.ref_xy, self.vel, self.height, self.yaw]).all(axis=1)
        return np.isfinite(self.feet).all(axis=(1, 2, 3)) & scalars

    def rotations(self) -> np.ndarray:
        """Rotations (B, 3, 3) about z by the reference yaws."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        rot = np.zeros((len(self), 3, 3))
        rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1], rot[:, 2, 2] = c, -s, s, c, 1.0
        return rot

    def origins(self) -> np.ndarray:
        """Heading-frame origins (B, 3): the current CoM xy."""
        return np.c_[self.x0[:, 0:2], np.zeros(len(self))]

    def in_heading_frame(self) -> ProblemBatch:
        """The problems expressed in their heading frames (reference yaw 0, CoM xy at the origin)."""
        rot, origin = self.rotations(), self.origins()
        return ProblemBatch(
            x0=_states_to_frame(self.x0, rot, origin, self.yaw),
            contact=self.contact,
            feet=(self.feet - origin[:, None, None]) @ rot[:, None],
            ref_xy=((self.ref_xy - origin[:, 0:2])[:, None] @ rot[:, 0:2, 0:2])[:, 0],
            vel=(self.vel[:, None] @ rot[:, 0:2, 0:2])[:, 0],
            height=self.height,
            yaw=np.zeros(len(self)),
        )

    def reference_states(self, dt_s: float) -> np.ndarray:
        """Reference state trajectories (B, N+1, 12), as ``reference_states``."""
        n = self.contact.shape[1]
        t = dt_s * np.arange(n + 1)
        ref = np.zeros((len(self), n + 1, NX))
        ref[..., 0:2] = self.ref_xy[:, None] + t[:, None] * self.vel[:, None]
        ref[..., 2] = self.height[:, None]
        ref[..., 3:5] = self.vel[:, None]
        ref[..., 8] = self.yaw[:, None]
        return ref


def _states_to_frame(x: np.ndarray, rot: np.ndarray, origin: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """World states (B, ..., 12) -> frames rotated by ``rot`` (B, 3, 3) about z with ``origin`` (B, 3)."""
    extra = (1,) * (x.ndim - 2)
    r = rot.reshape(len(rot), *extra, 3, 3)
    out = np.array(x, dtype=float, copy=True)
    out[..., 0:3] = ((out[..., 0:3] - origin.reshape(len(rot), *extra, 3))[..., None, :] @ r)[..., 0, :]
    out[..., 3:6] = (out[..., None, 3:6] @ r)[..., 0, :]
    out[..., 8] -= yaw.reshape(len(rot), *extra)
    out[..., 9:12] = (out[..., None, 9:12] @ r)[..., 0, :]
    return out


def _states_from_frame(x: np.ndarray, rot: np.ndarray, origin: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Inverse of ``_states_to_frame``."""
    extra = (1,) * (x.ndim - 2)
    rt = np.swapaxes(rot, 1, 2).reshape(len(rot), *extra, 3, 3)
    out = np.array(x, dtype=float, copy=True)
    out[..., 0:3] = (out[..., None, 0:3] @ rt)[..., 0, :] + origin.reshape(len(rot), *extra, 3)
    out[..., 3:6] = (out[..., None, 3:6] @ rt)[..., 0, :]
    out[..., 8] += yaw.reshape(len(rot), *extra)
    out[..., 9:12] = (out[..., None, 9:12] @ rt)[..., 0, :]
    return out


def build_condensed_qp(
    model: SrbdModel,
    weights: TrajoptWeights,
    dt_s: float,
    problems: Sequence[TrajoptProblem] | ProblemBatch,
    cache: dict | None = None,
) -> CondensedQp:
    """Linearize about the references and condense the QPs of a batch of problems (same N).

    The friction pyramids are aligned with the frame of the problems. ``cache`` (a dict owned by the
    caller, reused only with the same model, weights and dt) keeps the matrices shared by problems with
    the same reference yaw and support pattern.
    """
    if not isinstance(problems, ProblemBatch):
        problems = ProblemBatch.of(problems, np.shape(problems[0].contact)[0])
    batch, b, n = problems, len(problems), problems.contact.shape[1]
    x_ref = batch.reference_states(dt_s)
    support = batch.contact.any(axis=2)
    keys = [(float(y), sup.tobytes()) for y, sup in zip(batch.yaw, support, strict=True)]
    unique = list(dict.fromkeys(keys))
    group = np.array([unique.index(k) for k in keys]) if len(unique) > 1 else np.zeros(b, dtype=int)
    cache = {} if cache is None else cache
    if len(cache) > 512:  # acyclic gaits keep few support patterns; never let it grow without bound
        cache.clear()
    shared = []
    for yaw, sup in unique:
        if (n, yaw, sup) not in cache:
            cache[(n, yaw, sup)] = _SharedMatrices.build(
                model, weights, dt_s, yaw, np.frombuffer(sup, dtype=bool)
            )
        shared.append(cache[(n, yaw, sup)])

    def per_candidate(name: str) -> np.ndarray:
        stacked = np.stack([getattr(m, name) for m in shared])
        return np.broadcast_to(stacked[0], (b, *stacked.shape[1:])) if len(shared) == 1 else stacked[group]

    p_bar = x_ref[:, :n, 0:3].copy()
    p_bar[:, 0] = batch.x0[:, 0:3]  # exact moment arms at the first node
    x_free = _free_response(model, dt_s, per_candidate("a"), per_candidate("tipping"), batch.x0, p_bar)
    w_state = weights.node_state_weights(n).reshape(-1)
    err = (x_free - x_ref[:, 1:]).reshape(b, -1)
    w_force = np.asarray(weights.force, dtype=float)
    f_ref = reference_forces(batch.contact, model.mass_kg, model.gravity)
    z_rel = x_ref[:, 1:, 2] - x_free[..., 2]
    band = model.com_height_band_m
    return CondensedQp(
        x0=batch.x0,
        contact=batch.contact,
        arm=batch.feet - p_bar[:, :, None, :],
        group=group,
        gamma=np.stack([m.gamma for m in shared]),
        q_w=per_candidate("q_w"),
        q_w_inv=per_candidate("q_w_inv"),
        g_w=2.0 * (per_candidate("gamma_w") @ err[..., None])[..., 0],
        h_force=2.0 * w_force,
        g_force=-2.0 * w_force * f_ref,
        const=err**2 @ w_state + (f_ref**2).reshape(b, -1, 3).sum(axis=1) @ w_force,
        x_free=x_free,
        z_lo=z_rel - band,
        z_hi=z_rel + band,
        mu=model.mu,
        fz_max=model.fz_max_n,
    )


# ----------------------------------------------------------------------------------------------------
# Batched primal-dual interior-point method for the condensed QP
# ----------------------------------------------------------------------------------------------------


def _foot_rows(mu: float) -> np.ndarray:
    """Rows (6, 3) of the foot constraints C f <= d: friction pyramid, -f_z <= 0, f_z <= fz_max."""
    return np.array(
        [
            [1.0, 0.0, -mu],
            [-1.0, 0.0, -mu],
            [0.0, 1.0, -mu],
            [0.0, -1.0, -mu],
            [0.0, 0.0, -1.0],
            [0.0, 0.0, 1.0],
        ]
    )


class _Cholesky:
    """Cholesky factorization of a batch of symmetric positive definite matrices (B, n, n).

    One matrix: LAPACK potrf directly (least overhead). Several: torch's batched Cholesky when available
    (numpy has no batched triangular solve), numpy's batched solve otherwise.
    """

    def __init__(self, mats: np.ndarray) -> None:
        self._single = self._torch = None
        self.ok = np.ones(mats.shape[0], dtype=bool)
        if mats.shape[0] == 1:
            from scipy.linalg import lapack

            self._lapack = lapack
            factor, info = lapack.dpotrf(mats[0], lower=True, clean=False)
            self._single, self.ok[0] = factor, info == 0
            return
        try:
            import torch
        except ImportError:  # pragma: no cover - torch is a project dependency
            self._mats = mats
            self.ok = np.isfinite(mats).all(axis=(1, 2))
            return
        self._torch = torch
        self._factor, info = torch.linalg.cholesky_ex(torch.from_numpy(mats))
        self.ok = info.numpy() == 0

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solutions (B, n) for right-hand sides (B, n); NaN where the factorization failed."""
        if self._single is not None:
            out = self._lapack.dpotrs(self._single, rhs[0], lower=True)[0][None]
        elif self._torch is None:
            out = np.linalg.solve(self._mats, rhs[..., None])[..., 0]
        else:
            rhs_t = self._torch.from_numpy(rhs[..., None])
            out = self._torch.cholesky_solve(rhs_t, self._factor).numpy()[..., 0]
        return np.where(self.ok[:, None], out, np.nan)


class _IpmOperators:
    """Operators of a condensed QP batch for the interior-point iterations.

    Forces are handled as (B, N, 12) (the 4 feet of a node side by side). Constraint rows, per candidate:
    ``[foot rows (N*4*6), height upper (N), height lower (N)]`` (the height rows only ``with_height``),
    ``A f + s = b``, ``s >= 0``. Swing feet have zero columns in the wrench map and masked rows.
    """

    #: attributes with one entry per candidate (sliced by ``take``)
    PER_CANDIDATE = (
        "stance",
        "foot_mask",
        "jac",
        "jac_t",
        "gz",
        "gz_t",
        "rhs",
        "row_mask",
        "n_rows",
        "g_force",
        "q_w",
        "q_w_inv",
        "gz_qi",
        "gz_qi_gz",
        "g_w",
        "const",
        "scale_d",
    )

    def __init__(self, qp: CondensedQp, with_height: bool) -> None:
        b, n = qp.batch, qp.n_nodes
        self.n_nodes, self.mu, self.with_height = n, qp.mu, with_height
        self.stance = np.repeat(qp.contact.astype(float), 3, axis=2)  # (B, N, 12)
        jac = np.zeros((b, n, N_LEGS, 6, 3))
        jac[..., 0:3, :] = np.eye(3)
        jac[..., 3:6, :] = _skew(qp.arm)
        jac *= qp.contact[..., None, None]  # (B, N, 4, 6, 3), zero for swing feet
        self.foot_mask = qp.contact[..., None, None].astype(float)  # (B, N, 4, 1, 1)
        self.jac = np.swapaxes(jac, 2, 3).reshape(b, n, 6, NU)  # (B, N, 6, 12)
        self.jac_t = np.swapaxes(self.jac, -1, -2)
        # the CoM height depends on the vertical forces only: rows of G restricted to the F_z columns
        self.gz = qp.gamma[:, 2::NX, 2::6][qp.group]  # (B, N, N)
        self.gz_t = np.swapaxes(self.gz, 1, 2)
        self.gz_qi = self.gz @ qp.q_w_inv[:, 2::6, :]  # (B, N, 6N) = Gz Q_w^-1
        self.gz_qi_gz = self.gz_qi[:, :, 2::6] @ self.gz_t  # (B, N, N) = Gz Q_w^-1 Gz'
        self.c_t = _foot_rows(qp.mu).T  # (3, 6)
        self.n_foot = n * N_LEGS * 6
        n_h = 2 * n if with_height else 0
        foot_rhs = np.broadcast_to(np.array([0.0, 0.0, 0.0, 0.0, 0.0, qp.fz_max]), (b, n * N_LEGS, 6))
        height_rhs = [qp.z_hi, -qp.z_lo] if with_height else []
        self.rhs = np.concatenate([foot_rhs.reshape(b, -1), *height_rhs], axis=1)
        foot_mask = np.repeat(qp.contact.reshape(b, -1).astype(float), 6, axis=1)
        self.row_mask = np.concatenate([foot_mask, np.ones((b, n_h))], axis=1)
        self.n_rows = self.row_mask.sum(axis=1)
        self.inv_scale_p = 1.0 / np.concatenate([np.full(self.n_foot, 1.0 + qp.fz_max), np.ones(n_h)])
        self.h_force_3 = qp.h_force
        self.h_force = np.tile(qp.h_force, N_LEGS)  # (12,)
        self.g_force = qp.g_force.reshape(b, n, NU) * self.stance
        self.q_w, self.q_w_inv, self.g_w, self.const = qp.q_w, qp.q_w_inv, qp.g_w, qp.const
        self.scale_d = 1.0 + np.abs(self.wrench_adjoint(self.g_w) + self.g_force).reshape(b, -1).max(axis=1)

    def take(self, keep: np.ndarray) -> _IpmOperators:
        """The operators of a subset of the candidates (boolean mask)."""
        sub = object.__new__(_IpmOperators)
        sub.__dict__.update(self.__dict__)
        for name in self.PER_CANDIDATE:
            setattr(sub, name, getattr(self, name)[keep])
        return sub

    def wrench(self, f: np.ndarray) -> np.ndarray:
        """J f (B, 6N) for f (B, N, 12)."""
        return (self.jac @ f[..., None]).reshape(f.shape[0], -1)

    def wrench_adjoint(self, y: np.ndarray) -> np.ndarray:
        """J' y (B, N, 12) for y (B, 6N), zero on swing feet."""
        return (self.jac_t @ y.reshape(y.shape[0], self.n_nodes, 6, 1))[..., 0]

    def height(self, w: np.ndarray) -> np.ndarray:
        """CoM height response Gz w (B, N) to the wrenches w (B, 6N)."""
        return (self.gz @ w[:, 2::6, None])[..., 0]

    def rows(self, f: np.ndarray, w: np.ndarray) -> np.ndarray:
        """A f (B, m), given w = J f."""
        b = f.shape[0]
        foot = (f.reshape(b, -1, 3) @ self.c_t).reshape(b, -1)
        if not self.with_height:
            return foot
        u = self.height(w)
        return np.concatenate([foot, u, -u], axis=1)

    def adjoint(self, v: np.ndarray, y_extra: np.ndarray | None) -> np.ndarray:
        """A' v + J' y_extra (B, N, 12) for v (B, m) and a wrench-space y_extra (B, 6N) or None."""
        b, n, nf = v.shape[0], self.n_nodes, self.n_foot
        y = np.zeros((b, 6 * n)) if y_extra is None else y_extra.copy()
        if self.with_height:
            y[:, 2::6] += (self.gz_t @ (v[:, nf : nf + n] - v[:, nf + n :])[..., None])[..., 0]
        v_foot = v[:, :nf].reshape(b, n * N_LEGS, 6) @ self.c_t.T
        return v_foot.reshape(b, n, NU) * self.stance + self.wrench_adjoint(y)


class _Newton:
    """Reduced Newton system ``(H + A' W A) dx = r`` of one interior-point iteration.

    ``H + A'WA = R' + J' Q' J`` with ``R'`` block diagonal per foot (3x3) and ``Q' = Q_w + Gz' W_h Gz``
    (6N x 6N). By the Woodbury identity ``(R' + J'Q'J)^-1 = P - P J' S^-1 J P`` with ``P = R'^-1`` and
    ``S = Q'^-1 + J P J'`` (symmetric positive definite, 6N x 6N): ``J P J'`` is block diagonal per node
    and ``Q'^-1`` follows from the fixed ``Q_w^-1`` by an N x N Woodbury correction for the height rows,
    so there is one dense 6N x 6N Cholesky factorization per iteration.
    """

    def __init__(self, ops: _IpmOperators, w_rows: np.ndarray) -> None:
        b, n, nf = w_rows.shape[0], ops.n_nodes, ops.n_foot
        self.ops = ops
        p_feet = self._foot_block_inverse(ops, w_rows[:, :nf].reshape(b, n, N_LEGS, 6)) * ops.foot_mask
        self.p_blk = np.zeros((b, n, NU, NU))  # P per node, block diagonal over the feet
        for leg in range(N_LEGS):
            self.p_blk[:, :, 3 * leg : 3 * leg + 3, 3 * leg : 3 * leg + 3] = p_feet[:, :, leg]
        m_blk = ops.jac @ self.p_blk @ ops.jac_t  # J P J' per node (B, N, 6, 6)
        s_mat = ops.q_w_inv.copy()
        diag = np.arange(n)
        s_mat.reshape(b, n, 6, n, 6)[:, diag, :, diag, :] += m_blk.swapaxes(0, 1)
        if ops.with_height:
            r = np.sqrt(w_rows[:, nf : nf + n] + w_rows[:, nf + n :])
            core = np.linalg.inv(np.eye(n) + r[:, :, None] * ops.gz_qi_gz * r[:, None, :])
            ru = r[..., None] * ops.gz_qi  # (B, N, 6N); Q_w^-1 - Q'^-1 = U' r (I + r G r)^-1 r U
            s_mat -= np.swapaxes(ru, 1, 2) @ core @ ru
        self.chol = _Cholesky(s_mat)

    @staticmethod
    def _foot_block_inverse(ops: _IpmOperators, w: np.ndarray) -> np.ndarray:
        """Inverse (B, N, 4, 3, 3) of diag(h) + C' diag(w) C in closed form.

        For the rows of ``_foot_rows`` the block is [[a, 0, b], [0, c, d], [b, d, e]].
        """
        h, mu = ops.h_force_3, ops.mu
        a = h[0] + w[..., 0] + w[..., 1]
        c = h[1] + w[..., 2] + w[..., 3]
        e = h[2] + mu * mu * w[..., 0:4].sum(axis=-1) + w[..., 4] + w[..., 5]
        bb = mu * (w[..., 1] - w[..., 0])
        d = mu * (w[..., 3] - w[..., 2])
        out = np.empty((*a.shape, 3, 3))
        out[..., 0, 0] = c * e - d * d
        out[..., 0, 1] = out[..., 1, 0] = bb * d
        out[..., 0, 2] = out[..., 2, 0] = -bb * c
        out[..., 1, 1] = a * e - bb * bb
        out[..., 1, 2] = out[..., 2, 1] = -a * d
        out[..., 2, 2] = a * c
        return out / (a * out[..., 0, 0] - bb * bb * c)[..., None, None]

    def apply_p(self, v: np.ndarray) -> np.ndarray:
        """P v for v (B, N, 12)."""
        return (self.p_blk @ v[..., None])[..., 0]

    def solve(self, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """dx (B, N, 12) for rhs (B, N, 12), and J dx (B, 6N)."""
        y = self.apply_p(rhs)
        wy = self.ops.wrench(y)
        corr = self.apply_p(self.ops.wrench_adjoint(self.chol.solve(wy)))
        return y - corr, wy - self.ops.wrench(corr)


def _max_step(v: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """Largest alpha in [0, 1] per row with v + alpha dv >= 0 (v > 0)."""
    ratio = np.where(dv < 0.0, v / np.maximum(-dv, 1e-300), np.inf)
    return np.minimum(1.0, ratio.min(axis=1))


@dataclass
class IpmResult:
    """Per-candidate result of the batched interior-point method."""

    forces: np.ndarray  #: (B, N, 4, 3)
    cost: np.ndarray  #: (B,)
    status: list[str]
    iterations: np.ndarray  #: (B,) int


@dataclass
class _Iterate:
    """Primal-dual iterate of the candidates still in the batch."""

    f: np.ndarray  #: (B, N, 12) forces
    w: np.ndarray  #: (B, 6N) wrenches J f
    s: np.ndarray  #: (B, m) slacks
    z: np.ndarray  #: (B, m) multipliers

    def take(self, keep: np.ndarray) -> _Iterate:
        return _Iterate(self.f[keep], self.w[keep], self.s[keep], self.z[keep])

    def moved(self, d: tuple[np.ndarray, ...], alpha: np.ndarray) -> _Iterate:
        a = alpha[:, None]
        return _Iterate(self.f + a[..., None] * d[0], self.w + a * d[1], self.s + a * d[2], self.z + a * d[3])


@dataclass
class _Residuals:
    """Residuals and convergence measure of an iterate."""

    dual: np.ndarray  #: (B, N, 12)
    prim: np.ndarray  #: (B, m)
    obj: np.ndarray  #: (B,)
    error: np.ndarray  #: (B,) max of the scaled primal and dual residuals and the relative duality gap

    @classmethod
    def of(cls, ops: _IpmOperators, it: _Iterate) -> _Residuals:
        y_lin = (ops.q_w @ it.w[..., None])[..., 0] + ops.g_w
        lin = ops.h_force * it.f + ops.g_force
        r_dual = lin + ops.adjoint(it.z, y_lin)
        r_prim = (ops.rows(it.f, it.w) + it.s - ops.rhs) * ops.row_mask
        obj = 0.5 * ((it.f * (lin + ops.g_force)).sum(axis=(1, 2)) + (it.w * (y_lin + ops.g_w)).sum(axis=1))
        obj += ops.const
        error = np.maximum.reduce(
            [
                np.abs(r_prim * ops.inv_scale_p).max(axis=1),
                np.abs(r_dual).reshape(len(obj), -1).max(axis=1) / ops.scale_d,
                (it.s * it.z).sum(axis=1) / (1.0 + np.abs(obj)),
            ]
        )
        return cls(dual=r_dual, prim=r_prim, obj=np.where(np.isfinite(error), obj, np.nan), error=error)

    def take(self, keep: np.ndarray) -> _Residuals:
        return _Residuals(self.dual[keep], self.prim[keep], self.obj[keep], self.error[keep])


def _ipm_direction(ops: _IpmOperators, it: _Iterate, res: _Residuals) -> tuple[np.ndarray, ...]:
    """Mehrotra predictor-corrector direction (df, dw, ds, dz) of one iteration."""
    s, z = it.s, it.z
    w_rows = z / s
    newton = _Newton(ops, w_rows)

    def direction(r_comp: np.ndarray) -> tuple[np.ndarray, ...]:
        df, dw = newton.solve(-res.dual - ops.adjoint(w_rows * res.prim - r_comp / s, None))
        ds = (-res.prim - ops.rows(df, dw)) * ops.row_mask
        return df, dw, ds, -(r_comp + z * ds) / s

    sz = s * z
    mu = sz.sum(axis=1) / ops.n_rows
    _, _, ds, dz = direction(sz)
    alpha = np.minimum(_max_step(s, ds), _max_step(z, dz))[:, None]
    mu_aff = ((s + alpha * ds) * (z + alpha * dz)).sum(axis=1) / ops.n_rows
    sigma = np.minimum(mu_aff / np.maximum(mu, 1e-300), 1.0) ** 3
    return direction(sz + ds * dz - (sigma * mu)[:, None] * ops.row_mask)


#: An iterate whose error is below this is an acceptable solution when the iterations stall.
IPM_ACCEPTABLE = 1e-6
#: Barrier weights z/s beyond this exhaust double precision: the candidate stops there.
IPM_MAX_WEIGHT = 1e13
#: Multipliers beyond this mean the height band cannot be met (infeasible problem).
IPM_MAX_MULTIPLIER = 1e10


def _ipm_run(qp: CondensedQp, with_height: bool, max_iter: int, tol: float, mu0: float = 0.1) -> IpmResult:
    """Interior-point iterations on a batch.

    Each candidate keeps its best iterate (smallest error). It stops when converged (error < ``tol``),
    infeasible (multipliers diverge; only possible with the height rows: without them zero forces are
    feasible), stalled (non-finite direction, barrier weights beyond double precision, error growing
    100x over its best) or out of iterations; a stalled candidate whose best error is below
    ``IPM_ACCEPTABLE`` is solved. Finished candidates are frozen and, once a quarter of the batch is
    finished, dropped from it.
    """
    ops = _IpmOperators(qp, with_height)
    b, n = qp.batch, qp.n_nodes
    f = -ops.g_force / ops.h_force  # the reference forces: strictly inside the pyramids (zero in swing)
    w = ops.wrench(f)
    s = np.where(ops.row_mask > 0, np.maximum(ops.rhs - ops.rows(f, w), 1e-2), 1.0)
    it = _Iterate(f, w, s, mu0 * ops.row_mask / s)
    idx = np.arange(b)  # candidates in the batch
    live = np.ones(b, dtype=bool)  # in the batch and not finished
    stalled = np.zeros(b, dtype=bool)
    best = np.full(b, np.inf)
    out = IpmResult(np.zeros((b, n, NU)), np.full(b, np.nan), ["max_iter"] * b, np.zeros(b, dtype=int))
    for k in range(max_iter + 1):
        res = _Residuals.of(ops, it)
        better = live & (res.error < best[idx])
        out.forces[idx[better]], out.cost[idx[better]] = it.f[better] * ops.stance[better], res.obj[better]
        best[idx[better]] = res.error[better]
        infeasible = with_height & (it.z.max(axis=1) > IPM_MAX_MULTIPLIER)
        stalled |= ((it.z / it.s).max(axis=1) > IPM_MAX_WEIGHT) | (res.error > 100.0 * best[idx])
        finished = live & ((res.error < tol) | infeasible | stalled | (k == max_iter))
        for i, inf in zip(idx[finished], infeasible[finished], strict=True):
            out.status[i] = _ipm_status(best[i], tol, bool(inf), k == max_iter)
        live &= ~finished
        if not live.any():
            break
        if (~live).sum() * 4 >= len(live):
            idx, ops, it, res, live = idx[live], ops.take(live), it.take(live), res.take(live), live[live]
        out.iterations[idx[live]] += 1
        d = _ipm_direction(ops, it, res)
        stalled = ~(
            np.isfinite(d[2]).all(axis=1) & np.isfinite(d[3]).all(axis=1) & np.isfinite(d[1]).all(axis=1)
        )
        alpha = 0.99 * np.minimum(_max_step(it.s, d[2]), _max_step(it.z, d[3]))
        alpha = np.where(live & ~stalled, alpha, 0.0)
        d = tuple(np.nan_to_num(x, nan=0.0, posinf=0.0, neginf=0.0) for x in d) if stalled.any() else d
        it = it.moved(d, alpha)
    out.forces = out.forces.reshape(b, n, N_LEGS, 3)
    return out


def _ipm_status(best_error: float, tol: float, infeasible: bool, out_of_iterations: bool) -> str:
    """Status of a finished candidate from its best error."""
    if best_error < tol:
        return "ok"
    if infeasible:
        return "infeasible"
    if best_error < IPM_ACCEPTABLE:
        return "ok"
    return "max_iter" if out_of_iterations else "error: numerical breakdown"


def solve_condensed_ipm(qp: CondensedQp, max_iter: int = 50, tol: float = 1e-8) -> IpmResult:
    """Solve a batch of condensed QPs with Mehrotra's predictor-corrector interior-point method.

    The CoM height band is handled as an outer active set: all candidates are first solved with the
    force constraints only (always feasible: zero forces are); the few whose CoM leaves the band are
    solved again with the band rows. Each run starts from the reference forces (interior to the friction
    pyramids). A candidate is ``"ok"`` when its scaled primal and dual residuals and its relative duality
    gap are below ``tol`` (or below ``IPM_ACCEPTABLE`` when double precision runs out first),
    ``"infeasible"`` when its multipliers diverge on the band rows, ``"max_iter"`` when it runs out of
    iterations and ``"error: numerical breakdown"`` otherwise.
    """
    out = _ipm_run(qp, with_height=False, max_iter=max_iter, tol=tol)
    w = qp.wrenches(out.forces).reshape(qp.batch, -1)
    u = (qp.gamma[:, 2::NX, 2::6][qp.group] @ w[:, 2::6, None])[..., 0]
    margin = 1e-9
    outside = ((u < qp.z_lo - margin) | (u > qp.z_hi + margin)).any(axis=1)
    if outside.any():
        sub = _ipm_run(qp.take(outside), with_height=True, max_iter=max_iter, tol=tol)
        where = np.flatnonzero(outside)
        out.forces[where], out.cost[where] = sub.forces, sub.cost
        out.iterations[where] += sub.iterations
        for j, i in enumerate(where):
            out.status[i] = sub.status[j]
    return out


# ----------------------------------------------------------------------------------------------------
# casadi multiple-shooting problems: nonlinear reference NLP (ipopt) and sparse linearized QP (qpsol)
# ----------------------------------------------------------------------------------------------------


def _casadi_step(model: SrbdModel, dt_s: float, x, f, feet, support, p_bar):  # noqa: ANN001, ANN202
    """The nonlinear SRBD step of ``srbd_step`` in casadi SX (x (12), f (12), feet (12)).

    ``support`` and ``p_bar`` are unused (same signature as ``_casadi_linear_step``).
    """
    import casadi as ca

    p, v, rpy, w = x[0:3], x[3:6], x[6:9], x[9:12]
    cr, sr, cp, sp = ca.cos(rpy[0]), ca.sin(rpy[0]), ca.cos(rpy[1]), ca.sin(rpy[1])
    cy, sy = ca.cos(rpy[2]), ca.sin(rpy[2])
    rot = ca.vertcat(
        ca.horzcat(cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr),
        ca.horzcat(sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr),
        ca.horzcat(-sp, cp * sr, cp * cr),
    )
    rate_map = ca.vertcat(
        ca.horzcat(cy / cp, sy / cp, 0), ca.horzcat(-sy, cy, 0), ca.horzcat(cy * sp / cp, sy * sp / cp, 1)
    )
    inertia_w = rot @ ca.DM(model.inertia_matrix()) @ rot.T
    tau = sum(ca.cross(feet[3 * i : 3 * i + 3] - p, f[3 * i : 3 * i + 3]) for i in range(N_LEGS))
    w_dot = rot @ ca.DM(np.linalg.inv(model.inertia_matrix())) @ rot.T @ (tau - ca.cross(w, inertia_w @ w))
    acc = (f[0:3] + f[3:6] + f[6:9] + f[9:12]) / model.mass_kg + ca.DM([0.0, 0.0, -model.gravity])
    return ca.vertcat(
        p + dt_s * v + 0.5 * dt_s**2 * acc,
        v + dt_s * acc,
        rpy + dt_s * rate_map @ (w + 0.5 * dt_s * w_dot),
        w + dt_s * w_dot,
    )


def _casadi_linear_step(model: SrbdModel, dt_s: float, x, f, feet, support, p_bar):  # noqa: ANN001, ANN202
    """The linearized step of the fast path in casadi SX, in the heading frame (reference yaw 0): moments
    about ``p_bar`` plus the tipping term ``(p - p_bar) x F_ref`` with ``F_ref = support * weight``."""
    import casadi as ca

    i_inv = ca.DM(np.linalg.inv(model.inertia_matrix()))
    p, v, rpy, w = x[0:3], x[3:6], x[6:9], x[9:12]
    tau = sum(ca.cross(feet[3 * i : 3 * i + 3] - p_bar, f[3 * i : 3 * i + 3]) for i in range(N_LEGS))
    f_ref = ca.vertcat(0, 0, model.weight_n * support)
    w_dot = i_inv @ (tau + ca.cross(f_ref, p - p_bar))
    acc = (f[0:3] + f[3:6] + f[6:9] + f[9:12]) / model.mass_kg + ca.DM([0.0, 0.0, -model.gravity])
    return ca.vertcat(
        p + dt_s * v + 0.5 * dt_s**2 * acc,
        v + dt_s * acc,
        rpy + dt_s * (w + 0.5 * dt_s * w_dot),
        w + dt_s * w_dot,
    )


_IPOPT_STATUS = {
    "Solve_Succeeded": "ok",
    "Solved_To_Acceptable_Level": "ok",
    "Maximum_Iterations_Exceeded": "max_iter",
    "Infeasible_Problem_Detected": "infeasible",
    "Restoration_Failed": "infeasible",
}


def _qpsol_status(plugin: str, stats: dict) -> str:
    """Our status of a casadi qpsol result."""
    raw = str(stats.get("return_status", "unknown"))
    if stats.get("success", False):
        return "ok"
    if "infeas" in raw.lower():
        return "infeasible"
    if "iter" in raw.lower():
        return "max_iter"
    return f"error: {plugin} {raw}"


class _CasadiOcp:
    """Multiple-shooting SRBD problem in casadi, built once, solved with parameters.

    Variables stage-wise ``[f_k (12), x_{k+1} (12)]``; constraints per stage ``[dynamics (12), pyramid rows
    (16)]``; contact (forces of swing feet fixed to 0, ``0 <= f_z <= fz_max``) and the CoM height band
    enter as variable bounds. ``kind="nlp"``: nonlinear SRBD with ipopt (cold and warm-started instances);
    ``kind="qp"``: the linearized SRBD of the fast path with a casadi qpsol plugin (sparse).
    Problems are given in the heading frame.
    """

    def __init__(
        self, model: SrbdModel, config: TrajoptConfig, weights: TrajoptWeights, kind: str, plugin: str
    ):
        import casadi as ca

        n = config.n_nodes
        self.model, self.config, self.kind, self.plugin = model, config, kind, plugin
        x0 = ca.SX.sym("x0", NX)
        feet, x_ref, f_ref = ca.SX.sym("feet", NU, n), ca.SX.sym("xr", NX, n), ca.SX.sym("fr", NU, n)
        support, p_bar = ca.SX.sym("support", n), ca.SX.sym("pbar", 3, n)
        step = _casadi_step if kind == "nlp" else _casadi_linear_step
        q, wf = weights.node_state_weights(n), np.tile(np.asarray(weights.force, dtype=float), N_LEGS)
        pyramid = ca.DM(_foot_rows(model.mu)[0:4])
        variables, g, cost, x_prev = [], [], 0, x0
        for k in range(n):
            f_k, x_k = ca.SX.sym(f"f{k}", NU), ca.SX.sym(f"x{k + 1}", NX)
            variables += [f_k, x_k]
            g.append(x_k - step(model, config.dt_s, x_prev, f_k, feet[:, k], support[k], p_bar[:, k]))
            g.extend(pyramid @ f_k[3 * i : 3 * i + 3] for i in range(N_LEGS))
            cost += ca.sumsqr(np.sqrt(q[k]) * (x_k - x_ref[:, k])) + ca.sumsqr(
                np.sqrt(wf) * (f_k - f_ref[:, k])
            )
            x_prev = x_k
        prob = {
            "x": ca.vertcat(*variables),
            "f": cost,
            "g": ca.vertcat(*g),
            "p": ca.vertcat(x0, ca.vec(feet), ca.vec(x_ref), ca.vec(f_ref), support, ca.vec(p_bar)),
        }
        self.warm = None
        if kind == "nlp":
            base = {
                "print_time": False,
                "error_on_fail": False,
                "ipopt.print_level": 0,
                "ipopt.sb": "yes",
                "ipopt.max_iter": config.max_iter,
                "ipopt.tol": config.tol,
            }
            warm = {
                "ipopt.warm_start_init_point": "yes",
                "ipopt.mu_init": 1e-4,
                "ipopt.warm_start_bound_push": 1e-6,
                "ipopt.warm_start_mult_bound_push": 1e-6,
            }
            self.cold = ca.nlpsol("srbd_nlp", plugin, prob, base)
            self.warm = ca.nlpsol("srbd_nlp_warm", plugin, prob, {**base, **warm})
        else:
            self.cold = ca.qpsol(
                "srbd_qp", plugin, prob, {"error_on_fail": False, **_QPSOL_OPTIONS.get(plugin, {})}
            )
        self.previous: dict | None = None

    def _arguments(self, problem: ProblemBatch) -> dict[str, np.ndarray]:
        """Parameters, bounds and the reference initial guess of a (heading-frame) problem (batch of 1)."""
        n, model = self.config.n_nodes, self.model
        x0, contact = problem.x0[0], problem.contact[0]
        x_ref = problem.reference_states(self.config.dt_s)[0]
        f_ref = reference_forces(contact, model.mass_kg, model.gravity).reshape(n, NU)
        p_bar = x_ref[:n, 0:3].copy()
        p_bar[0] = x0[0:3]
        p = np.concatenate(
            [
                x0,
                problem.feet[0].ravel(),
                x_ref[1:].ravel(),
                f_ref.ravel(),
                contact.any(axis=1),
                p_bar.ravel(),
            ]
        )
        f_lo = np.where(contact[..., None], [-np.inf, -np.inf, 0.0], 0.0).reshape(n, NU)
        f_hi = np.where(contact[..., None], [np.inf, np.inf, model.fz_max_n], 0.0).reshape(n, NU)
        x_lo, x_hi = np.full((n, NX), -np.inf), np.full((n, NX), np.inf)
        x_lo[:, 2] = x_ref[1:, 2] - model.com_height_band_m
        x_hi[:, 2] = x_ref[1:, 2] + model.com_height_band_m
        stage_g_lo = np.r_[np.zeros(NX), np.full(4 * N_LEGS, -np.inf)]
        return {
            "p": p,
            "lbx": np.concatenate([f_lo, x_lo], axis=1).ravel(),
            "ubx": np.concatenate([f_hi, x_hi], axis=1).ravel(),
            "lbg": np.tile(stage_g_lo, n),
            "ubg": np.zeros(n * len(stage_g_lo)),
            "x0": np.concatenate([f_ref, x_ref[1:]], axis=1).ravel(),
        }

    def solve(self, problem: ProblemBatch, warm_start: bool) -> TrajoptSolution:
        """One solve of a heading-frame problem (batch of 1); the solution stays in that frame."""
        n = self.config.n_nodes
        args = self._arguments(problem)
        solver = self.cold
        if warm_start and self.previous is not None:
            args["x0"] = self.previous["x"]
            if self.warm is not None:
                solver = self.warm
                args.update(lam_x0=self.previous["lam_x"], lam_g0=self.previous["lam_g"])
        t0 = time.perf_counter()
        out = solver(**args)
        elapsed = time.perf_counter() - t0
        stats = solver.stats()
        raw = str(stats.get("return_status", "unknown"))
        if self.kind == "nlp":
            status = _IPOPT_STATUS.get(raw, f"error: ipopt {raw}")
        else:
            status = _qpsol_status(self.plugin, stats)
        z = np.asarray(out["x"]).reshape(n, NU + NX)
        if status == "ok":
            self.previous = {k: np.asarray(out[k]).ravel() for k in ("x", "lam_x", "lam_g")}
        x = np.concatenate([problem.x0, z[:, NU:]], axis=0)
        return _result(
            status,
            float(out["f"]),
            x,
            z[:, :NU].reshape(n, N_LEGS, 3),
            elapsed,
            int(stats.get("iter_count", -1)),
            {"solver_status": raw},
        )


#: Options of the casadi qpsol plugins (quiet, tight enough to agree with the interior-point method).
_QPSOL_OPTIONS: dict[str, dict] = {
    "osqp": {"osqp": {"verbose": False, "eps_abs": 1e-8, "eps_rel": 1e-8, "polish": True}},
    "qrqp": {"print_iter": False, "print_header": False, "print_info": False},
    "qpoases": {"printLevel": "none"},
    "proxqp": {"proxqp": {"eps_abs": 1e-9}},
    "highs": {"highs": {"output_flag": False}},
}


# ----------------------------------------------------------------------------------------------------
# Public optimizer
# ----------------------------------------------------------------------------------------------------


def _check_shapes(problem: TrajoptProblem, n_nodes: int) -> None:
    """Raise ValueError on wrong shapes (a programming error, unlike non-finite data)."""
    shapes = {
        "x0": (np.shape(problem.x0), (NX,)),
        "contact": (np.shape(problem.contact), (n_nodes, N_LEGS)),
        "foot_pos_world": (np.shape(problem.foot_pos_world), (n_nodes, N_LEGS, 3)),
        "com_vel_ref_xy": (np.shape(problem.com_vel_ref_xy), (2,)),
    }
    for name, (got, want) in shapes.items():
        if got != want:
            raise ValueError(f"TrajoptProblem.{name} has shape {got}, expected {want}")


def _failed(status: str, n_nodes: int, elapsed: float = 0.0) -> TrajoptSolution:
    """A failure result (NaN trajectory, infinite cost)."""
    return TrajoptSolution(
        status=status,
        success=False,
        cost=math.inf,
        x=np.full((n_nodes + 1, NX), np.nan),
        forces_world=np.full((n_nodes, N_LEGS, 3), np.nan),
        solve_time_s=elapsed,
        iterations=0,
    )


class TrajectoryOptimizer:
    """SRBD trajectory optimizer for a fixed horizon; the problem structure is built once.

    ``solve`` handles one problem (the MPC solve), ``solve_batch`` many problems of the same horizon (the
    candidate actions of one state). Solvers (``TrajoptConfig.solver``):

    * ``"auto"``: ``solve`` uses the sparse linearized QP with casadi/piqp, ``solve_batch`` the batched
      interior-point method (the fastest measured path for each use; both solve the same QP);
    * ``"qp-ipm"``: the batched interior-point method for both;
    * ``"qp-<plugin>"``: the sparse linearized QP with that casadi qpsol plugin (``piqp``, ``proxqp``,
      ``osqp``, ``qrqp``, ``hpipm``, ``daqp``, ...);
    * ``"nlp-ipopt"``: the nonlinear SRBD (reference), warm-started from the previous solve.

    All solvers work in the heading frame (reference yaw, CoM xy at the origin) and return world-frame
    trajectories and forces. Numerical failures never raise: ``success=False`` and a status.
    """

    def __init__(
        self,
        model: SrbdModel | None = None,
        config: TrajoptConfig | None = None,
        weights: TrajoptWeights | None = None,
    ) -> None:
        self.model = model or SrbdModel()
        self.config = config or TrajoptConfig()
        self.weights = weights or TrajoptWeights()
        solver = self.config.solver
        self._cache: dict = {}  # condensing matrices per support pattern (few patterns occur)
        self._ocp: _CasadiOcp | None = None
        if solver == "auto":
            self._ocp = _CasadiOcp(self.model, self.config, self.weights, "qp", "piqp")
        elif solver.startswith("nlp-"):
            self._ocp = _CasadiOcp(self.model, self.config, self.weights, "nlp", solver[4:])
        elif solver.startswith("qp-") and solver != "qp-ipm":
            self._ocp = _CasadiOcp(self.model, self.config, self.weights, "qp", solver[3:])
        elif solver != "qp-ipm":
            raise ValueError(
                f"unknown solver {solver!r}: 'auto', 'qp-ipm', 'qp-<qpsol plugin>' or 'nlp-ipopt'"
            )

    @property
    def n_nodes(self) -> int:
        return self.config.n_nodes

    def solve(self, problem: TrajoptProblem, warm_start: bool = True) -> TrajoptSolution:
        """Solve one problem. ``warm_start`` reuses the previous solution (ipopt: primal-dual; the QP
        solvers start from the reference, which is what they are fastest with)."""
        if self._ocp is None:
            return self.solve_batch([problem])[0]
        batch = ProblemBatch.of([problem], self.n_nodes)
        if not batch.finite()[0]:
            return _failed("error: non-finite input", self.n_nodes)
        t0 = time.perf_counter()
        try:
            sol = self._ocp.solve(batch.in_heading_frame(), warm_start)
        except Exception as exc:  # noqa: BLE001 - a numerical failure must come back as a status
            return _failed(f"error: {type(exc).__name__}: {exc}", self.n_nodes, time.perf_counter() - t0)
        rot, origin = batch.rotations(), batch.origins()
        sol.x = _states_from_frame(sol.x[None], rot, origin, batch.yaw)[0]
        sol.forces_world = sol.forces_world @ rot[0].T
        sol.solve_time_s = time.perf_counter() - t0
        return sol

    def solve_batch(self, problems: Sequence[TrajoptProblem]) -> list[TrajoptSolution]:
        """Solve many problems of this horizon (e.g. the candidate actions of one state).

        With ``"auto"`` and ``"qp-ipm"`` the valid problems are condensed and solved together; each
        solution's ``solve_time_s`` is its share of the batch time (``info["batch_time_s"]`` is the total).
        Other solvers solve the problems one after the other (cold).
        """
        if self.config.solver not in ("auto", "qp-ipm"):
            return [self.solve(p, warm_start=False) for p in problems]
        if not problems:
            return []
        batch = ProblemBatch.of(problems, self.n_nodes)
        valid = batch.finite()
        results = [_failed("error: non-finite input", self.n_nodes) for _ in problems]
        if valid.any():
            t0 = time.perf_counter()
            try:
                solved = self._solve_ipm(batch.take(valid))
            except Exception as exc:  # noqa: BLE001 - a numerical failure must come back as a status
                status = f"error: {type(exc).__name__}: {exc}"
                solved = [_failed(status, self.n_nodes, time.perf_counter() - t0) for _ in range(valid.sum())]
            for i, sol in zip(np.flatnonzero(valid), solved, strict=True):
                results[i] = sol
        return results

    def _solve_ipm(self, batch: ProblemBatch) -> list[TrajoptSolution]:
        """Condense in the heading frames and solve with the batched interior-point method."""
        t0 = time.perf_counter()
        qp = build_condensed_qp(
            self.model, self.weights, self.config.dt_s, batch.in_heading_frame(), self._cache
        )
        with np.errstate(all="ignore"):
            res = solve_condensed_ipm(qp, self.config.max_iter, self.config.tol)
            rot, origin = batch.rotations(), batch.origins()
            states = _states_from_frame(qp.states(res.forces), rot, origin, batch.yaw)
            forces = res.forces @ np.swapaxes(rot, 1, 2)[:, None]
        elapsed = time.perf_counter() - t0
        info = {"batch_time_s": elapsed, "batch_size": qp.batch}
        return [
            _result(
                res.status[b],
                float(res.cost[b]),
                states[b],
                forces[b],
                elapsed / qp.batch,
                int(res.iterations[b]),
                info,
            )
            for b in range(qp.batch)
        ]


def _result(
    status: str, cost: float, x: np.ndarray, forces: np.ndarray, elapsed: float, iterations: int, info: dict
) -> TrajoptSolution:
    """A solution; a failed solve reports an infinite cost (its value at exit goes to info)."""
    ok = status == "ok"
    return TrajoptSolution(
        status=status,
        success=ok,
        cost=cost if ok else math.inf,
        x=x,
        forces_world=forces,
        solve_time_s=elapsed,
        iterations=iterations,
        info=dict(info) if ok else {**info, "cost_at_exit": cost},
    )


# ----------------------------------------------------------------------------------------------------
# Example problems (tests, benchmark)
# ----------------------------------------------------------------------------------------------------

#: Solo12 hips (HFE) relative to the CoM at the standing pose (base frame; CoM 2.4 cm below the base).
HIP_OFFSETS_COM = np.array(
    [[0.1946, 0.1015, 0.024], [0.1946, -0.1015, 0.024], [-0.1946, 0.1015, 0.024], [-0.1946, -0.1015, 0.024]]
)


def feet_under_hips(com_pos: np.ndarray, yaw_rad: float = 0.0) -> np.ndarray:
    """Foot positions (4, 3) on the ground (z = 0) under the hips of a level robot."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    feet = np.asarray(com_pos, dtype=float) + HIP_OFFSETS_COM @ rz.T
    feet[:, 2] = 0.0
    return feet


def example_problem(
    swing_legs_per_step: Sequence[Sequence[int]],
    com_vel_ref_xy: Sequence[float] = (0.1, 0.0),
    x0: np.ndarray | None = None,
    com_height_m: float = 0.215,
    foothold_offsets: np.ndarray | None = None,
    n_stance_pre: int = 3,
) -> TrajoptProblem:
    """A typical walking or trotting problem: the feet start under the hips; each swinging leg lands
    under its hip at the CoM position predicted (by the reference velocity) for the end of its step
    horizon, plus ``foothold_offsets[step, leg]`` (xy, optional)."""
    contact = horizon_schedule(swing_legs_per_step, n_stance_pre=n_stance_pre)
    n_step = len(contact) // len(swing_legs_per_step)
    if x0 is None:
        x0 = np.zeros(NX)
        x0[2] = com_height_m
        x0[3:5] = com_vel_ref_xy
    x0 = np.asarray(x0, dtype=float)
    vel = np.asarray(com_vel_ref_xy, dtype=float)
    feet_now = feet_under_hips(x0[0:3], x0[8])
    feet = np.repeat(feet_now[None], len(contact), axis=0)
    for step, legs in enumerate(swing_legs_per_step):
        com_end = x0[0:3].copy()
        com_end[0:2] += vel * (step + 1) * n_step * 0.04
        landing = feet_under_hips(com_end, x0[8])
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
    x0: np.ndarray, com_vel_ref_xy: Sequence[float], spacing_m: float = 0.05
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
                problems.append(example_problem([(leg,)], com_vel_ref_xy, x0=x0, foothold_offsets=offsets))
    return problems


def trot_candidates(
    x0: np.ndarray, com_vel_ref_xy: Sequence[float], spacing_m: float = 0.05
) -> list[TrajoptProblem]:
    """The 162 trotting candidates of a state (paper: 2 diagonal pairs x 9 x 9 footholds, 3 x 3 per leg)."""
    grid = [(dx, dy) for dx in spacing_m * np.arange(-1, 2) for dy in spacing_m * np.arange(-1, 2)]
    problems = []
    for pair in ((0, 3), (1, 2)):
        for first in grid:
            for second in grid:
                offsets = np.zeros((1, N_LEGS, 2))
                offsets[0, pair[0]], offsets[0, pair[1]] = first, second
                problems.append(example_problem([pair], com_vel_ref_xy, x0=x0, foothold_offsets=offsets))
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
    steps: Sequence[Sequence[int]], solver: str, n_solves: int, rng: np.random.Generator
) -> list[float]:
    """Warm-started solves of one horizon with the state and the velocity reference perturbed each time."""
    n = 8 * len(steps)
    opt = TrajectoryOptimizer(config=TrajoptConfig(n_nodes=n, solver=solver))
    times = []
    for i in range(n_solves + 1):
        vel = np.array([0.1, 0.0]) + rng.normal(0.0, 0.01, 2)
        problem = example_problem(steps, vel, x0=_perturbed_state(rng, vel, 0.215))
        t0 = time.perf_counter()
        sol = opt.solve(problem, warm_start=True)
        if i > 0:  # the first solve pays one-time imports
            times.append(time.perf_counter() - t0)
        if not sol.success:
            raise RuntimeError(f"benchmark solve failed: {sol.status}")
    return times


def _bench_batch(gait: str, n_states: int, rng: np.random.Generator) -> tuple[int, list[float]]:
    """Batched solves of all the candidates of ``n_states`` perturbed states."""
    opt = TrajectoryOptimizer(config=TrajoptConfig.for_candidates())
    make = walk_candidates if gait == "walk" else trot_candidates
    times, size = [], 0
    for i in range(n_states + 1):
        vel = np.array([0.05, 0.0]) + rng.normal(0.0, 0.01, 2)
        problems = make(_perturbed_state(rng, vel, 0.215), vel)
        t0 = time.perf_counter()
        sols = opt.solve_batch(problems)
        if i > 0:
            times.append(time.perf_counter() - t0)
        size = len(problems)
        if not all(s.success for s in sols):
            raise RuntimeError(f"benchmark batch failed: {[s.status for s in sols if not s.success][:3]}")
    return size, times


def benchmark(n_solves: int = 50, seed: int = 0, single_core: bool = True) -> list[dict]:
    """Time the MPC-like solves and the candidate solves; rows of name, median_ms, p99_ms.

    24-node solves (walk and trot schedules) and single 8-node candidate solves are warm-started with the
    state and the velocity reference perturbed at every solve; the batched rows time all the candidates
    of a state at once and report per-candidate times (``batch_ms``, ``candidates_per_s``). With
    ``single_core`` the process is pinned to one CPU and torch to one thread while timing (both restored).
    """
    rng = np.random.default_rng(seed)
    restore = _pin_single_core() if single_core else None
    try:
        rows = [
            _timing_row("24-node walk, auto (piqp QP)", _bench_mpc(WALK_STEPS, "auto", n_solves, rng)),
            _timing_row("24-node trot, auto (piqp QP)", _bench_mpc(TROT_STEPS, "auto", n_solves, rng)),
            _timing_row("24-node walk, qp-ipm", _bench_mpc(WALK_STEPS, "qp-ipm", n_solves, rng)),
            _timing_row(
                "24-node walk, nlp-ipopt (reference)", _bench_mpc(WALK_STEPS, "nlp-ipopt", n_solves, rng)
            ),
            _timing_row(
                "8-node candidate, auto (piqp QP)", _bench_mpc(WALK_STEPS[:1], "auto", n_solves, rng)
            ),
            _timing_row(
                "8-node candidate, qp-proxqp", _bench_mpc(WALK_STEPS[:1], "qp-proxqp", n_solves, rng)
            ),
            _timing_row("8-node candidate, qp-ipm", _bench_mpc(WALK_STEPS[:1], "qp-ipm", n_solves, rng)),
        ]
        for gait in ("walk", "trot"):
            size, times = _bench_batch(gait, max(3, n_solves // 10), rng)
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


def _pin_single_core():  # noqa: ANN202 - returns the restore callable
    """Pin the process to one CPU and torch to one thread; return a function that undoes it."""
    import os

    affinity = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    if affinity:
        os.sched_setaffinity(0, {min(affinity)})
    try:
        import torch
    except ImportError:  # pragma: no cover
        torch = None
    threads = torch.get_num_threads() if torch is not None else None
    if torch is not None:
        torch.set_num_threads(1)

    def restore() -> None:
        if affinity:
            os.sched_setaffinity(0, affinity)
        if torch is not None:
            torch.set_num_threads(threads)

    return restore


def format_table(rows: Sequence[dict]) -> str:
    """The benchmark rows as a text table."""
    lines = [f"{'case':<64} {'median ms':>10} {'p99 ms':>9}  extra", "-" * 100]
    for row in rows:
        extra = ", ".join(f"{k} {v:.1f}" for k, v in row.items() if k not in ("name", "median_ms", "p99_ms"))
        lines.append(f"{row['name']:<64} {row['median_ms']:>10.3f} {row['p99_ms']:>9.3f}  {extra}")
    return "\n".join(lines)
