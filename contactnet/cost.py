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
* ``V_area``: area of the final support polygon (convex hull of the four feet).

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
(``RankingCost.evaluate_reference``): one ``solve`` per candidate, shapely polygons, Python loops. The
tests check that both give the same V and ranking.

Failed optimizations (infeasible, iteration limit, numerical failure) get ``V = CostWeights.failure_cost``
exactly (a large finite constant, the same for all of them) and NaN terms; ``ranking`` sorts stably, so
failures tie at the bottom in index order and the order of the others is untouched.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from contactnet.gait import GaitSpec
from contactnet.robot import FOOT_RADIUS_M
from contactnet.trajopt import (
    NX,
    SrbdModel,
    TrajectoryOptimizer,
    TrajoptConfig,
    TrajoptProblem,
    TrajoptSolution,
    TrajoptWeights,
)

#: The candidate grids are centred on the hips at the base position moved by this much of commanded
#: velocity (0: the current hips, the paper's "fixed offsets from the current hip position").
GRID_LEAD_S = 0.0

#: Columns of ``CostBreakdown.terms``.
TERM_NAMES: tuple[str, ...] = ("opt", "stab", "kin", "cent", "area")


@dataclass(frozen=True)
class CostWeights:
    """Weights of the ranking cost and the shape of its kinematic term.

    ``V = sum_k (opt V_opt + stab V_stab + kin V_kin) + cent V_cent - area V_area`` with the terms in SI
    units (V_opt: the optimizer's cost; V_stab and V_cent in m; V_kin in violations; V_area in m^2).
    Walk: ``WALK_WEIGHTS`` (the defaults); trot: ``TROT_WEIGHTS``; ``for_gait(name)`` picks one.

    How they were chosen. The oracle is greedy (cheapest action now), so a good cost is one whose greedy
    choices keep walking: ``weight_study`` takes the cheapest action 30 times from standing, each from
    the state the oracle predicts, at six commanded velocities spanning the data generation range, and
    reports the worst foot-to-hip distance, the chosen actions' V_stab and V_kin and how often the same
    legs swing twice in a row. Grid searches over stab {10, 30, 100, 300}, cent {2 .. 100}, area
    {0, 1, 3, 5}, kin threshold {0.10, 0.12} gave the weights below; then PyBullet confirmed them
    (``Locomotion`` with ``OraclePlanner``, no fall: walk and trot for 10-12 s on flat at 0.1 m/s forward,
    sideways and diagonally backwards, 0.05 m/s forward; the stepping stones and the first version of
    the narrow stones, with 8-10 cm bars, at 0.05 m/s, both gaits, to the goal). Rollout totals over
    the six velocities (worst foot-hip m, sum V_stab, repeats):

    =====================================  =======  ======  =======
    walk: WALK_WEIGHTS                      0.150    1.9     0.14
    walk, cent 2 / area 5 (first guess)     0.220    6.4     0.12
    walk, stab 10                           0.150    2.6     0.14
    walk, kin threshold 0.10                0.128    4.3     0.08
    trot: TROT_WEIGHTS                      0.090    6.0     0.05
    trot with WALK_WEIGHTS                  0.117    5.5     0.21
    trot, stab 100                          0.112    5.8     0.14
    trot, area 0                            0.090    7.1     0.10
    =====================================  =======  ======  =======

    * ``opt = 1``: the scale. Over the candidates of a walking state V_opt spans about 0.15-0.5; it
      strongly prefers lifting the legs the CoM moves away from (hind legs when walking forward:
      0.15 vs 0.28) and hardly cares where a foot lands.
    * ``cent`` (walk 40, trot 100 per m): the term that makes greedy stepping sustainable. A foot moved
      by d shifts the centroid by d/4, so with cent/4 above V_opt's preference for the "easy" legs
      (~0.13 per step) the lagging leg is the one that moves, and it moves until the support centroid
      is under the final CoM. With cent 2-10 the feet fall behind (worst foot-hip 0.22-0.28 m, then
      kinematic violations at every step). Trot needs more: alternating pairs must land so that both
      diagonals pass near the CoM path, which is what a small V_cent measures.
    * ``stab`` (walk 100, trot 10 per m per node): for the walk a CoM 1 cm outside the swing triangle
      for the 4 swing nodes costs 4, above the whole spread of V_opt, so the static-stability order of
      the crawl wins. For the trot the "polygon" is a segment the moving CoM can never stay on, so V_stab
      is a controllability measure that is never zero; with 100 it dominates and the pair whose diagonal
      is nearer the CoM *now* swings again and again (repeats 0.14 vs 0.05).
    * ``kin = 50`` per violation, threshold 0.12 m, ramp 2 cm: a violation costs more than everything
      else together on a normal step ("a high value") and grows with the excess, so that among bad
      plans the least bad ranks first. Threshold: Solo12's hip (HFE) stands 0.24 m above the ground
      with 0.16 + 0.16 m links and the foot-ball centre 0.223 m below it; a foot 0.12 m from its hip
      reference needs sqrt(0.12^2 + 0.223^2) = 0.253 m, 79 % of full reach, leaving room for 4 cm of
      height loss (90 %) and for the abduction offset before the knee straightens. The corners of the
      20 x 20 cm walk grid (0.141 m) lie beyond it on purpose. 0.10 m keeps the feet closer (0.128 vs
      0.150 m) but doubles V_stab: legs get moved for kinematics before the support allows it.
    * ``area`` (walk 3, trot 5 per m^2): moving a foot 5 cm outward adds ~0.01 m^2, i.e. 0.03-0.05;
      it breaks ties between equivalent footholds toward a wider support (area 0: V_stab 2.4 vs 1.9
      walking, 7.1 vs 6.0 trotting) and stays far below V_cent's pull (cent/4 per m of foot motion).
      When it is not (the first guess, cent 2 / area 5), it pushes hind feet backwards, since a hind
      foot moved back lengthens the polygon (~0.15 m^2 per m), and the feet fall behind.
    """

    opt: float = 1.0
    stab: float = 100.0
    kin: float = 50.0
    cent: float = 40.0
    area: float = 3.0
    #: Horizontal foot-to-hip-reference distance above which a stance foot violates the kinematic limit.
    kin_threshold_m: float = 0.12
    #: Each further ``kin_ramp_m`` beyond the threshold adds one more violation (the hinge's slope).
    kin_ramp_m: float = 0.02
    #: The hips move with the CoM over the horizon (constant hip-CoM offset): along the CoM reference path
    #: (``"reference"``: the commanded velocity) or along each candidate's optimized CoM (``"optimized"``).
    kin_hip_path: str = "reference"
    #: V of a candidate whose optimization failed (the same constant for all failures).
    failure_cost: float = 1e6

    def __post_init__(self) -> None:
        values = (self.opt, self.stab, self.kin, self.cent, self.area, self.failure_cost)
        if not all(np.isfinite(v) and v >= 0.0 for v in values):
            raise ValueError(f"cost weights must be finite and >= 0, got {values}")
        if not (self.kin_threshold_m > 0.0 and self.kin_ramp_m > 0.0):
            raise ValueError("kin_threshold_m and kin_ramp_m must be > 0")
        if self.kin_hip_path not in ("reference", "optimized"):
            raise ValueError(f"kin_hip_path must be 'reference' or 'optimized', got {self.kin_hip_path!r}")

    @classmethod
    def for_gait(cls, gait_name: str) -> CostWeights:
        """The tuned weights of a gait (``WALK_WEIGHTS`` or ``TROT_WEIGHTS``)."""
        try:
            return {"walk": WALK_WEIGHTS, "trot": TROT_WEIGHTS}[gait_name]
        except KeyError:
            raise ValueError(f"no cost weights for gait {gait_name!r}") from None

    def vector(self) -> np.ndarray:
        """Signed weights of the ``TERM_NAMES`` columns: V = terms @ vector()."""
        return np.array([self.opt, self.stab, self.kin, self.cent, -self.area])


