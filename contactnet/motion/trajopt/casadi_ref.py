"""casadi multiple-shooting problems: the nonlinear reference NLP (ipopt) and the sparse linearized QP.

``_CasadiOcp`` builds one problem structure in casadi and solves it with parameters:

* ``kind="qp"``: the SRBD linearized as in ``contactnet.motion.trajopt.condensed``, kept sparse (states and
  forces as variables) and solved by a casadi qpsol plugin (piqp for the MPC solve, the fastest
  measured one at a time);
* ``kind="nlp"``: the nonlinear SRBD with ipopt, warm-started from the previous solve (the reference the
  fast paths are tested against).

Both state the friction pyramids about +z on flat ground (``PYRAMIDS`` "flat") and, for problems with a tilted
normal, plainly about each stance foot's normal ("normals", a second instance the optimizer builds at its first
use); the MPC solve (``piqp_direct``) states the tilted problems with the forces in contact coordinates
("coordinates"), whose rows and Hessian stay constant.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from contactnet.motion.trajopt.model import (
    N_LEGS,
    NU,
    NX,
    SrbdModel,
    TrajoptConfig,
    TrajoptWeights,
    _foot_rows,
    reference_forces,
)
from contactnet.motion.trajopt.problem import ProblemBatch, TrajoptSolution, _result


def _casadi_step(model: SrbdModel, dt_s: float, x, f, feet, support, p_bar, ext):  # noqa: ANN001, ANN202
    """The nonlinear SRBD step of ``srbd_step`` in casadi SX (x (12), f (12), feet (12), ext (3): the external
    force at the CoM).

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
    acc = (f[0:3] + f[3:6] + f[6:9] + f[9:12] + ext) / model.mass_kg + ca.DM([0.0, 0.0, -model.gravity])
    return ca.vertcat(
        p + dt_s * v + 0.5 * dt_s**2 * acc,
        v + dt_s * acc,
        rpy + dt_s * rate_map @ (w + 0.5 * dt_s * w_dot),
        w + dt_s * w_dot,
    )


def _casadi_linear_step(model: SrbdModel, dt_s: float, x, f, feet, support, p_bar, ext):  # noqa: ANN001, ANN202
    """The linearized step of the fast path in casadi SX, in the heading frame (reference yaw 0): moments
    about ``p_bar`` plus the tipping term ``(p - p_bar) x F_ref`` with ``F_ref = support * weight`` (the weight
    only: of the ground's reaction to a known external force ``ext`` at the CoM the term is left out, the
    CoM's deviation from ``p_bar`` times a push, small next to the feet's exact moments about ``p_bar``)."""
    import casadi as ca

    i_inv = ca.DM(np.linalg.inv(model.inertia_matrix()))
    p, v, rpy, w = x[0:3], x[3:6], x[6:9], x[9:12]
    tau = sum(ca.cross(feet[3 * i : 3 * i + 3] - p_bar, f[3 * i : 3 * i + 3]) for i in range(N_LEGS))
    f_ref = ca.vertcat(0, 0, model.weight_n * support)
    w_dot = i_inv @ (tau + ca.cross(f_ref, p - p_bar))
    acc = (f[0:3] + f[3:6] + f[6:9] + f[9:12] + ext) / model.mass_kg + ca.DM([0.0, 0.0, -model.gravity])
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


#: How ``srbd_problem`` states the friction pyramids and the force term of the cost:
#:
#: * "flat": about +z: the variables are the heading-frame forces, the pyramid rows those of ``_foot_rows`` (the
#:   normal force's bounds are variable bounds), the force weights along x, y, z (the MPC solve on flat ground);
#: * "normals": about each foot's normal, written plainly: the variables are the heading-frame forces, each foot's
#:   contact frame ``[t1 t2 n]`` is a parameter, the rows are ``t1.f - mu n.f <= 0``, ``-t1.f - mu n.f <= 0``,
#:   the same with ``t2``, ``-n.f <= 0`` and ``n.f <= fz_max``, and the force error is weighted along
#:   ``t1, t2, n`` (the reference, any ground);
#: * "coordinates": about each foot's normal by a change of variables: the variables are each foot's force in its
#:   contact coordinates ``f_c`` (the dynamics see ``f = R f_c``, ``R`` a parameter), the rows and bounds those of
#:   "flat" on ``f_c`` and the reference forces given in contact coordinates: the Hessian and the rows stay
#:   constant (the MPC solve on sloped ground, ``piqp_direct``).
#:
#: "normals" and "coordinates" take the contact frames as the last parameters, the columns ``t1, t2, n`` of each
#: foot side by side (36 numbers per node).
PYRAMIDS = ("flat", "normals", "coordinates")


