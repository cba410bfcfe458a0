"""The public optimizer: one solve (the MPC) or a batch of solves (the candidates of one state)."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from contactnet.interrupt import sigint_deferred
from contactnet.motion.trajopt.casadi_ref import _CasadiOcp
from contactnet.motion.trajopt.condensed import build_condensed_qp
from contactnet.motion.trajopt.ipm import solve_condensed_ipm
from contactnet.motion.trajopt.model import SrbdModel, TrajoptConfig, TrajoptWeights
from contactnet.motion.trajopt.piqp_direct import PiqpOcp
from contactnet.motion.trajopt.problem import (
    ProblemBatch,
    TrajoptProblem,
    TrajoptSolution,
    _failed,
    _result,
    _states_from_frame,
)


class TrajectoryOptimizer:
    """SRBD trajectory optimizer for a fixed horizon; the problem structure is built once.

    ``solve`` handles one problem (the MPC solve), ``solve_batch`` many problems of the same horizon (the
    candidate actions of one state). Solvers (``TrajoptConfig.solver``):

    * ``"auto"``: ``solve`` uses the sparse linearized QP stated in casadi and solved by piqp directly
      (``contactnet.motion.trajopt.piqp_direct``), ``solve_batch`` the batched interior-point method (the fastest
      measured path for each use; both solve the same QP);
    * ``"qp-ipm"``: the batched interior-point method for both;
    * ``"qp-<plugin>"``: the sparse linearized QP with that casadi qpsol plugin (``piqp``, ``proxqp``,
      ``osqp``, ``qrqp``, ``hpipm``, ``daqp``, ...);
    * ``"nlp-ipopt"``: the nonlinear SRBD (reference), warm-started from the previous solve.

    All solvers work in the heading frame (reference yaw, CoM xy at the origin) and return world-frame
    trajectories and forces. The friction pyramids are about each stance foot's ground normal
    (``TrajoptProblem.contact_normals_world``, +z by default); the problem structures of the one-at-a-time solvers
    for tilted normals are built at their first such problem, so that flat ground costs nothing more. Numerical failures never raise: ``success=False`` and a status.
    The robot enters through ``model`` (``SrbdModel.for_robot(description)``). ``tilted_normals``: build the
    problem structure for tilted normals now (a terrain with sloped tops), not at the first such solve (a few
    hundred ms).
    """

    def __init__(
        self,
        model: SrbdModel,
        config: TrajoptConfig | None = None,
        weights: TrajoptWeights | None = None,
        tilted_normals: bool = False,
    ) -> None:
        self.model = model
        self.config = config or TrajoptConfig()
        self.weights = weights or TrajoptWeights()
        solver = self.config.solver
        self._cache: dict = {}  # condensing matrices per support pattern (few patterns occur)
        self._ocp: _CasadiOcp | None = None
        self._ocp_tilted: _CasadiOcp | None = None  # the problem about tilted normals, built at its first use
        if solver != "auto" and not solver.startswith(("nlp-", "qp-")):
            raise ValueError(f"unknown solver {solver!r}: 'auto', 'qp-ipm', 'qp-<qpsol plugin>' or 'nlp-ipopt'")
        # casadi states the problem and piqp/casadi solve it: C extensions that may swallow a Ctrl-C raised in
        # their Python callbacks (`contactnet.interrupt`), so a SIGINT waits for them here and in `solve`.
        with sigint_deferred():
            if solver == "auto":
                self._ocp = PiqpOcp(self.model, self.config, self.weights)
            elif solver.startswith("nlp-"):
                self._ocp = _CasadiOcp(self.model, self.config, self.weights, "nlp", solver[4:])
            elif solver != "qp-ipm":
                self._ocp = _CasadiOcp(self.model, self.config, self.weights, "qp", solver[3:])
        if tilted_normals:
            self._tilted_ocp()

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
            with sigint_deferred():
                sol = self._ocp_for(batch).solve(batch.in_heading_frame(), warm_start)
        except Exception as exc:  # noqa: BLE001 - a numerical failure must come back as a status
            return _failed(f"error: {type(exc).__name__}: {exc}", self.n_nodes, time.perf_counter() - t0)
        rot, origin = batch.rotations(), batch.origins()
        sol.x = _states_from_frame(sol.x[None], rot, origin, batch.yaw)[0]
        sol.forces_world = sol.forces_world @ rot[0].T
        sol.solve_time_s = time.perf_counter() - t0
        return sol

    def _ocp_for(self, batch: ProblemBatch) -> _CasadiOcp:
        """The problem structure that solves ``batch`` (of one): ``_ocp`` (pyramids about +z) on flat ground; with a
        tilted normal, one built at its first use: piqp on the forces in contact coordinates ("auto"), the pyramid
        rows written with the normals (the casadi solvers; ``casadi_ref.PYRAMIDS``)."""
        return self._ocp if batch.normals is None else self._tilted_ocp()

    def _tilted_ocp(self) -> _CasadiOcp | None:
        """The problem structure for tilted normals (built once; None with "qp-ipm", which needs none)."""
        if self._ocp_tilted is None and self._ocp is not None:
            with sigint_deferred():
                if isinstance(self._ocp, PiqpOcp):
                    self._ocp_tilted = PiqpOcp(self.model, self.config, self.weights, "coordinates")
                else:
                    ocp = self._ocp
                    self._ocp_tilted = _CasadiOcp(self.model, self.config, self.weights, ocp.kind, ocp.plugin,
                                                  "normals")
        return self._ocp_tilted

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