#: Walk: the defaults of ``CostWeights``.
WALK_WEIGHTS = CostWeights()
#: Trot: see ``CostWeights``.
TROT_WEIGHTS = CostWeights(stab=10.0, cent=100.0, area=5.0)


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
    surface_z: float = 0.0  #: ground height the swinging feet land on

    @classmethod
    def from_context(cls, ctx) -> CostState:  # noqa: ANN001 - planner.PlanningContext (import cycle)
        """The state of a ``PlanningContext`` (feet there are ball centres; the height is relative)."""
        feet = np.array(ctx.foot_pos_world, dtype=float)
        feet[:, 2] -= FOOT_RADIUS_M
        surface_z = float(ctx.terrain.surface_z)
        return cls(
            com_pos_world=np.array(ctx.com_pos_world, dtype=float),
            com_vel_world=np.array(ctx.com_vel_world, dtype=float),
            rpy=np.array(ctx.rpy, dtype=float),
            ang_vel_world=np.array(ctx.ang_vel_world, dtype=float),
            foot_pos_world=feet,
            base_xy_world=np.array(ctx.base_xy_world, dtype=float),
            yaw_rad=float(ctx.yaw_rad),
            vel_cmd_world=np.asarray(ctx.vel_cmd_world(), dtype=float),
            com_height_ref_m=float(ctx.com_height_ref_m) + surface_z,
            surface_z=surface_z,
        )

    def x0(self) -> np.ndarray:
        """The optimizer's initial state (12,)."""
        return np.concatenate([self.com_pos_world, self.com_vel_world, self.rpy, self.ang_vel_world]).astype(float)


