"""One optimization problem, its solution, a batch of problems, and the objective.

Cost (sum of squares, no 1/2): tracking over the nodes 1..N of the CoM reference (the user velocity
integrated from the current CoM xy; its height one number, or one per node when the ground under the
feet changes height along the horizon), level orientation at the reference yaw, zero angular
velocity, and of the reference forces (weight shared by the stance legs, vertical; zero in swing). The
returned ``cost`` is this value at the optimum (``trajectory_cost`` recomputes it).

Every solver works in the *heading frame* of a problem (rotated by the reference yaw about z, origin at
the current CoM xy: ``ProblemBatch.in_heading_frame``) and returns world-frame trajectories and forces.
The xy weights are aligned with that frame. The friction pyramids are built about the ground's normal under each
stance foot (``TrajoptProblem.contact_normals_world``, default +z) in that foot's contact frame
(``model.contact_frames``: on flat ground the heading frame's axes); the force weights act along its axes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from contactnet.frames import rotation_z
from contactnet.motion.trajopt.model import (
    N_LEGS,
    NX,
    SrbdModel,
    TrajoptWeights,
    contact_frames,
    reference_forces,
)


@dataclass
class TrajoptProblem:
    """Parameters of one solve."""

    x0: np.ndarray  #: (12,) [com_pos_world, com_vel_world, rpy, ang_vel_world]
    contact: np.ndarray  #: (N, 4) bool, True = the leg is in stance at node k
    foot_pos_world: np.ndarray  #: (N, 4, 3) foot positions (meaningful where in stance)
    com_vel_ref_xy: np.ndarray  #: (2,) user velocity, world frame
    #: World z of the CoM reference: one number for the whole horizon, or (N+1,) one per node (node 0 is
    #: the current state and is not tracked), e.g. the height of the feet's support plus the nominal height.
    com_height_ref_m: float | np.ndarray
    yaw_ref_rad: float = 0.0
    #: (2,) where the CoM xy reference starts (world); None: at the current CoM xy. A caller that
    #: keeps a reference path (e.g. the commanded velocity integrated over time) passes it here so
    #: that a push that moved the robot is also undone, not only stopped.
    com_xy_ref_start: np.ndarray | None = None
    #: Base pitch reference (rad, positive nose down): one number, or (N+1,) one per node; 0 keeps the body
    #: level. On stairs it follows the slope from the hind to the front feet.
    pitch_ref_rad: float | np.ndarray = 0.0
    #: (3,) a known force on the body at the CoM over the whole horizon (N, world), e.g. the push the disturbance
    #: observer estimates (``contactnet.planning.observer``); None: none. The plan then leans against it, and its
    #: reference forces include holding it (``reference_forces``).
    external_force_world: np.ndarray | None = None
    #: (N, 4, 3) unit normals (world) of the ground under each foot at each node, e.g. ``Terrain.normal_at`` of the
    #: footholds; the friction pyramids and the normal force's bounds are about them (swing feet: ignored). None:
    #: +z everywhere (flat ground).
    contact_normals_world: np.ndarray | None = None

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


def _check_shapes(problem: TrajoptProblem, n_nodes: int) -> None:
    """Raise ValueError on wrong shapes (a programming error, unlike non-finite data)."""
    shapes = {
        "x0": (np.shape(problem.x0), (NX,)),
        "contact": (np.shape(problem.contact), (n_nodes, N_LEGS)),
        "foot_pos_world": (np.shape(problem.foot_pos_world), (n_nodes, N_LEGS, 3)),
        "com_vel_ref_xy": (np.shape(problem.com_vel_ref_xy), (2,)),
    }
    if problem.external_force_world is not None:
        shapes["external_force_world"] = (np.shape(problem.external_force_world), (3,))
    if problem.contact_normals_world is not None:
        shapes["contact_normals_world"] = (np.shape(problem.contact_normals_world), (n_nodes, N_LEGS, 3))
    for name in ("com_height_ref_m", "pitch_ref_rad"):
        if np.ndim(getattr(problem, name)) != 0:
            shapes[name] = (np.shape(getattr(problem, name)), (n_nodes + 1,))
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


def reference_states(problem: TrajoptProblem, n_nodes: int, dt_s: float) -> np.ndarray:
    """Reference state trajectory (N+1, 12).

    CoM xy integrates the user velocity from the reference start (default: the current CoM xy), CoM
    z is the problem's height reference (per node when it is an array), the velocity is the user
    velocity, the orientation is at the reference yaw and pitch (level by default), no angular velocity.
    """
    v = np.asarray(problem.com_vel_ref_xy, dtype=float)
    t = dt_s * np.arange(n_nodes + 1)
    ref = np.zeros((n_nodes + 1, NX))
    ref[:, 0:2] = problem.ref_xy_start() + t[:, None] * v
    ref[:, 2] = np.broadcast_to(np.asarray(problem.com_height_ref_m, dtype=float), (n_nodes + 1,))
    ref[:, 3:5] = v
    ref[:, 7] = np.broadcast_to(np.asarray(problem.pitch_ref_rad, dtype=float), (n_nodes + 1,))
    ref[:, 8] = problem.yaw_ref_rad
    return ref


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
    f_err = forces - reference_forces(batch.contact[0], model.mass_kg, model.gravity, batch.ext[0] @ rot[0])
    frames = batch.in_heading_frame().contact_frames()
    if frames is not None:  # the error's contact coordinates: the force weights act along each foot's axes
        f_err = (f_err[..., None, :] @ frames[0])[..., 0, :]
    return float(
        np.sum(weights.node_state_weights(n) * err**2) + np.sum(np.asarray(weights.force) * f_err**2)
    )


@dataclass
class ProblemBatch:
    """Problems of one horizon stacked into arrays (B leading)."""

    x0: np.ndarray  #: (B, 12)
    contact: np.ndarray  #: (B, N, 4) bool
    feet: np.ndarray  #: (B, N, 4, 3)
    ref_xy: np.ndarray  #: (B, 2) start of the CoM xy reference
    vel: np.ndarray  #: (B, 2)
    height: np.ndarray  #: (B, N+1) CoM height reference of every node
    yaw: np.ndarray  #: (B,)
    pitch: np.ndarray  #: (B, N+1) pitch reference of every node
    ext: np.ndarray  #: (B, 3) known external force on the body (zero: none)
    #: (B, N, 4, 3) unit ground normals under the feet (+z for swing feet); None: +z everywhere (flat ground, and
    #: then no rotation costs anything)
    normals: np.ndarray | None = None

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
            height=np.array([np.broadcast_to(np.asarray(p.com_height_ref_m, dtype=float), (n_nodes + 1,))
                             for p in problems]).reshape(-1, n_nodes + 1),
            yaw=np.array([p.yaw_ref_rad for p in problems], dtype=float),
            pitch=np.array([np.broadcast_to(np.asarray(p.pitch_ref_rad, dtype=float), (n_nodes + 1,))
                            for p in problems]).reshape(-1, n_nodes + 1),
            ext=np.array([np.zeros(3) if p.external_force_world is None else p.external_force_world
                          for p in problems], dtype=float).reshape(-1, 3),
            normals=_stacked_normals(problems, contact),
        )

    def __len__(self) -> int:
        return len(self.x0)

    def take(self, keep: np.ndarray) -> ProblemBatch:
        return ProblemBatch(*(None if getattr(self, f) is None else getattr(self, f)[keep]
                              for f in self.__dataclass_fields__))

    def finite(self) -> np.ndarray:
        """(B,) True where every number is finite."""
        scalars = np.isfinite(np.concatenate((self.x0, self.ref_xy, self.vel, self.height, self.yaw[:, None], self.pitch,
                                              self.ext), axis=1)).all(axis=1)
        feet = np.isfinite(self.feet).all(axis=(1, 2, 3))
        if self.normals is not None:
            feet &= np.isfinite(self.normals).all(axis=(1, 2, 3))
        return feet & scalars

    def contact_frames(self) -> np.ndarray | None:
        """(B, N, 4, 3, 3) every foot's contact frame (``model.contact_frames`` of its normal, in this batch's
        frame); None when every normal is +z (the identity)."""
        return None if self.normals is None else contact_frames(self.normals)

    def rotations(self) -> np.ndarray:
        """Rotations (B, 3, 3) about z by the reference yaws."""
        return rotation_z(self.yaw)

    def origins(self) -> np.ndarray:
        """Heading-frame origins (B, 3): the current CoM xy."""
        origins = np.zeros((len(self), 3))
        origins[:, 0:2] = self.x0[:, 0:2]
        return origins

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
            pitch=self.pitch,
            ext=(self.ext[:, None] @ rot)[:, 0],
            normals=None if self.normals is None else self.normals @ rot[:, None],
        )

    def reference_states(self, dt_s: float) -> np.ndarray:
        """Reference state trajectories (B, N+1, 12), as ``reference_states``."""
        n = self.contact.shape[1]
        t = dt_s * np.arange(n + 1)
        ref = np.zeros((len(self), n + 1, NX))
        ref[..., 0:2] = self.ref_xy[:, None] + t[:, None] * self.vel[:, None]
        ref[..., 2] = self.height
        ref[..., 3:5] = self.vel[:, None]
        ref[..., 7] = self.pitch
        ref[..., 8] = self.yaw[:, None]
        return ref


def _stacked_normals(problems: Sequence[TrajoptProblem], contact: np.ndarray) -> np.ndarray | None:
    """The problems' contact normals (B, N, 4, 3), unit length, +z on swing feet and where a problem gives none;
    None when every stance foot's normal is +z."""
    if all(p.contact_normals_world is None for p in problems):
        return None
    up = np.array([0.0, 0.0, 1.0])
    normals = np.array([np.broadcast_to(up, contact.shape[1:] + (3,)) if p.contact_normals_world is None
                        else p.contact_normals_world for p in problems], dtype=float).reshape(contact.shape + (3,))
    with np.errstate(all="ignore"):  # a zero or non-finite normal stays non-finite: ``finite`` rejects the problem
        normals = np.where(contact[..., None], normals / np.linalg.norm(normals, axis=-1, keepdims=True), up)
    return None if not normals[..., 0:2].any() else normals


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
