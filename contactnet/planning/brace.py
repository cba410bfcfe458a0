"""Bracing (issue 27): stand on all four feet while a push lasts, step again when it is over.

A horizontal push F on the body, held at the CoM height h, moves the centre of pressure that balances it
``F h / (m g)`` from under the CoM (6 cm at 7.5 N for Solo12). Two stance feet (a trot) cannot hold such an offset
across their diagonal, three (a walk) only inside their triangle: under a push from the side or from behind the
body rolls over its stance feet while the other legs swing (traced: a trot pushed with 7.5 N at 238 degrees rolled
over its FR-HL diagonal within 0.3 s). Four feet hold it inside their rectangle (half-widths of about 14 and 19 cm).

So while the disturbance observer's estimate (``contactnet.planning.observer``) is at least ``threshold_m_s2`` times
the robot's mass (3 N for Solo12), each new step horizon whose step would swing two legs or more
(``min_swinging_legs``: the trot's) stands (``GaitSpec.stand_index``: no leg swings, the optimizer plans the body
over four feet with the push as a known force); a swing under way still lands where it was going. Once the estimate falls below the
threshold the planner steps again, and the capture step (``contactnet.planning.capture``) takes the velocity the
push left. Standing is always safe on the terrain the feet already stand on, so bracing needs no terrain check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from contactnet.motion.gait import GaitSpec
from contactnet.planning.ranking import PlannedStep


@dataclass(frozen=True)
class BraceConfig:
    """When the loop braces instead of stepping."""

    # the estimated push (horizontal magnitude) from which a new step horizon stands, per kg of the robot's mass
    threshold_m_s2: float = 1.2
    # only a step that would swing this many legs or more is replaced (2: the trot's; a walk's three stance feet
    # hold a push inside their triangle, and the walk stepping on with its capture step did as well as bracing)
    min_swinging_legs: int = 2

    def __post_init__(self) -> None:
        if not (math.isfinite(self.threshold_m_s2) and self.threshold_m_s2 >= 0.0):
            raise ValueError(f"BraceConfig.threshold_m_s2 must be a finite number >= 0, got {self.threshold_m_s2!r}")
        if not 1 <= self.min_swinging_legs <= 4:
            raise ValueError(f"BraceConfig.min_swinging_legs must be 1 to 4, got {self.min_swinging_legs!r}")


def braces(config: BraceConfig | None, force_xy: tuple[float, float] | None, first_step: PlannedStep,
           mass_kg: float) -> bool:
    """Whether the next step horizon stands instead of ``first_step`` (the planner's): bracing on, a push estimated
    at ``threshold_m_s2 * mass_kg`` or more (N), and a step that swings ``min_swinging_legs`` legs or more."""
    return (config is not None and force_xy is not None and len(first_step.legs) >= config.min_swinging_legs
            and math.hypot(*force_xy) >= config.threshold_m_s2 * mass_kg)


def standing_horizon(gait: GaitSpec, n_steps: int) -> list[PlannedStep]:
    """``n_steps`` standing steps (no leg swings), as a planner's stand choice makes them."""
    return [PlannedStep(legs=(), footholds_xy_world=np.zeros((0, 2)), action_index=gait.stand_index, rank=None)
            for _ in range(n_steps)]


__all__ = ["BraceConfig", "braces", "standing_horizon"]