@dataclass
class CostBreakdown:
    """V of every candidate action of one state, with its terms and trajectories."""

    V: np.ndarray  #: (N_a,) weighted total; ``failure_cost`` where the optimization failed
    terms: np.ndarray  #: (N_a, 5) unweighted sums, columns TERM_NAMES; NaN where it failed
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

_PAIRS = np.array([(i, j) for i in range(4) for j in range(i, 4)])  # with i == j: single points
_TRIANGLES = np.array(list(itertools.combinations(range(4), 3)))
_CYCLES = np.array([(0, 1, 2, 3), (0, 1, 3, 2), (0, 2, 1, 3)])  # the 3 cyclic orders of 4 points


def support_distance(point_xy: np.ndarray, feet_xy: np.ndarray, stance: np.ndarray) -> np.ndarray:
    """Distance of points to the convex hull of the stance feet, 0 inside (vectorized).

    ``point_xy`` (..., 2), ``feet_xy`` (..., 4, 2), ``stance`` (..., 4) bool; returns (...). With two
    stance feet the hull is a segment, with one a point; with none the distance is ``inf``.

    Exact without building the hull: outside the hull, the nearest hull point lies on a hull edge, and
    every segment between two stance feet lies inside the hull, so the distance is the minimum over all
    such segments; a point is inside the hull iff it is inside a triangle of three stance feet.
    """
    p = np.asarray(point_xy, dtype=float)
    f = np.asarray(feet_xy, dtype=float)
    s = np.asarray(stance, dtype=bool)
    px, py = p[..., 0, None], p[..., 1, None]  # (..., 1)
    fx, fy = f[..., 0], f[..., 1]  # (..., 4)
    ax, ay, bx, by = fx[..., _PAIRS[:, 0]], fy[..., _PAIRS[:, 0]], fx[..., _PAIRS[:, 1]], fy[..., _PAIRS[:, 1]]
    abx, aby, apx, apy = bx - ax, by - ay, px - ax, py - ay  # (..., 10)
    len2 = abx * abx + aby * aby
    dot = apx * abx + apy * aby
    t = np.clip(np.divide(dot, len2, out=np.zeros_like(dot), where=len2 > 0), 0.0, 1.0)
    seg_dist = np.hypot(apx - t * abx, apy - t * aby)
    valid = s[..., _PAIRS[:, 0]] & s[..., _PAIRS[:, 1]]
    dist = np.min(np.where(valid, seg_dist, np.inf), axis=-1)
    # inside a (non-degenerate) triangle of stance feet -> 0
    x0, y0 = fx[..., _TRIANGLES[:, 0]], fy[..., _TRIANGLES[:, 0]]  # (..., 4)
    x1, y1 = fx[..., _TRIANGLES[:, 1]], fy[..., _TRIANGLES[:, 1]]
    x2, y2 = fx[..., _TRIANGLES[:, 2]], fy[..., _TRIANGLES[:, 2]]
    c0 = (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)
    c1 = (x2 - x1) * (py - y1) - (y2 - y1) * (px - x1)
    c2 = (x0 - x2) * (py - y2) - (y0 - y2) * (px - x2)
    twice_area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
    inside = ((c0 >= 0) & (c1 >= 0) & (c2 >= 0)) | ((c0 <= 0) & (c1 <= 0) & (c2 <= 0))
    tri_valid = s[..., _TRIANGLES].all(axis=-1) & (np.abs(twice_area) > 1e-12)
    return np.where((inside & tri_valid).any(axis=-1), 0.0, dist)