def _foot_frame(frames, k: int, leg: int):  # noqa: ANN001, ANN202 - casadi SX
    """The contact frame R = [t1 t2 n] (3x3 SX) of ``leg`` at node ``k`` from the frames parameter (36, N)."""
    import casadi as ca

    column = frames[9 * leg : 9 * leg + 9, k]
    return ca.horzcat(column[0:3], column[3:6], column[6:9])


def srbd_problem(model: SrbdModel, config: TrajoptConfig, weights: TrajoptWeights, kind: str,
                 pyramids: str = "flat") -> dict:
    """The multiple-shooting SRBD problem in casadi SX (``kind`` "qp": linearized, "nlp": nonlinear; ``pyramids``
    one of ``PYRAMIDS``), as a qpsol/nlpsol problem dict: variables stage-wise ``[f_k (12), x_{k+1} (12)]``,
    constraints per stage ``[dynamics (12), pyramid rows (16; "normals": 24)]``, parameters ``[x0, feet, x_ref,
    f_ref, support, p_bar, ext]`` and, but with "flat", ``frames``."""
    import casadi as ca

    if pyramids not in PYRAMIDS:
        raise ValueError(f"unknown pyramids {pyramids!r}: one of {PYRAMIDS}")
    n, mu = config.n_nodes, model.mu
    x0 = ca.SX.sym("x0", NX)
    feet, x_ref, f_ref = ca.SX.sym("feet", NU, n), ca.SX.sym("xr", NX, n), ca.SX.sym("fr", NU, n)
    support, p_bar, ext = ca.SX.sym("support", n), ca.SX.sym("pbar", 3, n), ca.SX.sym("ext", 3)
    frames = ca.SX.sym("frames", 9 * N_LEGS, n)
    step = _casadi_step if kind == "nlp" else _casadi_linear_step
    q, w_force = weights.node_state_weights(n), np.asarray(weights.force, dtype=float)
    pyramid = ca.DM(_foot_rows(mu)[0:4])
    variables, g, cost, x_prev = [], [], 0, x0
    for k in range(n):
        f_k, x_k = ca.SX.sym(f"f{k}", NU), ca.SX.sym(f"x{k + 1}", NX)
        variables += [f_k, x_k]
        feet_f = [f_k[3 * i : 3 * i + 3] for i in range(N_LEGS)]
        if pyramids == "coordinates":
            f_heading = ca.vertcat(*(_foot_frame(frames, k, i) @ feet_f[i] for i in range(N_LEGS)))
        else:
            f_heading = f_k
        g.append(x_k - step(model, config.dt_s, x_prev, f_heading, feet[:, k], support[k], p_bar[:, k], ext))
        if pyramids == "normals":
            force_term = 0
            for i in range(N_LEGS):
                rot, f = _foot_frame(frames, k, i), feet_f[i]
                t1, t2, normal = rot[:, 0], rot[:, 1], rot[:, 2]
                g.extend([ca.dot(t1, f) - mu * ca.dot(normal, f), -ca.dot(t1, f) - mu * ca.dot(normal, f),
                          ca.dot(t2, f) - mu * ca.dot(normal, f), -ca.dot(t2, f) - mu * ca.dot(normal, f),
                          -ca.dot(normal, f), ca.dot(normal, f)])
                force_term += ca.sumsqr(np.sqrt(w_force) * (rot.T @ (f - f_ref[3 * i : 3 * i + 3, k])))
        else:
            g.extend(pyramid @ f for f in feet_f)
            force_term = ca.sumsqr(np.sqrt(np.tile(w_force, N_LEGS)) * (f_k - f_ref[:, k]))
        cost += ca.sumsqr(np.sqrt(q[k]) * (x_k - x_ref[:, k])) + force_term
        x_prev = x_k
    parameters = [x0, ca.vec(feet), ca.vec(x_ref), ca.vec(f_ref), support, ca.vec(p_bar), ext]
    if pyramids != "flat":
        parameters.append(ca.vec(frames))
    return {"x": ca.vertcat(*variables), "f": cost, "g": ca.vertcat(*g), "p": ca.vertcat(*parameters)}


