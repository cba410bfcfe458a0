"""The fast path's QP: the SRBD linearized about the reference and condensed onto the foot forces.

Linearization (translation exact): rotation about level orientation at the reference yaw and zero
angular velocity, moments about the reference CoM plus the first-order tipping term
``(p - p_ref) x F_ref``. The result is a convex QP in the forces alone (``CondensedQp``), batched over
the candidates of one state; the matrices shared by problems with the same reference yaw and support
pattern are built once (``build_condensed_qp``'s cache). ``contactnet.motion.trajopt.ipm`` solves it.

Friction pyramids about tilted ground normals: the QP's variables are then each foot's force in its contact
coordinates, ``f = R f_c`` with ``R = [t1 t2 n]`` (``model.contact_frames``), so that the pyramid rows stay the
standard ones of ``_foot_rows``: the wrench map becomes ``J R`` (``CondensedQp.frames``), the force gradient
``R' g_force``; the force Hessian ``diag(h_force)`` is unchanged because the force weights act along the contact
axes (``TrajoptWeights.force``). On flat ground (every normal +z) ``frames`` is None and nothing is rotated.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from contactnet.frames import rotation_rpy, skew
from contactnet.motion.trajopt.model import NX, SrbdModel, TrajoptWeights, reference_forces
from contactnet.motion.trajopt.problem import ProblemBatch, TrajoptProblem


@dataclass
class CondensedQp:
    """Batch of B condensed QPs in the foot forces f (B, N, 4, 3), each in its foot's contact coordinates (the
    heading frame's on flat ground, ``frames`` None)::

        min  1/2 f' H f + g' f + const,   H = diag(h_force) + J' Q_w J,   g = J' g_w + g_force
        s.t. friction pyramid and 0 <= f_n <= fz_max on stance feet (the rows of ``_foot_rows``), f = 0 on
             swing feet,
             z_lo <= Gz J f <= z_hi          (CoM height band, relative to the free response)

    ``J`` maps the forces of node k to the node wrench (total force, moment about the linearization
    point ``pbar_k``): ``w_k = sum_i J_ki f_ki`` with ``J_ki = [I; [r_ki - pbar_k]x] R_ki`` (``R_ki`` the foot's
    contact frame, ``frames``; the identity when None). The states of
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
    #: (B, N, 4, 3, 3) each foot's contact frame [t1 t2 n] in the heading frame; None: the identity (flat ground)
    frames: np.ndarray | None = None

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
            if isinstance(v, np.ndarray) and k not in ("gamma", "h_force"):  # (frames: None stays None)
                fields[k] = v[keep]
        return CondensedQp(**fields)

    def to_heading(self, forces: np.ndarray) -> np.ndarray:
        """Forces (B, N, 4, 3) in the heading frame from the QP's variables (contact coordinates)."""
        return forces if self.frames is None else (self.frames @ forces[..., None])[..., 0]

    def wrenches(self, forces: np.ndarray) -> np.ndarray:
        """Node wrenches (B, N, 6) of heading-frame forces (B, N, 4, 3)."""
        return np.concatenate([forces.sum(axis=2), np.cross(self.arm, forces).sum(axis=2)], axis=-1)

    def states(self, forces: np.ndarray) -> np.ndarray:
        """State trajectories (B, N+1, 12) of the linearized model under heading-frame forces (B, N, 4, 3)."""
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
    omega_dot_p = i_inv[:, None] @ skew(f_ref)  # d(omega')/dp = I^-1 [F_ref]x, (G, N, 3, 3)
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
    model: SrbdModel, dt_s: float, a: np.ndarray, tipping: np.ndarray, x0: np.ndarray, p_bar: np.ndarray,
    ext: np.ndarray,
) -> np.ndarray:
    """States (B, N, 12) of nodes 1..N under zero wrenches (gravity, the external forces ``ext`` (B, 3) at the
    CoM, and the tipping terms only)."""
    b, n = p_bar.shape[:2]
    c = -(tipping @ p_bar[..., None])[..., 0]
    acc = np.array([0.0, 0.0, -model.gravity]) + ext / model.mass_kg  # (B, 3)
    c[..., 0:3] += 0.5 * dt_s**2 * acc[:, None]
    c[..., 3:6] += dt_s * acc[:, None]
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


def build_condensed_qp(
    model: SrbdModel,
    weights: TrajoptWeights,
    dt_s: float,
    problems: Sequence[TrajoptProblem] | ProblemBatch,
    cache: dict | None = None,
) -> CondensedQp:
    """Linearize about the references and condense the QPs of a batch of problems (same N).

    The friction pyramids are about the problems' normals (``ProblemBatch.normals``, in the frame of the
    problems; +z when None), the variables in each foot's contact coordinates. ``cache`` (a dict owned by the
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
    x_free = _free_response(model, dt_s, per_candidate("a"), per_candidate("tipping"), batch.x0, p_bar,
                            batch.ext)
    w_state = weights.node_state_weights(n).reshape(-1)
    err = (x_free - x_ref[:, 1:]).reshape(b, -1)
    w_force = np.asarray(weights.force, dtype=float)
    f_ref = reference_forces(batch.contact, model.mass_kg, model.gravity, batch.ext)
    frames = batch.contact_frames()
    if frames is not None:  # the reference forces in contact coordinates R' f_ref (the weights act along those axes)
        f_ref = (f_ref[..., None, :] @ frames)[..., 0, :]
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
        frames=frames,
    )