def _polygon_area_centroid(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed area (...) and area centroid (..., 2) of polygons (..., n, 2) (shoelace)."""
    x, y = vertices[..., 0], vertices[..., 1]
    xn, yn = np.roll(x, -1, axis=-1), np.roll(y, -1, axis=-1)
    c = x * yn - xn * y
    area = 0.5 * c.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cx = ((x + xn) * c).sum(axis=-1) / (6.0 * area)
        cy = ((y + yn) * c).sum(axis=-1) / (6.0 * area)
    centroid = np.stack([cx, cy], axis=-1)
    degenerate = np.abs(area) < 1e-12  # collinear: fall back to the mean of the vertices
    centroid = np.where(degenerate[..., None], vertices.mean(axis=-2), centroid)
    return area, centroid


def hull_area_centroid(feet_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area (...) and area centroid (..., 2) of the convex hull of 4 points (..., 4, 2) (vectorized).

    The hull is either a quadrilateral (the 4 points in convex position: then the one cyclic order that
    is not self-intersecting has the largest shoelace area of the three) or a triangle (one point inside
    the others': then that triangle's area is larger than any of the three orders'). So the hull is the
    candidate polygon of largest absolute area among the 3 cyclic orders and the 4 triangles.
    """
    f = np.asarray(feet_xy, dtype=float)
    quads = f[..., _CYCLES, :]  # (..., 3, 4, 2)
    tris = f[..., _TRIANGLES, :]  # (..., 4, 3, 2)
    qa, qc = _polygon_area_centroid(quads)
    ta, tc = _polygon_area_centroid(tris)
    areas = np.abs(np.concatenate([qa, ta], axis=-1))  # (..., 7)
    cents = np.concatenate([qc, tc], axis=-2)  # (..., 7, 2)
    best = np.argmax(areas, axis=-1)
    area = np.take_along_axis(areas, best[..., None], axis=-1)[..., 0]
    centroid = np.take_along_axis(cents, best[..., None, None], axis=-2)[..., 0, :]
    return area, centroid


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


def rotation_2d(yaw_rad: float) -> np.ndarray:
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.array([[c, -s], [s, c]])


class RankingCost:
    """The ranking cost of one gait: V for every candidate action of a state.

    ``hip_ref_xy_base`` (4, 2): the legs' hip references in the base frame (Solo12's nominal foot XY,
    ``Solo12.foot_nominal_base[:, :2]``), the centres of the candidate grids. The optimizer (8 nodes,
    batched interior-point method, ``TrajoptConfig.for_candidates``) is built once.
    """

    def __init__(
        self,
        gait: GaitSpec,
        hip_ref_xy_base: np.ndarray,
        weights: CostWeights | None = None,
        model: SrbdModel | None = None,
        trajopt_weights: TrajoptWeights | None = None,
        grid_lead_s: float = GRID_LEAD_S,
    ) -> None:
        self.gait = gait
        self.grid_lead_s = float(grid_lead_s)
        self.hip_ref_xy_base = np.array(hip_ref_xy_base, dtype=float).reshape(4, 2)
        self.weights = weights or CostWeights.for_gait(gait.name)
        self.model = model or SrbdModel()
        self.trajopt_weights = trajopt_weights or TrajoptWeights()
        self.trajopt_config = TrajoptConfig.for_candidates(n_nodes=gait.nodes_per_step)
        if abs(self.trajopt_config.dt_s - gait.node_dt_s) > 1e-12:
            self.trajopt_config = TrajoptConfig(
                n_nodes=gait.nodes_per_step, dt_s=gait.node_dt_s, solver="qp-ipm", tol=self.trajopt_config.tol
            )
        self.optimizer = TrajectoryOptimizer(self.model, self.trajopt_config, self.trajopt_weights)
        self._reference_optimizer: TrajectoryOptimizer | None = None

    # ---- candidates ------------------------------------------------------------------------
    @property
    def n_actions(self) -> int:
        return self.gait.n_actions

    @cached_property
    def _contact(self) -> np.ndarray:
        """(N_a, N, 4) bool contact plan of every action."""
        swing, _ = self.gait.action_table
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
        """(N_a, 4, 2) every foot's xy after each action: swing legs on their cell, the others where they are."""
        return candidate_footholds_world(self.gait, self.grid_centres_world(state), state.yaw_rad,
                                         state.foot_pos_world)

    def _foot_plans(self, state: CostState) -> np.ndarray:
        """(N_a, N, 4, 3) foot contact points of every action's plan (swing feet: landed from touchdown)."""
        swing, _ = self.gait.action_table
        n = self.gait.nodes_per_step
        touchdown = self.gait.n_stance_pre + self.gait.n_swing
        now = np.asarray(state.foot_pos_world, dtype=float)
        landed = np.repeat(now[None], self.n_actions, axis=0)
        landed[..., 0:2] = self.candidate_footholds(state)
        landed[..., 2] = np.where(swing, state.surface_z, now[:, 2])
        plans = np.repeat(now[None, None], self.n_actions, axis=0).repeat(n, axis=1)
        plans[:, touchdown:] = landed[:, None]
        return plans

    def problems(self, state: CostState, foot_plans: np.ndarray | None = None) -> list[TrajoptProblem]:
        """The optimizer problem of every action (one step horizon); ``foot_plans``: ``_foot_plans(state)``."""
        x0 = state.x0()
        vel = np.asarray(state.vel_cmd_world, dtype=float)
        ref = None if state.com_xy_ref_start is None else np.asarray(state.com_xy_ref_start, dtype=float)
        contact = self._contact
        feet = self._foot_plans(state) if foot_plans is None else foot_plans
        return [
            TrajoptProblem(
                x0=x0,
                contact=contact[a],
                foot_pos_world=feet[a],
                com_vel_ref_xy=vel,
                com_height_ref_m=float(state.com_height_ref_m),
                yaw_ref_rad=float(state.yaw_rad),
                com_xy_ref_start=ref,
            )
            for a in range(self.n_actions)
        ]

    # ---- fast path -------------------------------------------------------------------------
    def evaluate(self, state: CostState, keep_solutions: bool = False) -> CostBreakdown:
        """V of every action: one batched optimizer call, vectorized geometry."""
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
        feet = self._foot_plans(nominal_state(self.hip_ref_xy_base))[..., 0:2]
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
        """(N_a, 4) unweighted V_stab, V_kin, V_cent, V_area from CoM trajectories (N_a, N+1, 3) and foot
        plans (N_a, N, 4, 2), vectorized over actions and nodes."""
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
        kin = kin_penalty(dist, w.kin_threshold_m, w.kin_ramp_m).sum(axis=(1, 2))
        area, centroid = hull_area_centroid(feet_xy[:, -1])
        cent = np.linalg.norm(p[:, -1] - centroid, axis=-1)
        return np.stack([stab, kin, cent, area], axis=1)

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

    # ---- reference -------------------------------------------------------------------------
    def reference_optimizer(self) -> TrajectoryOptimizer:
        """An independent solver of the same QP for the reference: casadi + piqp (sparse), one at a time."""
        if self._reference_optimizer is None:
            config = TrajoptConfig(n_nodes=self.gait.nodes_per_step, dt_s=self.gait.node_dt_s, solver="auto")
            self._reference_optimizer = TrajectoryOptimizer(self.model, config, self.trajopt_weights)
        return self._reference_optimizer

    def evaluate_reference(self, state: CostState, optimizer: TrajectoryOptimizer | None = None) -> CostBreakdown:
        """The same V, plainly: one optimizer ``solve`` per action, shapely polygons, Python loops."""
        from shapely.geometry import MultiPoint, Point

        opt = optimizer or self.reference_optimizer()
        w = self.weights
        gait = self.gait
        t0 = time.perf_counter()
        rot = rotation_2d(state.yaw_rad)
        feet_now = np.asarray(state.foot_pos_world, dtype=float)
        hips_now = [np.asarray(state.base_xy_world) + rot @ self.hip_ref_xy_base[leg] for leg in range(4)]
        grid_base = np.asarray(state.base_xy_world) + self.grid_lead_s * np.asarray(state.vel_cmd_world)
        n = gait.nodes_per_step
        terms, success, coms, footholds, solutions = [], [], [], [], []
        opt_time = 0.0
        for index in range(gait.n_actions):
            action = gait.decode(index)
            contact = gait.step_contact(action.legs)
            feet = np.repeat(feet_now[None], n, axis=0)
            for leg, offset in zip(action.legs, action.offsets_xy, strict=True):
                landing = grid_base + rot @ self.hip_ref_xy_base[leg] + rot @ offset
                for k in range(gait.n_stance_pre + gait.n_swing, n):
                    feet[k, leg] = (landing[0], landing[1], state.surface_z)
            problem = TrajoptProblem(
                x0=state.x0(),
                contact=contact,
                foot_pos_world=feet,
                com_vel_ref_xy=np.asarray(state.vel_cmd_world, dtype=float),
                com_height_ref_m=float(state.com_height_ref_m),
                yaw_ref_rad=float(state.yaw_rad),
                com_xy_ref_start=state.com_xy_ref_start,
            )
            ts = time.perf_counter()
            sol = opt.solve(problem, warm_start=False)
            opt_time += time.perf_counter() - ts
            solutions.append(sol)
            success.append(sol.success)
            coms.append(sol.x[:, 0:3])
            footholds.append(feet[-1, :, 0:2])
            com_xy = sol.x[:, 0:2]
            stab = kin = 0.0
            for k in range(n):
                stance = [leg for leg in range(4) if contact[k, leg]]
                hull = MultiPoint([tuple(feet[k, leg, 0:2]) for leg in stance]).convex_hull
                stab += max(hull.distance(Point(*com_xy[j])) for j in (k, k + 1))
                for leg in stance:
                    worst = 0.0
                    for j in (k, k + 1):
                        if w.kin_hip_path == "optimized":
                            hip = hips_now[leg] + (com_xy[j] - com_xy[0])
                        else:
                            hip = hips_now[leg] + j * gait.node_dt_s * np.asarray(state.vel_cmd_world)
                        worst = max(worst, float(np.hypot(*(feet[k, leg, 0:2] - hip))))
                    if worst > w.kin_threshold_m:
                        kin += 1.0 + (worst - w.kin_threshold_m) / w.kin_ramp_m
            final = MultiPoint([tuple(feet[-1, leg, 0:2]) for leg in range(4)]).convex_hull
            cent = final.centroid.distance(Point(*com_xy[-1]))
            terms.append([sol.cost, stab, kin, cent, final.area])
        breakdown = self._finish(
            np.array(terms, dtype=float), np.array(success), np.array(coms), np.array(footholds), solutions
        )
        breakdown.optimizer_s = opt_time
        breakdown.total_s = time.perf_counter() - t0
        return breakdown


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
        feet[leg] = (xy[0], xy[1], state.surface_z)
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
        surface_z=state.surface_z,
    )


