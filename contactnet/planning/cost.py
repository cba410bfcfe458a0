"""The ranking cost V of every candidate action of a state (the paper's Sec. III-B).

For each candidate action ``a`` (the gait's swing legs plus one grid cell per swinging leg) we build
the contact plan of one step horizon (8 nodes of 40 ms: 3 four-leg stance, 4 swing, 1 stance), solve
the single-rigid-body trajectory optimization with it, and score the result::

    V = sum_k (g_opt V_opt,k + g_stab V_stab,k + g_kin V_kin,k) + g_cent V_cent - g_area V_area

* ``V_opt``: the optimizer's optimal cost (CoM / orientation / force tracking), summed over the nodes
  by the optimizer itself;
* ``V_stab,k``: distance of the CoM ground projection to the support polygon of the legs in stance at
  node k (convex hull of their contact points; a segment with two legs, as in trot), zero inside;
* ``V_kin,k``: for each stance foot, a hinge with a jump on the horizontal distance between the foot
  and its hip reference, the hips moving with the CoM (constant hip-CoM offset over the horizon);
* ``V_cent``: distance of the final CoM projection to the area centroid of the final support polygon;
* ``V_area``: area of the final support polygon (convex hull of the four feet);
* ``V_swing``, ``V_short`` (the energy-like terms): how many legs swing, and for each swinging foot how much
  less than ``short_swing_m`` it moves (a fraction of it: 1 for a foot put back where it was).

Beside the N_a stepping actions the cost scores **standing** (``CostWeights.stand``, on by default): the
choice ``gait.stand_index`` whose contact plan keeps all four feet down for the whole step horizon. It pays
V_opt, V_stab (zero: the CoM over the four feet's polygon), V_kin (feet lagging behind the moving hips),
V_cent and V_area like any action, and no energy term. With a zero command and a balanced state nothing
needs to move and standing is cheapest; a swing that barely moves its foot ranks below standing.

A node k is the interval [t_k, t_k+1] with the support of ``contact[k]``; its terms are evaluated at
both ends (the optimized states x[k] and x[k+1]) and the worse end counts. Within an interval the CoM
moves almost in a straight line, and both distances are convex along a straight line (distance to a
convex set; distance to a hip that translates with the CoM), so the worse end *is* the worst moment of
the interval: the touchdown state x[7] is checked against the swing support, x[3] (lift-off) as well.

Which CoM the hips follow in V_kin (``CostWeights.kin_hip_path``): by default the CoM *reference* path
(the commanded velocity), not each candidate's optimized CoM. With the optimized CoM the kinematic
term can be gamed: when a foot lags behind, the cheapest candidates are those whose optimized body
*stops* (the optimizer gives up a little tracking, V_opt, to spare a 50-per-violation V_kin), the feet
fall further behind at every step and greedy walking breaks down (``weight_study``: the worst foot-hip
distance grows from 0.15 to 0.27 m and V_stab sevenfold). Along the reference path every candidate that
keeps a lagging foot in stance pays the same, and the candidates that move that foot win.

Candidate footholds (``RankingCost.candidate_footholds``): each leg's grid is centred on its hip
reference (``PlanningContext.hip_ref_world``: the nominal foot position, moving with the base) at the
*current* base position, the paper's "fixed offsets from the current hip position" (``GRID_LEAD_S`` =
0); the same as ``GaitSpec.candidates_world(ctx.hip_ref_world(ctx.base_xy_world), yaw)``. We tried
centring the grid on the hips predicted at touchdown (``grid_lead_s = 0.28``: base + v_cmd * 280 ms),
which keeps the grid symmetric about where the hip will be when the foot lands. It is worse: at
0.1 m/s the touchdown-centred grid offers footholds 0 and 5 cm ahead of the touchdown hip, while the
natural trot foothold (half the 0.48 s stance ahead, ~2.4 cm) lies in between; the cost then picks
5 cm, the landed pair's diagonal stays ahead of the CoM and the same pair swings again and again
(``weight_study``: repeats 0.33 vs 0.05, V_stab 14.1 vs 6.0). The current-hip grid offers 2.2 cm
ahead. For the walk the difference is smaller but in the same direction (V_stab 5.4 vs 1.9). At
0.1 m/s the current-hip grid still reaches 7 cm ahead of the touchdown hip, more than a crawl needs.

Fast path (``RankingCost.evaluate``): one batched optimizer call for all candidates
(``TrajectoryOptimizer.solve_batch``) and vectorized numpy for the geometry. Reference
(``reference_evaluate`` in ``tests/test_cost.py``): one ``solve`` per candidate, shapely polygons, Python loops. The
tests check that both give the same V and ranking.

Failed optimizations (infeasible, iteration limit, numerical failure) get ``V = CostWeights.failure_cost``
exactly (a large finite constant, the same for all of them) and NaN terms; ``ranking`` sorts stably, so
failures tie at the bottom in index order and the order of the others is untouched.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from contactnet.frames import rotation_2d
from contactnet.motion.cost_weights import CostWeights
from contactnet.motion.gait import GaitSpec
from contactnet.motion.support_polygon import hull_area_centroid, support_distance
from contactnet.motion.trajopt import (
    NX,
    SrbdModel,
    TrajectoryOptimizer,
    TrajoptConfig,
    TrajoptProblem,
    TrajoptSolution,
    TrajoptWeights,
)
from contactnet.robots.description import RobotDescription

#: The candidate grids are centred on the hips at the base position moved by this much of commanded
#: velocity (0: the current hips, the paper's "fixed offsets from the current hip position").
GRID_LEAD_S = 0.0

#: Columns of ``CostBreakdown.terms``.
TERM_NAMES: tuple[str, ...] = ("opt", "stab", "kin", "cent", "area", "swing", "short")


@dataclass(frozen=True)
class CostState:
    """The robot state a ranking cost is evaluated at (world frame, SI units)."""

    com_pos_world: np.ndarray  #: (3,)
    com_vel_world: np.ndarray  #: (3,)
    rpy: np.ndarray  #: (3,) base roll, pitch, yaw
    ang_vel_world: np.ndarray  #: (3,)
    foot_pos_world: np.ndarray  #: (4, 3) contact points on the ground (ball centre minus radius in z)
    base_xy_world: np.ndarray  #: (2,) base origin (the hip references move with it)
    yaw_rad: float
    vel_cmd_world: np.ndarray  #: (2,) commanded velocity, world frame
    com_height_ref_m: float  #: absolute z of the CoM reference
    com_xy_ref_start: np.ndarray | None = None  #: (2,) start of the CoM xy reference (None: the CoM)
    ground_z: float = 0.0  #: ground height under the robot (``Terrain.ground_z``): where the swinging feet land
    #: The ground's unit normals (M, 3) under points (M, 2) (``Terrain.normal_at``) on a terrain with sloped tops: the
    #: optimizer's friction pyramids stand on them (``TrajoptProblem.contact_normals_world``); None: +z (flat tops).
    normals_at: Callable[[np.ndarray], np.ndarray] | None = None

    @classmethod
    def from_context(cls, ctx, foot_radius_m: float) -> CostState:  # noqa: ANN001 - planner.PlanningContext
        """The state of a ``PlanningContext`` (feet there are ball centres of ``foot_radius_m``; the CoM
        height reference is relative to the feet's support, ``contactnet.motion.ground``: the ground on flat terrain)."""
        from contactnet.motion.ground import support_height

        feet = np.array(ctx.foot_pos_world, dtype=float)
        feet[:, 2] -= foot_radius_m
        ground_z = support_height(ctx.terrain, feet[:, :2])
        return cls(
            com_pos_world=np.array(ctx.com_pos_world, dtype=float),
            com_vel_world=np.array(ctx.com_vel_world, dtype=float),
            rpy=np.array(ctx.rpy, dtype=float),
            ang_vel_world=np.array(ctx.ang_vel_world, dtype=float),
            foot_pos_world=feet,
            base_xy_world=np.array(ctx.base_xy_world, dtype=float),
            yaw_rad=float(ctx.yaw_rad),
            vel_cmd_world=np.asarray(ctx.vel_cmd_world(), dtype=float),
            com_height_ref_m=float(ctx.com_height_ref_m) + ground_z,
            ground_z=ground_z,
            normals_at=ctx.terrain.normal_at if ctx.terrain.sloped else None,
        )

    def x0(self) -> np.ndarray:
        """The optimizer's initial state (12,)."""
        return np.concatenate([self.com_pos_world, self.com_vel_world, self.rpy, self.ang_vel_world]).astype(float)


@dataclass
class CostBreakdown:
    """V of every candidate action of one state, with its terms and trajectories."""

    V: np.ndarray  #: (C,) weighted total of every choice (N_a actions, then standing when the cost offers
    #: it); ``failure_cost`` where the optimization failed
    terms: np.ndarray  #: (C, 7) unweighted sums, columns TERM_NAMES; NaN where it failed
    success: np.ndarray  #: (N_a,) bool
    com_traj_world: np.ndarray  #: (N_a, N+1, 3) optimized CoM positions (NaN where it failed)
    footholds_xy_world: np.ndarray  #: (N_a, 4, 2) where each foot is after the step (swing legs landed)
    solutions: list[TrajoptSolution] = field(default_factory=list, repr=False)
    optimizer_s: float = 0.0  #: wall time of the optimizer calls
    total_s: float = 0.0  #: wall time of the whole evaluation

    def ranking(self) -> np.ndarray:
        """Action indices from cheapest to most expensive (stable: ties keep index order)."""
        return np.argsort(self.V, kind="stable")

    def ranks(self) -> np.ndarray:
        """(N_a,) position of every action in ``ranking()`` (0 = cheapest)."""
        ranks = np.empty(len(self.V), dtype=int)
        ranks[self.ranking()] = np.arange(len(self.V))
        return ranks


# ----------------------------------------------------------------------------------------------------
# Geometry, vectorized (leading axes broadcast)
# ----------------------------------------------------------------------------------------------------

def kin_penalty(distance_m: np.ndarray, threshold_m: float, ramp_m: float) -> np.ndarray:
    """Hinge with a jump: 0 up to the threshold, then 1 + (d - threshold) / ramp."""
    d = np.asarray(distance_m, dtype=float)
    return np.where(d > threshold_m, 1.0 + (d - threshold_m) / ramp_m, 0.0)


# ----------------------------------------------------------------------------------------------------
# The cost
# ----------------------------------------------------------------------------------------------------


def candidate_footholds_world(gait: GaitSpec, grid_centres_world: np.ndarray, yaw_rad: float,
                              foot_pos_world: np.ndarray) -> np.ndarray:
    """(N_a, 4, 2) every foot's xy after each action of ``gait``: the swing legs on their grid cell
    (grid centred on ``grid_centres_world`` (4, 2), turned by the heading), the others where they are.
    The one definition of the candidate geometry, shared by the ranking cost and the planners."""
    swing, offsets = gait.action_table
    landing = np.asarray(grid_centres_world, dtype=float)[None] + offsets @ rotation_2d(yaw_rad).T
    feet = np.asarray(foot_pos_world, dtype=float)[:, 0:2]
    return np.where(swing[..., None], landing, feet[None])


def ranking_trajopt_weights(robot: RobotDescription) -> TrajoptWeights:
    """The optimizer's weights when it ranks ``robot``'s candidates: the force term per squared body weight
    (``TrajoptWeights.for_robot`` with power 2; the walking loop's is per body weight). Measured with Go2 (k = 6.4,
    oracle, walk, 0.05 m/s on flat, 6 s): V_opt 2-5 times Solo12's, standing chosen in 6 of 17 plans and 0.14 m
    walked of 0.30 m commanded; with the force weight divided by k^2, 2 of 17 and 0.27 m (Solo12: 4 of 19, 0.30 m).
    Solo12's weights are unchanged."""
    return TrajoptWeights.for_robot(robot, power=2.0)


class RankingCost:
    """The ranking cost of one gait: V for every candidate action of a state.

    ``robot``: the robot's description; its nominal foot XY (``foot_nominal_base[:, :2]``) are the legs'
    hip references in the base frame, the centres of the candidate grids, and its ``kin_threshold_m`` the
    kinematic term's threshold. The optimizer (8 nodes,
    batched interior-point method, ``TrajoptConfig.for_candidates``) is built once.
    """

    def __init__(
        self,
        gait: GaitSpec,
        robot: RobotDescription,
        weights: CostWeights | None = None,
        model: SrbdModel | None = None,
        trajopt_weights: TrajoptWeights | None = None,
        grid_lead_s: float = GRID_LEAD_S,
    ) -> None:
        self.gait = gait
        self.grid_lead_s = float(grid_lead_s)
        self.robot = robot
        self.hip_ref_xy_base = np.array(robot.foot_nominal_base[:, :2], dtype=float)
        self.kin_threshold_m = float(robot.kin_threshold_m)
        self.weights = weights or gait.cost_weights
        self.model = model or SrbdModel.for_robot(robot)
        self.trajopt_weights = trajopt_weights or ranking_trajopt_weights(robot)
        self.trajopt_config = TrajoptConfig.for_candidates(n_nodes=gait.nodes_per_step)
        if abs(self.trajopt_config.dt_s - gait.node_dt_s) > 1e-12:
            self.trajopt_config = TrajoptConfig(
                n_nodes=gait.nodes_per_step, dt_s=gait.node_dt_s, solver="qp-ipm", tol=self.trajopt_config.tol
            )
        self.optimizer = TrajectoryOptimizer(self.model, self.trajopt_config, self.trajopt_weights)

    # ---- candidates ------------------------------------------------------------------------
    @property
    def n_actions(self) -> int:
        """The stepping actions."""
        return self.gait.n_actions

    @property
    def n_choices(self) -> int:
        """What the cost ranks: the stepping actions, then standing (``gait.stand_index``) when
        ``CostWeights.stand``."""
        return self.gait.n_choices if self.weights.stand else self.gait.n_actions

    @cached_property
    def _swing(self) -> np.ndarray:
        """(C, 4) bool: the legs each choice swings (none for standing)."""
        swing, _ = self.gait.action_table
        if self.weights.stand:
            swing = np.vstack([swing, np.zeros((1, 4), dtype=bool)])
        swing.flags.writeable = False
        return swing

    @cached_property
    def _contact(self) -> np.ndarray:
        """(C, N, 4) bool contact plan of every choice."""
        swing = self._swing
        swing_nodes = np.zeros(self.gait.nodes_per_step, dtype=bool)
        swing_nodes[self.gait.n_stance_pre : self.gait.n_stance_pre + self.gait.n_swing] = True
        contact = ~(swing[:, None, :] & swing_nodes[None, :, None])
        contact.flags.writeable = False
        return contact

    def hip_ref_world(self, state: CostState, base_xy_world: np.ndarray | None = None) -> np.ndarray:
        """(4, 2) hip references in the world with the base at ``base_xy_world`` (default: the state's)."""
        base = state.base_xy_world if base_xy_world is None else np.asarray(base_xy_world, dtype=float)
        return base + self.hip_ref_xy_base @ rotation_2d(state.yaw_rad).T

    def grid_centres_world(self, state: CostState) -> np.ndarray:
        """(4, 2) centres of the candidate grids: the hip references with the base at its current position
        moved by ``grid_lead_s`` of commanded velocity (default 0: the current hips, as in the paper)."""
        base = np.asarray(state.base_xy_world, dtype=float)
        if self.grid_lead_s:
            base = base + self.grid_lead_s * np.asarray(state.vel_cmd_world, dtype=float)
        return self.hip_ref_world(state, base)

    def candidate_footholds(self, state: CostState) -> np.ndarray:
        """(C, 4, 2) every foot's xy after each choice: swing legs on their cell, the others where they are
        (all of them for standing)."""
        feet = candidate_footholds_world(self.gait, self.grid_centres_world(state), state.yaw_rad,
                                         state.foot_pos_world)
        if self.weights.stand:
            feet = np.concatenate([feet, np.asarray(state.foot_pos_world, dtype=float)[None, :, 0:2]])
        return feet

    def _foot_plans(self, state: CostState) -> np.ndarray:
        """(C, N, 4, 3) foot contact points of every choice's plan (swing feet: landed from touchdown)."""
        swing = self._swing
        n = self.gait.nodes_per_step
        touchdown = self.gait.n_stance_pre + self.gait.n_swing
        now = np.asarray(state.foot_pos_world, dtype=float)
        landed = np.repeat(now[None], self.n_choices, axis=0)
        landed[..., 0:2] = self.candidate_footholds(state)
        landed[..., 2] = np.where(swing, state.ground_z, now[:, 2])
        plans = np.repeat(now[None, None], self.n_choices, axis=0).repeat(n, axis=1)
        plans[:, touchdown:] = landed[:, None]
        return plans

    def problems(self, state: CostState, foot_plans: np.ndarray | None = None) -> list[TrajoptProblem]:
        """The optimizer problem of every choice (one step horizon); ``foot_plans``: ``_foot_plans(state)``."""
        x0 = state.x0()
        vel = np.asarray(state.vel_cmd_world, dtype=float)
        ref = None if state.com_xy_ref_start is None else np.asarray(state.com_xy_ref_start, dtype=float)
        contact = self._contact
        feet = self._foot_plans(state) if foot_plans is None else foot_plans
        normals = None if state.normals_at is None else state.normals_at(feet[..., 0:2].reshape(-1, 2)).reshape(
            feet.shape)
        return [
            TrajoptProblem(
                x0=x0,
                contact=contact[a],
                foot_pos_world=feet[a],
                com_vel_ref_xy=vel,
                com_height_ref_m=float(state.com_height_ref_m),
                yaw_ref_rad=float(state.yaw_rad),
                com_xy_ref_start=ref,
                contact_normals_world=None if normals is None else normals[a],
            )
            for a in range(self.n_choices)
        ]

    # ---- fast path -------------------------------------------------------------------------
    def evaluate(self, state: CostState, keep_solutions: bool = False) -> CostBreakdown:
        """V of every choice: one batched optimizer call, vectorized geometry."""
        t0 = time.perf_counter()
        plans = self._foot_plans(state)
        problems = self.problems(state, plans)
        t1 = time.perf_counter()
        solutions = self.optimizer.solve_batch(problems)
        t2 = time.perf_counter()
        success = np.array([s.success for s in solutions], dtype=bool)
        v_opt = np.array([s.cost for s in solutions], dtype=float)
        com = np.array([s.x[:, 0:3] for s in solutions], dtype=float)  # (N_a, N+1, 3)
        feet_xy = plans[..., 0:2]  # (N_a, N, 4, 2)
        terms = self.geometric_terms(state, com, feet_xy)
        terms = np.concatenate([v_opt[:, None], terms], axis=1)
        breakdown = self._finish(terms, success, com, feet_xy[:, -1], solutions if keep_solutions else [])
        breakdown.optimizer_s = t2 - t1
        breakdown.total_s = time.perf_counter() - t0
        return breakdown

    @cached_property
    def _checks(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where the per-node terms are evaluated: (state j, node k) pairs and, per node, its two ends.

        Node k is scored at both ends of its interval, states k and k+1. A state shared by two nodes
        with the same support pattern and feet is evaluated once (the support changes only at lift-off
        and touchdown, the same nodes for every action). Returns state indices (M,), node indices (M,)
        and the (N, 2) indices into those M checks of every node's two ends.
        """
        contact, n = self._contact, self.gait.nodes_per_step
        feet = self._foot_plans(nominal_state(self.robot))[..., 0:2]
        same = [
            bool(np.array_equal(contact[:, k], contact[:, k - 1]) and np.array_equal(feet[:, k], feet[:, k - 1]))
            for k in range(1, n)
        ]
        states, nodes, ends = [], [], np.zeros((n, 2), dtype=int)
        for j in range(n + 1):
            if j < n:  # state j as the start of node j
                ends[j, 0] = len(states)
                states.append(j)
                nodes.append(j)
            if j > 0:  # state j as the end of node j-1
                if j < n and same[j - 1]:
                    ends[j - 1, 1] = ends[j, 0]
                else:
                    ends[j - 1, 1] = len(states)
                    states.append(j)
                    nodes.append(j - 1)
        return np.array(states), np.array(nodes), ends

    def _hip_shift(self, state: CostState, com_xy: np.ndarray) -> np.ndarray:
        """(N_a, N+1, 2) how far the hips have moved at each node (constant hip-CoM offset): with the
        CoM reference path (the commanded velocity) or with the optimized CoM (``com_xy`` (N_a, N+1, 2))."""
        if self.weights.kin_hip_path == "optimized":
            return com_xy - com_xy[:, :1]
        t = self.gait.node_dt_s * np.arange(self.gait.nodes_per_step + 1)
        shift = t[:, None] * np.asarray(state.vel_cmd_world, dtype=float)[None]
        return np.broadcast_to(shift, com_xy.shape)

    def geometric_terms(self, state: CostState, com_world: np.ndarray, feet_xy: np.ndarray) -> np.ndarray:
        """(C, 6) unweighted V_stab, V_kin, V_cent, V_area, V_swing, V_short from CoM trajectories (C, N+1, 3)
        and foot plans (C, N, 4, 2), vectorized over choices and nodes."""
        w = self.weights
        states, nodes, ends = self._checks
        contact = self._contact[:, nodes]  # (N_a, M, 4)
        feet = feet_xy[:, nodes]  # (N_a, M, 4, 2)
        p = com_world[:, :, 0:2]
        pts = p[:, states]  # (N_a, M, 2)
        stab = support_distance(pts, feet, contact)[:, ends].max(axis=-1).sum(axis=1)
        # hips translate with the CoM (constant hip-CoM offset over the horizon)
        hips = self.hip_ref_world(state)[None, None] + self._hip_shift(state, p)[:, states, None, :]
        d = feet - hips
        dist = np.where(contact, np.hypot(d[..., 0], d[..., 1]), 0.0)[:, ends].max(axis=2)  # (N_a, N, 4)
        kin = kin_penalty(dist, self.kin_threshold_m, w.kin_ramp_m).sum(axis=(1, 2))
        area, centroid = hull_area_centroid(feet_xy[:, -1])
        cent = np.linalg.norm(p[:, -1] - centroid, axis=-1)
        moved = np.hypot(*np.moveaxis(feet_xy[:, -1] - feet_xy[:, 0], -1, 0))  # (C, 4) how far each foot moves
        swing = self._swing
        n_swing = swing.sum(axis=1).astype(float)
        short = np.where(swing, np.clip(1.0 - moved / w.short_swing_m, 0.0, 1.0), 0.0).sum(axis=1)
        return np.stack([stab, kin, cent, area, n_swing, short], axis=1)

    def _finish(
        self,
        terms: np.ndarray,
        success: np.ndarray,
        com: np.ndarray,
        footholds: np.ndarray,
        solutions: list[TrajoptSolution],
    ) -> CostBreakdown:
        terms = np.where(success[:, None], terms, np.nan)
        with np.errstate(invalid="ignore"):
            v = terms @ self.weights.vector()
        v = np.where(success & np.isfinite(v), v, self.weights.failure_cost)
        return CostBreakdown(
            V=v,
            terms=terms,
            success=success,
            com_traj_world=np.where(success[:, None, None], com, np.nan),
            footholds_xy_world=footholds,
            solutions=solutions,
        )


def predicted_state(
    state: CostState, footholds_xy_world: np.ndarray, legs: tuple[int, ...], duration_s: float
) -> CostState:
    """The state at the end of a step horizon, predicted as the paper does: the CoM xy integrated with
    the commanded velocity, velocity = the command, nominal height, level at the current yaw, no angular
    velocity; the step's legs moved to their footholds; the base moved like the CoM."""
    vel = np.asarray(state.vel_cmd_world, dtype=float)
    shift = vel * duration_s
    com = np.array(state.com_pos_world, dtype=float)
    com[0:2] += shift
    com[2] = state.com_height_ref_m
    feet = np.array(state.foot_pos_world, dtype=float)
    for leg, xy in zip(legs, np.asarray(footholds_xy_world, dtype=float).reshape(-1, 2), strict=True):
        feet[leg] = (xy[0], xy[1], state.ground_z)
    ref = None if state.com_xy_ref_start is None else np.asarray(state.com_xy_ref_start, dtype=float) + shift
    return CostState(
        com_pos_world=com,
        com_vel_world=np.array([vel[0], vel[1], 0.0]),
        rpy=np.array([0.0, 0.0, state.yaw_rad]),
        ang_vel_world=np.zeros(3),
        foot_pos_world=feet,
        base_xy_world=np.asarray(state.base_xy_world, dtype=float) + shift,
        yaw_rad=state.yaw_rad,
        vel_cmd_world=vel.copy(),
        com_height_ref_m=state.com_height_ref_m,
        com_xy_ref_start=ref,
        ground_z=state.ground_z,
        normals_at=state.normals_at,
    )


def nominal_state(
    robot: RobotDescription,
    vel_cmd_world: tuple[float, float] = (0.1, 0.0),
    com_height_m: float | None = None,
    yaw_rad: float = 0.0,
    foot_offsets_xy: np.ndarray | None = None,
) -> CostState:
    """A standing-then-walking state for tests and studies: base at the origin, feet at their hip
    references (the robot's nominal foot XY) plus ``foot_offsets_xy`` (4, 2) (world axes), CoM above the
    base (default: the robot's nominal height) moving at the command."""
    if com_height_m is None:
        com_height_m = robot.com_height_nominal_m
    hips = np.asarray(robot.foot_nominal_base[:, :2], dtype=float) @ rotation_2d(yaw_rad).T
    feet = np.zeros((4, 3))
    feet[:, 0:2] = hips + (0.0 if foot_offsets_xy is None else np.asarray(foot_offsets_xy, dtype=float))
    vel = np.asarray(vel_cmd_world, dtype=float)
    return CostState(
        com_pos_world=np.array([0.0, 0.0, com_height_m]),
        com_vel_world=np.array([vel[0], vel[1], 0.0]),
        rpy=np.array([0.0, 0.0, yaw_rad]),
        ang_vel_world=np.zeros(3),
        foot_pos_world=feet,
        base_xy_world=np.zeros(2),
        yaw_rad=yaw_rad,
        vel_cmd_world=vel,
        com_height_ref_m=com_height_m,
    )


__all__ = [
    "NX",
    "TERM_NAMES",
    "CostBreakdown",
    "CostState",
    "RankingCost",
    "kin_penalty",
    "nominal_state",
    "predicted_state",
]
