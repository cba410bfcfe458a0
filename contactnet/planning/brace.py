"""Bracing (issue 27): stand on all four feet while a push lasts, step again when it is over.

A horizontal push F on the body, held at the CoM height h, moves the centre of pressure that balances it
``F h / (m g)`` from under the CoM (6 cm at 7.5 N for Solo12). Two stance feet (a trot) cannot hold such an offset
across their diagonal, three (a walk) only inside their triangle: under a push from the side or from behind the
body rolls over its stance feet while the other legs swing (traced: a trot pushed with 7.5 N at 238 degrees rolled
over its FR-HL diagonal within 0.3 s). Four feet hold it inside their rectangle (half-widths of about 14 and 19 cm).

So while the disturbance observer's estimate (``contactnet.planning.observer``) is at least ``threshold_m_s2`` times
the robot's mass (3 N for Solo12), each new step horizon stands (``GaitSpec.stand_index``: no leg swings, the
optimizer plans the body over four feet with the push as a known force; ``min_swinging_legs`` 2 would brace the
trot only). A step already under way when the estimate first reaches the threshold comes down at once
(``touch_down``): its swinging feet land within ``touchdown_s`` where they are, or back where they lifted off if
that is not safe ground, and feet about to lift stay down. Traced: a trot pushed sideways as its diagonal lifted
gathered 0.4 m/s sideways in the 0.2 s that diagonal swung and then rolled over its four feet; with the touchdown
it gathered 0.25 m/s and stood. A foot so put down on the push's side of the CoM can land ``outward_m`` farther
along the push (the robot's ``brace_outward_m`` on terrain of one level by default; Go2's 5 cm), if that is safe
ground: met as a front foot lifts, a side push asks a centre of pressure beyond the other three feet's triangle, and
the foot that comes down is the one that can widen the support where it is asked (measured on Go2: docs/results.md).
While a horizon is braced the CoM reference stands still (``hold_reference``, ``contactnet.motion.com_reference``):
going on with the command, it took the body over its standing feet (9 cm in a 1 s push at 0.1 m/s). Once the
estimate falls below the threshold the planner steps again, and the capture step (``contactnet.planning.capture``)
takes the velocity the push left. Standing is always safe on the terrain the feet already stand on, and a foot put
down early lands on safe ground or where it stood, so bracing needs no other terrain check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from contactnet.motion.active_plan import ActivePlan, liftoff_point
from contactnet.motion.controller import SwingTrajectory
from contactnet.motion.gait import GaitSpec
from contactnet.planning.ranking import PlannedStep
from contactnet.robots.description import MAX_BRACE_OUTWARD_M
from contactnet.terrain import Terrain


@dataclass(frozen=True)
class BraceConfig:
    """When the loop braces instead of stepping."""

    # the estimated push (horizontal magnitude) from which a new step horizon stands, per kg of the robot's mass
    threshold_m_s2: float = 1.2
    # only a step that would swing this many legs or more is replaced (1: the walk's and the trot's; 2 braced the
    # trot only, before the touchdown below: the walk then did no better braced than stepping on with its capture
    # step, with it bracing saved 3 of its 4 falls at 7.5 N and lost none of 16)
    min_swinging_legs: int = 1
    # such a step already under way when the push is first estimated at the threshold puts its swinging feet down
    # at once (``touchdown_s``), where they are if that is safe ground, else back where they lifted off; not if its
    # swing ends within ``min_remaining_s`` anyway
    touch_down: bool = True
    touchdown_s: float = 0.04  # (0.08 s came too late: a trot on flat pushed with 7.5 N at four moments of its swing
    min_remaining_s: float = 0.05  # fell 5 times of 8 with it, 6 without a touchdown and never with 0.04 s)
    # a foot so put down on the push's side of the CoM lands this far beyond where it is, along the estimated push
    # (m; if that is safe ground): a wider support where the push drives the centre of pressure. None: the robot's
    # ``brace_outward_m`` (RobotSpec; Go2 0.05, Solo12 0)
    outward_m: float | None = None
    # while a horizon is braced the CoM reference stands still: the command's velocity is not planned and the
    # reference path does not move on with it (on its leash it follows only a body pushed away); False: the body
    # creeps on over its standing feet at the command. Not for the rest of a step the touchdown put down (held then
    # too, the trot pushed as its diagonal lifted, tested, tipped over)
    hold_reference: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.threshold_m_s2) and self.threshold_m_s2 >= 0.0):
            raise ValueError(f"BraceConfig.threshold_m_s2 must be a finite number >= 0, got {self.threshold_m_s2!r}")
        for name in ("touchdown_s", "min_remaining_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"BraceConfig.{name} must be a finite number > 0 (s), got {value!r}")
        if not 1 <= self.min_swinging_legs <= 4:
            raise ValueError(f"BraceConfig.min_swinging_legs must be 1 to 4, got {self.min_swinging_legs!r}")
        if self.outward_m is not None and not (isinstance(self.outward_m, int | float)
                                               and 0.0 <= self.outward_m <= MAX_BRACE_OUTWARD_M):
            raise ValueError(f"BraceConfig.outward_m must be None (the robot's) or in [0, {MAX_BRACE_OUTWARD_M}] m, "
                             f"got {self.outward_m!r}")

    def outward_on(self, robot_outward_m: float, heights: bool) -> float:
        """The ``outward_m`` a loop takes: this config's, else the robot's (``RobotDescription.brace_outward_m``)
        on terrain of one level and 0 on terrain with heights (where a foot moved sideways could meet a top's side)."""
        if self.outward_m is not None:
            return float(self.outward_m)
        return 0.0 if heights else float(robot_outward_m)


def braces(config: BraceConfig | None, force_xy: tuple[float, float] | None, first_step: PlannedStep,
           mass_kg: float) -> bool:
    """Whether the next step horizon stands instead of ``first_step`` (the planner's): bracing on, a push estimated
    at ``threshold_m_s2 * mass_kg`` or more (N), and a step that swings ``min_swinging_legs`` legs or more."""
    return (config is not None and force_xy is not None and len(first_step.legs) >= config.min_swinging_legs
            and math.hypot(*force_xy) >= config.threshold_m_s2 * mass_kg)


def touch_down_now(plan: ActivePlan, config: BraceConfig, gait: GaitSpec, t_now_s: float, feet_world: np.ndarray,
                   terrain: Terrain, foot_radius_m: float, push_xy_n: np.ndarray | None = None,
                   com_xy_world: np.ndarray | None = None, outward_m: float = 0.0) -> bool:
    """Bracing's touchdown on ``plan`` (edited in place) at ``t_now_s``: each swinging leg of the current step whose
    swing lasts ``min_remaining_s`` more comes down within ``touchdown_s`` (``touchdown_point``) and stands there
    until its next planned step; a leg that has not lifted off yet stays down. ``feet_world`` (4, 3): the foot
    centres now. A foot in the air on the side of ``com_xy_world`` (2,) the push ``push_xy_n`` (2,) points to lands
    ``outward_m`` beyond where it is along the push (``outward_shift``). Returns whether anything changed (the
    optimizer must then solve again)."""
    t_down_s = t_now_s + config.touchdown_s
    node_down = int(np.ceil((t_down_s - plan.plan_t0_s) / gait.node_dt_s - 1e-9))
    changed = False
    for leg, swing in list(plan.swings.items()):
        if plan.touched[leg] or swing.t1_s - t_now_s < config.min_remaining_s:
            continue
        liftoff = liftoff_point(swing)
        lifted = t_now_s >= swing.t0_s
        if lifted:  # in the air: a swing from here down onto the ground
            shift = outward_shift(feet_world[leg, :2], com_xy_world, push_xy_n, outward_m)
            ground = touchdown_point(terrain, feet_world[leg], liftoff, foot_radius_m, shift)
            plan.swings[leg] = SwingTrajectory(start_world=feet_world[leg].copy(),
                                               end_world=ground + np.array([0.0, 0.0, foot_radius_m]),
                                               t0_s=t_now_s, t1_s=t_down_s, height_m=0.0)
            plan.stand_on(leg, node_down, ground, gait, in_contact=True)
        else:  # it has not left the ground: it stays
            ground = touchdown_point(terrain, liftoff, liftoff, foot_radius_m)
            plan.touched[leg] = True
            plan.stand_on(leg, plan.node_at(t_now_s, gait.node_dt_s), ground, gait, in_contact=True)
        changed = True
    return changed


def outward_shift(foot_xy_world: np.ndarray, com_xy_world: np.ndarray | None, push_xy_n: np.ndarray | None,
                  outward_m: float) -> np.ndarray | None:
    """(2,) how far a foot put down by bracing lands beyond where it is: ``outward_m`` along the push if the foot
    is on the push's side of the CoM (its offset from the CoM has a positive component along the push); None
    otherwise (no push, no CoM, ``outward_m`` 0, or a foot on the other side)."""
    if outward_m <= 0.0 or push_xy_n is None or com_xy_world is None:
        return None
    force = float(np.hypot(*push_xy_n))
    if force <= 0.0:
        return None
    along = np.asarray(push_xy_n, dtype=float) / force
    if float((np.asarray(foot_xy_world, dtype=float) - com_xy_world) @ along) <= 0.0:
        return None
    return outward_m * along


def touchdown_point(terrain: Terrain, foot_world: np.ndarray, liftoff_world: np.ndarray,
                    margin_m: float, shift_xy_m: np.ndarray | None = None) -> np.ndarray:
    """Where a swinging foot (centre ``foot_world``, lifted off at ``liftoff_world``) comes down when bracing cuts
    its swing short: ``shift_xy_m`` (2,) beyond the point under it if that is ``margin_m`` inside safe ground, else
    the point under it if that is, else its lift-off point (it stood there). Returns the contact point (3,): that x,
    y and the ground's height there."""
    candidates = [foot_world[:2]] if shift_xy_m is None else [foot_world[:2] + shift_xy_m, foot_world[:2]]
    xy = next((c for c in candidates if bool(terrain.is_safe(c[None], margin_m)[0])), liftoff_world[:2])
    return np.array([xy[0], xy[1], float(terrain.ground_z(xy[None])[0])])


def standing_horizon(gait: GaitSpec, n_steps: int) -> list[PlannedStep]:
    """``n_steps`` standing steps (no leg swings), as a planner's stand choice makes them."""
    return [PlannedStep(legs=(), footholds_xy_world=np.zeros((0, 2)), action_index=gait.stand_index, rank=None)
            for _ in range(n_steps)]


__all__ = ["BraceConfig", "braces", "outward_shift", "standing_horizon", "touch_down_now",
           "touchdown_point"]