def nominal_state(
    hip_ref_xy_base: np.ndarray,
    vel_cmd_world: tuple[float, float] = (0.1, 0.0),
    com_height_m: float = 0.215,
    yaw_rad: float = 0.0,
    foot_offsets_xy: np.ndarray | None = None,
) -> CostState:
    """A standing-then-walking state for tests and studies: base at the origin, feet at their hip
    references plus ``foot_offsets_xy`` (4, 2) (world axes), CoM at the base moving at the command."""
    hips = np.asarray(hip_ref_xy_base, dtype=float) @ rotation_2d(yaw_rad).T
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


# ----------------------------------------------------------------------------------------------------
# Studies: greedy rollouts (how the weights were chosen) and timing
# ----------------------------------------------------------------------------------------------------


def greedy_rollout(cost: RankingCost, state: CostState, n_steps: int = 30) -> dict:
    """Take the cheapest action ``n_steps`` times on flat ground, each from the state predicted by the
    previous one (``predicted_state``: the oracle's own prediction). A cheap stand-in for a simulation:
    a cost whose greedy choices let the feet fall behind the body, or lift a leg with the CoM outside
    the remaining support, is a bad cost.

    Returns ``sequence`` (leg names per step), ``worst_foot_hip_m`` (largest horizontal distance of a
    foot from its hip reference after any step), ``stab`` and ``kin`` (sums of the chosen actions'
    V_stab, V_kin) and ``repeats`` (fraction of steps that swing the same legs as the step before).
    """
    from contactnet.robot import LEG_NAMES

    sequence, worst, stab, kin = [], 0.0, 0.0, 0.0
    for _ in range(n_steps):
        result = cost.evaluate(state)
        best = int(result.ranking()[0])
        legs = cost.gait.decode(best).legs
        sequence.append("".join(LEG_NAMES[leg] for leg in legs))
        stab += float(result.terms[best, 1])
        kin += float(result.terms[best, 2])
        footholds = result.footholds_xy_world[best, list(legs)]
        state = predicted_state(state, footholds, legs, cost.gait.step_duration_s)
        offsets = state.foot_pos_world[:, 0:2] - cost.hip_ref_world(state)
        worst = max(worst, float(np.hypot(offsets[:, 0], offsets[:, 1]).max()))
    repeats = sum(a == b for a, b in zip(sequence[:-1], sequence[1:], strict=True)) / max(1, n_steps - 1)
    return {"sequence": sequence, "worst_foot_hip_m": worst, "stab": stab, "kin": kin, "repeats": repeats}


