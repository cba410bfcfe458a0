"""The weights of the ranking cost V, one set per gait (``GaitSpec.cost_weights``); see ``contactnet.planning.cost``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CostWeights:
    """Weights of the ranking cost and the shape of its kinematic term.

    ``V = sum_k (opt V_opt + stab V_stab + kin V_kin) + cent V_cent - area V_area + swing V_swing + short V_short``
    with the terms in SI units (V_opt: the optimizer's cost; V_stab and V_cent in m; V_kin in violations;
    V_area in m^2; V_swing: how many legs swing; V_short: for each swinging foot, how much less than
    ``short_swing_m`` it moves, as a fraction of ``short_swing_m``). ``swing`` and ``short`` are the
    energy-like terms of the stand choice (``contactnet.motion.gait``, ``stand``): a swing costs effort, and a swing
    that barely moves its foot costs more; standing costs neither.
    Walk: ``WALK_WEIGHTS`` (the defaults); trot: ``TROT_WEIGHTS``; each ``GaitSpec`` carries its own
    (``GaitSpec.cost_weights``). The kinematic threshold is the robot's (``RobotDescription.kin_threshold_m``).

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
    * ``kin = 50`` per violation, ramp 2 cm, threshold the robot's (Solo12: 0.12 m): a violation costs more than everything
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
    #: Each further ``kin_ramp_m`` beyond the threshold adds one more violation (the hinge's slope).
    kin_ramp_m: float = 0.02
    #: The hips move with the CoM over the horizon (constant hip-CoM offset): along the CoM reference path
    #: (``"reference"``: the commanded velocity) or along each candidate's optimized CoM (``"optimized"``).
    kin_hip_path: str = "reference"
    #: V of a candidate whose optimization failed (the same constant for all failures).
    failure_cost: float = 1e6
    #: Whether standing (no leg swings for a step horizon) is one of the choices the cost ranks.
    stand: bool = True
    #: Effort per swinging leg, and the penalty of a swing that moves its foot by less than ``short_swing_m``
    #: (full at zero displacement, none from ``short_swing_m`` on).
    swing: float = 0.05
    short: float = 0.5
    short_swing_m: float = 0.03

    def __post_init__(self) -> None:
        values = (self.opt, self.stab, self.kin, self.cent, self.area, self.failure_cost, self.swing, self.short)
        if not all(np.isfinite(v) and v >= 0.0 for v in values):
            raise ValueError(f"cost weights must be finite and >= 0, got {values}")
        if not self.kin_ramp_m > 0.0:
            raise ValueError("kin_ramp_m must be > 0")
        if not self.short_swing_m > 0.0:
            raise ValueError("short_swing_m must be > 0")
        if self.kin_hip_path not in ("reference", "optimized"):
            raise ValueError(f"kin_hip_path must be 'reference' or 'optimized', got {self.kin_hip_path!r}")

    def vector(self) -> np.ndarray:
        """Signed weights of the ``TERM_NAMES`` columns: V = terms @ vector()."""
        return np.array([self.opt, self.stab, self.kin, self.cent, -self.area, self.swing, self.short])


#: Walk: the defaults of ``CostWeights``.
WALK_WEIGHTS = CostWeights()
#: Trot: see ``CostWeights``.
TROT_WEIGHTS = CostWeights(stab=10.0, cent=100.0, area=5.0)
