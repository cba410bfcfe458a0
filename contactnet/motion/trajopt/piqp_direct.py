"""The MPC solve: the sparse linearized SRBD QP of ``casadi_ref`` handed to piqp directly, not through
``casadi.qpsol``.

casadi still states the problem (``srbd_problem``) and evaluates its data from the parameters (about 0.05 ms);
piqp then solves it with its multistage KKT solver (it finds the stage structure of the variables ``[f_k,
x_{k+1}]`` and constraints in the sparsity) and one solver kept between solves, updated with each new problem's
numbers (casadi's plugin builds a new solver for every call with the general sparse LDL^T). Measured on MPC
problems recorded from walking, trotting and 7.5 N pushes and solved again one by one: 0.93-0.96 ms median against
1.96-2.04 ms through casadi, no failure, costs within 3e-7, and closer to the exact solution (checked on its active
set) than piqp's defaults: its tolerances are set to 1e-10, and its preconditioner is off, which costs nothing here.
``contactnet bench sim`` shows the solve in the loop (1.1-1.2 ms there).

The QP: ``min 1/2 z' H z + c' z`` subject to ``A z = b`` (the dynamics), ``G z <= 0`` (the friction pyramids)
and the variable bounds (contact, force and CoM height limits): ``H`` and ``G`` are constant; ``c``, ``A``'s
numbers (the moment arms of the feet) and ``b`` come from the parameters. On flat ground the forces are in the
heading frame (``casadi_ref.PYRAMIDS`` "flat"); when a foot's normal is tilted the optimizer uses a second
``PiqpOcp`` ("coordinates") whose forces are each foot's contact coordinates (``f = R f_c``): the same ``H``
and ``G``, ``R`` enters ``A``'s numbers (its pattern holds every entry of ``R``).
"""

from __future__ import annotations

import time

import numpy as np
import piqp

from contactnet.motion.trajopt.casadi_ref import _BufferedCall, _CasadiOcp, srbd_problem
from contactnet.motion.trajopt.model import N_LEGS, NU, NX, SrbdModel, TrajoptConfig, TrajoptWeights
from contactnet.motion.trajopt.problem import ProblemBatch, TrajoptSolution, _result

#: piqp's settings for the MPC QP (see the module doc).
PIQP_SETTINGS = {"preconditioner_iter": 0, "eps_abs": 1e-10, "eps_rel": 1e-10, "eps_duality_gap_abs": 1e-10,
                 "eps_duality_gap_rel": 1e-10}


