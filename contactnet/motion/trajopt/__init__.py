"""Single-rigid-body trajectory optimization (SRBD) for a quadruped.

Given the contact schedule and the footholds of a horizon, the optimizer finds the ground reaction
forces and the CoM / base trajectory that track the user velocity with the single rigid body model
(Orin 2013, as in the ContactNet paper); the optimal cost ranks candidate footholds and the forces
drive the whole-body controller. The robot enters through ``SrbdModel.for_robot(description)``.

Every solver works in the *heading frame* (rotated by the reference yaw about z, origin at the current
CoM xy) and returns world-frame trajectories and forces. The friction pyramids stand on the ground's normal under
each stance foot (``TrajoptProblem.contact_normals_world``, +z by default): the fast paths solve for each foot's
force in its contact frame (``model.contact_frames``), the casadi reference writes the rows with the normals.

Fast path: the SRBD linearized about the reference. It is a convex QP, solved

* one at a time (``TrajectoryOptimizer.solve``, the MPC solve) as a sparse multiple-shooting QP built once
  in casadi, its data evaluated from the parameters, and solved by piqp called directly (its multistage KKT
  solver, one solver updated from solve to solve);
* many at a time (``TrajectoryOptimizer.solve_batch``, the candidate actions of one state) condensed onto
  the forces and solved by a batched Mehrotra interior-point method written for this structure.

Reference: ``solver="nlp-ipopt"`` solves the nonlinear SRBD (multiple shooting, ipopt, warm-started).
``contactnet.bench.trajopt`` (``contactnet bench trajopt``) times all of them.

Modules:

* ``model``: the SRBD (parameters, dynamics, reference forces, foot constraints), weights, configuration;
* ``problem``: one problem and its solution, batches of problems in their heading frames, the objective;
* ``condensed``: the linearized SRBD condensed onto the forces (``CondensedQp``);
* ``ipm``: the batched interior-point method for the condensed QP;
* ``casadi_ref``: the casadi problems (sparse linearized QP, nonlinear reference NLP);
* ``piqp_direct``: the sparse QP handed to piqp directly (the MPC solve);
* ``optimizer``: ``TrajectoryOptimizer``, which picks the solver.
"""

from contactnet.motion.trajopt.condensed import build_condensed_qp
from contactnet.motion.trajopt.model import (
    NX,
    SrbdModel,
    TrajoptConfig,
    TrajoptWeights,
    dynamics_residual,
    reference_forces,
    srbd_step,
)
from contactnet.motion.trajopt.optimizer import TrajectoryOptimizer
from contactnet.motion.trajopt.problem import (
    ProblemBatch,
    TrajoptProblem,
    TrajoptSolution,
    reference_states,
    trajectory_cost,
)

__all__ = [
    "NX",
    "ProblemBatch",
    "SrbdModel",
    "TrajectoryOptimizer",
    "TrajoptConfig",
    "TrajoptProblem",
    "TrajoptSolution",
    "TrajoptWeights",
    "build_condensed_qp",
    "dynamics_residual",
    "reference_forces",
    "reference_states",
    "srbd_step",
    "trajectory_cost",
]
