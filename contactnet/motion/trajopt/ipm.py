"""Batched primal-dual interior-point method for the condensed QP (``solve_condensed_ipm``).

Many QPs at a time (the candidate actions of one state) are solved by Mehrotra's predictor-corrector
method written for this structure: the Newton system reduces, by the Woodbury identity, to one 6N x 6N
Cholesky factorization per candidate and iteration (torch's batched LAPACK), everything else is
vectorized numpy over the batch.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from contactnet.frames import skew
from contactnet.motion.trajopt.condensed import CondensedQp
from contactnet.motion.trajopt.model import N_LEGS, NU, NX, _foot_rows


@functools.cache
def _torch():
    """torch if it is installed, else None (looked up once: a failed import is not cached by Python)."""
    try:
        import torch
    except ImportError:
        return None
    return torch


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
        torch = _torch()
        if torch is None:  # without the extra ``train`` (contactnet.extras)
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

    Forces are handled as (B, N, 12) (the 4 feet of a node side by side), in the QP's variables (each foot's
    contact coordinates, ``CondensedQp.frames``: the wrench map includes the rotation). Constraint rows, per candidate:
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
        jac[..., 3:6, :] = skew(qp.arm)
        if qp.frames is not None:  # the variables are contact coordinates: J R per foot
            jac = jac @ qp.frames
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

    forces: np.ndarray  #: (B, N, 4, 3) in the heading frame
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
    f = -ops.g_force / ops.h_force  # the reference forces (zero in swing): inside the pyramids below atan(mu) slopes
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
    out.forces = qp.to_heading(out.forces.reshape(b, n, N_LEGS, 3))
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