class _CasadiOcp:
    """Multiple-shooting SRBD problem in casadi, built once, solved with parameters.

    Variables stage-wise ``[f_k (12), x_{k+1} (12)]``; constraints per stage ``[dynamics (12), pyramid rows]``;
    swing feet (forces fixed to 0) and the CoM height band enter as variable bounds. ``pyramids`` (``PYRAMIDS``):
    "flat" (about +z: 4 rows per foot, the normal force's bounds variable bounds) or "normals" (about each stance
    foot's normal, written plainly: 6 rows per foot). ``kind="nlp"``: nonlinear SRBD with ipopt (cold and
    warm-started instances); ``kind="qp"``: the linearized SRBD of the fast path with a casadi qpsol plugin
    (sparse). Problems are given in the heading frame.
    """

    def __init__(
        self, model: SrbdModel, config: TrajoptConfig, weights: TrajoptWeights, kind: str, plugin: str,
        pyramids: str = "flat",
    ):
        import casadi as ca

        self.model, self.config, self.kind, self.plugin, self.pyramids = model, config, kind, plugin, pyramids
        prob = srbd_problem(model, config, weights, kind, pyramids)
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
        self._call = _BufferedCall(self.cold) if kind == "qp" else None
        self._argument_constants()

    def _argument_constants(self) -> None:
        """Constant parts of the arguments (``_arguments``): force bounds of a stance foot, constraint bounds."""
        n, model = self.config.n_nodes, self.model
        self.previous: dict | None = None
        if self.pyramids == "normals":  # the rows bound the normal force
            self._stance_force_lo, self._stance_force_hi = np.full(3, -np.inf), np.full(3, np.inf)
            foot_hi = np.array([0.0, 0.0, 0.0, 0.0, 0.0, model.fz_max_n])
        else:
            self._stance_force_lo = np.array([-np.inf, -np.inf, 0.0])
            self._stance_force_hi = np.array([np.inf, np.inf, model.fz_max_n])
            foot_hi = np.zeros(4)
        # dynamics = 0, pyramid rows <= their bounds
        stage_g_lo = np.concatenate([np.zeros(NX), np.full(len(foot_hi) * N_LEGS, -np.inf)])
        stage_g_hi = np.concatenate([np.zeros(NX), np.tile(foot_hi, N_LEGS)])
        self._lbg, self._ubg = np.tile(stage_g_lo, n), np.tile(stage_g_hi, n)

    def _arguments(self, problem: ProblemBatch) -> dict[str, np.ndarray]:
        """Parameters, bounds and the reference initial guess of a (heading-frame) problem (batch of 1)."""
        n, model = self.config.n_nodes, self.model
        x0, contact = problem.x0[0], problem.contact[0]
        x_ref = problem.reference_states(self.config.dt_s)[0]
        f_ref = reference_forces(contact, model.mass_kg, model.gravity, problem.ext[0])
        frames = problem.contact_frames()
        frames = np.broadcast_to(np.eye(3), (n, N_LEGS, 3, 3)) if frames is None else frames[0]
        if self.pyramids == "coordinates":  # the reference forces in the variables' coordinates R' f_ref
            f_ref = (f_ref[..., None, :] @ frames)[..., 0, :]
        f_ref = f_ref.reshape(n, NU)
        p_bar = x_ref[:n, 0:3].copy()
        p_bar[0] = x0[0:3]
        parameters = [x0, problem.feet[0].ravel(), x_ref[1:].ravel(), f_ref.ravel(), contact.any(axis=1),
                      p_bar.ravel(), problem.ext[0]]
        if self.pyramids != "flat":  # the columns t1, t2, n of each foot's frame, node by node
            parameters.append(np.swapaxes(frames, -1, -2).ravel())
        p = np.concatenate(parameters)
        # Bounds, stage-wise [f_k, x_{k+1}]: forces of stance feet in 0 <= f_z <= fz_max (swing feet: 0), the CoM
        # height within its band.
        lbx, ubx = np.full((n, NU + NX), -np.inf), np.full((n, NU + NX), np.inf)
        lbx[:, :NU] = np.where(contact[..., None], self._stance_force_lo, 0.0).reshape(n, NU)
        ubx[:, :NU] = np.where(contact[..., None], self._stance_force_hi, 0.0).reshape(n, NU)
        lbx[:, NU + 2] = x_ref[1:, 2] - model.com_height_band_m
        ubx[:, NU + 2] = x_ref[1:, 2] + model.com_height_band_m
        return {
            "p": p,
            "lbx": lbx.ravel(),
            "ubx": ubx.ravel(),
            "lbg": self._lbg,
            "ubg": self._ubg,
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
        out = solver(**args) if self._call is None else self._call(**args)
        elapsed = time.perf_counter() - t0
        stats = solver.stats() if self._call is None else self._call.stats()
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
            float(np.asarray(out["f"]).ravel()[0]),
            x,
            z[:, :NU].reshape(n, N_LEGS, 3),
            elapsed,
            int(stats.get("iter_count", -1)),
            {"solver_status": raw},
        )


