"""A stance foot that lost its contact held where it stood (``LocomotionConfig.foot_hold``; on by default,
``--no-foot-hold`` turns it off).

The optimizer may plan a stance foot's force down to nothing (the body over the other feet during a swing), and a
push can lift the body off a foot. Such a foot, still planned in stance, gets ``-J^T f`` with ``f`` about zero: no
task holds its leg, which follows the body, and on a holed terrain it can drift over a gap while it is off the ground
(docs/results.md, "A stance foot that lost its contact"). A foot planned in stance that had its contact in this
stance on safe ground (a foot radius inside its top's edges), has lost it for ``lost_ticks`` ticks and is over
ground that is not safe is tracked by the swing PD instead, to the point where it last stood pressed ``press_m``
into the ground, until it touches again: it carries no force meanwhile and the body's wrench is spread over the
others. A foot that lost its load over the middle of its top, or that rose more than ``lift_m`` above where it
stood (a body tilting over it lifted it), stays in stance, where its force pushes it back down: holding those tipped
a standing robot leaning into its command and a Go2 pushed from the side (docs/results.md). A foot that landed on an
edge is not held either: an unsafe landing is the planner's, and holding it carried the fixed gait's walk across
the narrow stones (the paper's Fig. 6, where it falls).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FootHoldConfig:
    """When a stance foot counts as lost (ticks without contact in a row, after it touched in this stance) and how
    far below its last standing point it is pressed (m)."""

    lost_ticks: int = 5
    press_m: float = 0.01
    # a lost foot more than this above the point it last stood (m) was lifted by the body tilting over it, not slid
    # off its spot: it is left in stance, where the body's wrench pushes it back down (None: every lost foot held)
    lift_m: float | None = 0.01
    # ... and is held only if it stood on safe ground (a foot radius inside its top's edges) and its centre is now
    # over ground that is not, then until it touches again or is lifted: a foot that lost its load over the middle
    # of its top stays in the body's wrench, and a foot that landed on an edge (an unsafe landing, the planner's
    # doing: the fixed gait's on the narrow stones) is not rescued (False: every lost foot is held, the terrain unread)
    near_edge: bool = True

    def __post_init__(self) -> None:
        if isinstance(self.lost_ticks, bool) or not (isinstance(self.lost_ticks, int) and self.lost_ticks >= 1):
            raise ValueError(f"FootHoldConfig.lost_ticks must be a whole number >= 1, got {self.lost_ticks!r}")
        if not (isinstance(self.press_m, int | float) and 0.0 <= self.press_m <= 0.05):
            raise ValueError(f"FootHoldConfig.press_m must be in [0, 0.05] m, got {self.press_m!r}")
        lift = self.lift_m
        if lift is not None and not (isinstance(lift, int | float) and 0.0 < lift <= 0.1):
            raise ValueError(f"FootHoldConfig.lift_m must be None (no limit) or in (0, 0.1] m, got {lift!r}")


class FootHold:
    """The stance feet's last standing points and how long each has been off the ground (one per run)."""

    def __init__(self, config: FootHoldConfig) -> None:
        self.config = config
        self.anchors_world = np.zeros((4, 3))  # where each stance foot last touched
        self.planted = np.zeros(4, dtype=bool)  # touched since its stance began
        self.lost = np.zeros(4, dtype=int)  # ticks off the ground since, in stance
        self.holding = np.zeros(4, dtype=bool)  # held now (until it touches again or is lifted)
        self.held_ticks = 0  # ticks with a foot held (the run's summary)

    def apply(self, stance: np.ndarray, contact: np.ndarray, feet_world: np.ndarray, swing_pos: np.ndarray,
              swing_vel: np.ndarray, safe: Callable[[np.ndarray], bool] | None = None) -> None:
        """In place on ``stance`` (4,), ``swing_pos`` and ``swing_vel`` (4, 3): a lost stance foot becomes a swing
        foot tracking its anchor. ``contact`` (4,) the feet touching now, ``feet_world`` (4, 3) where they are;
        ``safe(xy)``: whether a foot centred at ``xy`` (2,) is well inside its top (``near_edge``: held when its
        anchor is and it is not; None: always held)."""
        held = False
        for leg in range(4):
            if not stance[leg] or contact[leg]:
                self.planted[leg] = bool(stance[leg])
                self.lost[leg] = 0
                self.holding[leg] = False
                if stance[leg]:
                    self.anchors_world[leg] = feet_world[leg]
                continue
            if not self.planted[leg]:
                continue
            self.lost[leg] += 1
            lift = self.config.lift_m
            if lift is not None and feet_world[leg, 2] - self.anchors_world[leg, 2] > lift:  # lifted by the body
                # over it: its stance force pushes it back down
                self.holding[leg] = False
                continue
            if not self.holding[leg] and self.lost[leg] >= self.config.lost_ticks:
                self.holding[leg] = not (self.config.near_edge and safe is not None
                                         and (safe(feet_world[leg, :2]) or not safe(self.anchors_world[leg, :2])))
            if self.holding[leg]:
                stance[leg] = False
                swing_pos[leg] = self.anchors_world[leg]
                swing_pos[leg, 2] -= self.config.press_m
                swing_vel[leg] = 0.0
                held = True
        self.held_ticks += held


__all__ = ["FootHold", "FootHoldConfig"]
