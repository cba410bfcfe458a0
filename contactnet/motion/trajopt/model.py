"""The single rigid body model (SRBD) of a quadruped: parameters, dynamics and constraints.

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

Constraints on stance feet, about the ground's normal ``n`` under each foot (``TrajoptProblem.contact_normals_world``;
default +z, flat ground): with the foot's contact frame ``R = [t1 t2 n]`` (``contact_frames``: ``t1`` the heading
frame's x projected onto the ground, ``t2 = n x t1``), ``|f.t1|, |f.t2| <= mu f.n``, ``0 <= f.n <= fz_max``; on
flat ground ``|f_x|, |f_y| <= mu f_z``, ``0 <= f_z <= fz_max`` in the heading frame. No force on swing feet. The CoM height stays within
``com_height_band_m`` of the reference (the robot must neither fall nor jump: this is what makes a plan
without support infeasible).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from contactnet.frames import euler_rate_map, rotation_rpy

if TYPE_CHECKING:
    from contactnet.robots import RobotDescription

N_LEGS = 4
NX = 12
NU = 3 * N_LEGS


# ----------------------------------------------------------------------------------------------------
# Parameters
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class SrbdModel:
    """Physical parameters of the single rigid body (no robot defaults: see ``for_robot``)."""

    mass_kg: float
    inertia_body: tuple[float, ...]  #: (9,) body-frame inertia about the CoM, row-major, kg m^2
    #: Upper bound on each foot's normal force (``for_robot``: twice the robot weight, so that a single
    #: leg may carry the whole robot through a push with margin).
    fz_max_n: float
    gravity: float = 9.81
    mu: float = 0.6
    #: The CoM height may deviate at most this much from the reference (nodes 1..N).
    com_height_band_m: float = 0.1

    @classmethod
    def for_robot(cls, description: RobotDescription, gravity: float = 9.81, mu: float = 0.6) -> SrbdModel:
        """The model of a robot: its mass and standing composite inertia, ``fz_max_n`` twice its weight."""
        mass = float(description.mass_kg)
        return cls(
            mass_kg=mass,
            inertia_body=tuple(float(v) for v in np.asarray(description.inertia_com_standing).ravel()),
            fz_max_n=2.0 * mass * gravity,
            gravity=gravity,
            mu=mu,
        )

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
    #: Weight of the force tracking, per N^2, along each foot's contact axes (t1, t2, n): on flat ground the
    #: heading frame's (x, y, z). Equal weights (the default, and every use) make the term the same in any
    #: axes, so a tilted normal leaves it unchanged; unequal ones weigh the tangential and the normal parts of the
    #: error (a rotation of the heading frame's x, y, z weights would couple the axes and break the solvers'
    #: per-foot structure).
    force: tuple[float, float, float] = (1e-3, 1e-3, 1e-3)
    #: The last node's state weight is multiplied by this.
    terminal_factor: float = 1.0

    def __post_init__(self) -> None:
        # the condensed QP needs a positive definite wrench-space Hessian and force Hessian
        positive = (*self.com_vel, *self.ang_vel, *self.force, self.terminal_factor)
        if min(positive) <= 0.0 or min(*self.com_pos, *self.rpy) < 0.0:
            raise ValueError("velocity, angular velocity and force weights must be > 0, the others >= 0")

    @classmethod
    def for_robot(cls, description: RobotDescription, power: float = 1.0) -> TrajoptWeights:
        """The weights for ``description``: the force term divided by k^``power``, k its weight over Solo12's.

        ``force`` is per N^2 and was tuned with Solo12 (``REFERENCE_WEIGHT_N``); a robot k times heavier has k times
        larger forces and a k^2 times larger force term. The walking loop takes ``power`` 1 (the default), measured
        with Go2 (k = 6.4; 0.05 m/s, its ContactNet): with Solo12's weights (power 0) the reference forces' equal
        shares outweighed the CoM's tracking, its CoM stayed 5 cm behind its reference over its feet and it stopped on
        the narrow stones and the stone grid (and the stepping stones' trot); with power 2 the forces swung so freely
        that feet slipped off the edges of holes (the random field n = 80, walk: 6 of seeds 0-9 fell); with power 1
        all of these crossed (docs/results.md, "Go2's body follows its command"). The ranking takes power 2
        (``contactnet.planning.cost.ranking_trajopt_weights``). Solo12 (k = 1): these weights."""
        from contactnet.robots.description import REFERENCE_WEIGHT_N

        default = cls()
        ratio = REFERENCE_WEIGHT_N / float(description.weight_n)
        if math.isclose(ratio, 1.0, rel_tol=1e-3):
            return default
        return replace(default, force=tuple(w * ratio**power for w in default.force))

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


# ----------------------------------------------------------------------------------------------------
# Reference forces and foot constraints
# ----------------------------------------------------------------------------------------------------


def reference_forces(contact: np.ndarray, mass_kg: float, gravity: float,
                     external_force: np.ndarray | None = None) -> np.ndarray:
    """Reference forces (..., N, 4, 3): weight shared by the stance legs, vertical; zero in swing. With
    ``external_force`` (..., 3), a known force on the body at the CoM (N), the stance legs share its opposite
    too: the ground forces that hold the body still against it (a steady push)."""
    c = np.asarray(contact, dtype=float)
    n_stance = c.sum(axis=-1, keepdims=True)
    share = np.divide(c, n_stance, out=np.zeros_like(c), where=n_stance > 0)
    f = np.zeros((*c.shape, 3))
    f[..., 2] = mass_kg * gravity * share
    if external_force is not None:
        f -= share[..., None] * np.asarray(external_force, dtype=float)[..., None, None, :]
    return f


def contact_frames(normals: np.ndarray) -> np.ndarray:
    """Contact frames (..., 3, 3) of unit normals (..., 3) given in the heading frame: columns ``t1`` (the frame's x
    projected onto the plane normal to ``n``; its y where x is almost along ``n``), ``t2 = n x t1`` and ``n``.
    Exactly the identity for ``n = +z``. A force ``f`` has the contact coordinates ``R' f``."""
    n = np.asarray(normals, dtype=float)
    axis = np.zeros_like(n)
    along_x = np.abs(n[..., 0]) > 0.9
    axis[..., 0], axis[..., 1] = ~along_x, along_x
    t1 = axis - (axis * n).sum(axis=-1, keepdims=True) * n
    t1 /= np.linalg.norm(t1, axis=-1, keepdims=True)
    return np.stack([t1, np.cross(n, t1), n], axis=-1)


def _foot_rows(mu: float) -> np.ndarray:
    """Rows (6, 3) of the foot constraints C f <= d in contact coordinates (t1, t2, n): friction pyramid,
    -f_n <= 0, f_n <= fz_max."""
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


# ----------------------------------------------------------------------------------------------------
# Nonlinear SRBD in numpy (reference for tests)
# ----------------------------------------------------------------------------------------------------


def srbd_step(
    model: SrbdModel, dt_s: float, x: np.ndarray, forces_world: np.ndarray, foot_pos_world: np.ndarray,
    external_force_world: np.ndarray | None = None,
) -> np.ndarray:
    """One discrete nonlinear SRBD step, vectorized over leading axes.

    ``x`` (..., 12), ``forces_world`` and ``foot_pos_world`` (..., 4, 3); ``external_force_world`` (3,) a force on
    the body at the CoM (N), no moment about it.
    """
    x = np.asarray(x, dtype=float)
    f = np.asarray(forces_world, dtype=float)
    p, v, rpy, w = x[..., 0:3], x[..., 3:6], x[..., 6:9], x[..., 9:12]
    acc = f.sum(axis=-2) / model.mass_kg + np.array([0.0, 0.0, -model.gravity])
    if external_force_world is not None:
        acc = acc + np.asarray(external_force_world, dtype=float) / model.mass_kg
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
    model: SrbdModel, dt_s: float, x: np.ndarray, forces_world: np.ndarray, foot_pos_world: np.ndarray,
    external_force_world: np.ndarray | None = None,
) -> np.ndarray:
    """Residuals x[k+1] - step(x[k], f[k]) of a trajectory under the nonlinear SRBD, (N, 12).

    ``x`` is (N+1, 12), ``forces_world`` and ``foot_pos_world`` are (N, 4, 3).
    """
    x = np.asarray(x, dtype=float)
    return x[1:] - srbd_step(model, dt_s, x[:-1], forces_world, foot_pos_world, external_force_world)