#: Commanded velocities of ``weight_study`` (world frame, m/s): the data generation range.
STUDY_VELOCITIES: tuple[tuple[float, float], ...] = (
    (0.1, 0.0), (0.05, 0.0), (0.0, 0.1), (-0.07, 0.05), (0.06, -0.1), (-0.09, -0.075),
)


def weight_study(gait: GaitSpec, weights: CostWeights, hip_ref_xy_base: np.ndarray, n_steps: int = 30,
                 **cost_kwargs) -> list[dict]:
    """Greedy rollouts from standing at every ``STUDY_VELOCITIES`` (rows: velocity + ``greedy_rollout``)."""
    cost = RankingCost(gait, hip_ref_xy_base, weights, **cost_kwargs)
    rows = []
    for vel in STUDY_VELOCITIES:
        row = greedy_rollout(cost, nominal_state(hip_ref_xy_base, vel), n_steps)
        rows.append({"vel": vel, **row})
    return rows


def benchmark(n_states: int = 20, seed: int = 0, single_core: bool = True,
              hip_ref_xy_base: np.ndarray | None = None) -> list[dict]:
    """Time ``RankingCost.evaluate`` for walk (100 candidates) and trot (162) on perturbed walking states:
    rows of gait, total_ms, optimizer_ms, rest_ms (medians per state). ``single_core`` pins the process to
    one CPU and torch to one thread while timing (as ``trajopt.benchmark``)."""
    from contactnet.gait import TROT, WALK
    from contactnet.trajopt import _pin_single_core

    hips = _SOLO12_NOMINAL_FOOT_XY if hip_ref_xy_base is None else np.asarray(hip_ref_xy_base, dtype=float)
    rng = np.random.default_rng(seed)
    restore = _pin_single_core() if single_core else None
    rows = []
    try:
        for gait in (WALK, TROT):
            cost = RankingCost(gait, hips)
            times = []
            for i in range(n_states + 1):
                vel = rng.uniform(-0.1, 0.1, 2)
                state = nominal_state(hips, vel, foot_offsets_xy=rng.uniform(-0.04, 0.04, (4, 2)))
                result = cost.evaluate(state)
                if i > 0:  # the first evaluation pays one-time imports
                    times.append((result.total_s, result.optimizer_s))
            t = 1e3 * np.asarray(times)
            rows.append({
                "gait": gait.name,
                "candidates": gait.n_actions,
                "total_ms": float(np.median(t[:, 0])),
                "optimizer_ms": float(np.median(t[:, 1])),
                "rest_ms": float(np.median(t[:, 0] - t[:, 1])),
            })
    finally:
        if restore is not None:
            restore()
    return rows


#: Solo12's nominal foot xy in the base frame (``Solo12.foot_nominal_base[:, :2]``), for studies without
#: loading the robot model.
_SOLO12_NOMINAL_FOOT_XY = np.array(
    [[0.1946, 0.14695], [0.1946, -0.14695], [-0.1946, 0.14695], [-0.1946, -0.14695]]
)


__all__ = [
    "NX",
    "TERM_NAMES",
    "CostBreakdown",
    "CostState",
    "CostWeights",
    "RankingCost",
    "TROT_WEIGHTS",
    "WALK_WEIGHTS",
    "benchmark",
    "greedy_rollout",
    "hull_area_centroid",
    "kin_penalty",
    "nominal_state",
    "predicted_state",
    "support_distance",
    "weight_study",
]