class _BufferedCall:
    """Calls a casadi Function on numpy arrays it owns (casadi's ``Function.buffer``): the same evaluation as
    ``function(**args)`` without converting every input to a casadi DM and every output back (about 0.3 ms of
    a 24-node QP solve). Inputs not given take the function's defaults; the outputs are copies."""

    def __init__(self, function) -> None:  # noqa: ANN001 - a casadi Function
        self.function = function
        self._inputs = [np.zeros(function.nnz_in(i)) for i in range(function.n_in())]
        self._names_in = {name: i for i, name in enumerate(function.name_in())}
        self._defaults = [function.default_in(i) for i in range(function.n_in())]
        self._outputs = {name: np.zeros(function.nnz_out(i)) for i, name in enumerate(function.name_out())}
        self._buffer, self._evaluate = function.buffer()
        for i, array in enumerate(self._inputs):
            self._buffer.set_arg(i, memoryview(array))
        for i, array in enumerate(self._outputs.values()):
            self._buffer.set_res(i, memoryview(array))
        self._lock = threading.Lock()  # the arrays are shared by the calls

    def __call__(self, **args: np.ndarray) -> dict[str, np.ndarray]:
        with self._lock:
            given = [None] * len(self._inputs)
            for name, value in args.items():
                given[self._names_in[name]] = value
            for array, value, default in zip(self._inputs, given, self._defaults, strict=True):
                array[:] = default if value is None else np.ravel(value)
            self._evaluate()
            if self._buffer.ret():
                raise RuntimeError(f"casadi function {self.function.name()} failed (return flag {self._buffer.ret()})")
            return {name: array.copy() for name, array in self._outputs.items()}

    def stats(self) -> dict:
        """The function's statistics of the last call (``Function.stats``)."""
        return self._buffer.stats()

    def __getstate__(self) -> dict:  # pickled as its function; the buffers are made anew
        return {"function": self.function}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["function"])


#: Options of the casadi qpsol plugins (quiet, tight enough to agree with the interior-point method).
_QPSOL_OPTIONS: dict[str, dict] = {
    "osqp": {"osqp": {"verbose": False, "eps_abs": 1e-8, "eps_rel": 1e-8, "polish": True}},
    "qrqp": {"print_iter": False, "print_header": False, "print_info": False},
    "qpoases": {"printLevel": "none"},
    "proxqp": {"proxqp": {"eps_abs": 1e-9}},
    "highs": {"highs": {"output_flag": False}},
}