class PiqpOcp(_CasadiOcp):
    """``_CasadiOcp`` (kind "qp") solved by piqp called directly (see the module doc); the same arguments and
    results. ``pyramids``: "flat" (about +z) or "coordinates" (about each foot's normal, ``casadi_ref.PYRAMIDS``);
    the solution's forces are in the heading frame either way."""

    def __init__(self, model: SrbdModel, config: TrajoptConfig, weights: TrajoptWeights,
                 pyramids: str = "flat") -> None:
        import casadi as ca
        import scipy.sparse

        if pyramids not in ("flat", "coordinates"):
            raise ValueError(f"piqp_direct states the pyramids 'flat' or 'coordinates', not {pyramids!r}")
        self.model, self.config, self.kind, self.plugin = model, config, "qp", "piqp-direct"
        self.pyramids = pyramids
        self.warm = self.cold = None
        prob = srbd_problem(model, config, weights, "qp", pyramids)
        z, p, n_z = prob["x"], prob["p"], prob["x"].shape[0]
        zero = ca.DM.zeros(n_z)
        self._argument_constants()  # the constraint bounds: equalities are the dynamics, the rest the pyramids
        equality = self._lbg == self._ubg
        dynamics, pyramid = np.flatnonzero(equality).tolist(), np.flatnonzero(~equality).tolist()
        g = prob["g"]
        a_eq, g_in = ca.jacobian(g[dynamics], z), ca.jacobian(g[pyramid], z)
        hessian = ca.hessian(prob["f"], z)[0]
        data = ca.Function("srbd_qp_data", [p], [ca.substitute(ca.gradient(prob["f"], z), z, zero),
                                                 ca.vertcat(*a_eq.nonzeros()),
                                                 -ca.substitute(g[dynamics], z, zero),
                                                 ca.substitute(prob["f"], z, zero)],
                           ["p"], ["c", "a_eq", "b", "f0"])
        self._data = _BufferedCall(data)
        constants = ca.Function("srbd_qp_constants", [p], [hessian, g_in, ca.substitute(g[pyramid], z, zero)])
        h_dm, g_dm, g0 = constants(np.zeros(p.shape[0]))
        if np.any(np.asarray(g0) != 0.0):
            raise ValueError("the friction pyramid rows must not depend on the parameters")

        def csc(matrix, values=None):  # noqa: ANN001, ANN202 - a casadi matrix (or its sparsity with values)
            sparsity = matrix.sparsity()
            nz = np.asarray(matrix.nonzeros(), dtype=float) if values is None else values
            return scipy.sparse.csc_matrix((nz, np.array(sparsity.row()), np.array(sparsity.colind())),
                                           shape=matrix.shape)

        self._hessian, self._pyramid = csc(h_dm), csc(g_dm)
        self._a_eq = csc(a_eq, np.zeros(a_eq.nnz()))  # its numbers are written in place at every solve
        self._pyramid_lo, self._pyramid_hi = self._lbg[~equality], self._ubg[~equality]
        self._solver = None

    def _new_solver(self, c: np.ndarray, b: np.ndarray, lbx: np.ndarray, ubx: np.ndarray) -> piqp.SparseSolver:
        solver = piqp.SparseSolver()
        solver.settings.kkt_solver = piqp.KKTSolver.sparse_multistage
        for name, value in PIQP_SETTINGS.items():
            setattr(solver.settings, name, value)
        solver.setup(self._hessian, c, self._a_eq, b, self._pyramid, self._pyramid_lo, self._pyramid_hi, lbx, ubx)
        return solver

    def solve(self, problem: ProblemBatch, warm_start: bool) -> TrajoptSolution:
        """One solve of a heading-frame problem (batch of 1); the solution stays in that frame. piqp starts from
        its own initial point (``warm_start`` is not used)."""
        n = self.config.n_nodes
        args = self._arguments(problem)
        t0 = time.perf_counter()
        data = self._data(p=args["p"])
        self._a_eq.data[:] = data["a_eq"]
        if self._solver is None:
            self._solver = self._new_solver(data["c"], data["b"], args["lbx"], args["ubx"])
        else:
            self._solver.update(c=data["c"], A=self._a_eq, b=data["b"], x_l=args["lbx"], x_u=args["ubx"])
        code = self._solver.solve()
        result = self._solver.result
        elapsed = time.perf_counter() - t0
        status = _PIQP_STATUS.get(code, f"error: piqp {code}")
        z = np.array(result.x).reshape(n, NU + NX)
        objective = float(result.info.primal_obj) + float(data["f0"][0])
        x = np.concatenate([problem.x0, z[:, NU:]], axis=0)
        forces = z[:, :NU].reshape(n, N_LEGS, 3)
        frames = problem.contact_frames() if self.pyramids == "coordinates" else None
        if frames is not None:  # contact coordinates -> heading frame
            forces = (frames[0] @ forces[..., None])[..., 0]
        return _result(status, objective, x, forces, elapsed, int(result.info.iter), {"solver_status": str(code)})

    def __getstate__(self) -> dict:  # piqp's solver is not pickled: the copy makes its own at its first solve
        state = self.__dict__.copy()
        state["_solver"] = None
        return state


_PIQP_STATUS = {piqp.PIQP_SOLVED: "ok", piqp.PIQP_MAX_ITER_REACHED: "max_iter", piqp.PIQP_PRIMAL_INFEASIBLE: "infeasible",
                piqp.PIQP_DUAL_INFEASIBLE: "infeasible"}
