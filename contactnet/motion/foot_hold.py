"""A stance foot that lost its contact held where it stood (``LocomotionConfig.foot_hold``; off by default).

The optimizer may plan a stance foot's force down to nothing (the body over the other feet during a swing), and a
push can lift the body off a foot. Such a foot, still planned in stance, gets ``-J^T f`` with ``f`` about zero: no
task holds its leg, which follows the body, and on a holed terrain it can drift over a gap while it is off the ground
(docs/results.md, "A stance foot that lost its contact"). A foot planned in stance that had its contact in this
stance and has lost it for ``lost_ticks`` ticks is tracked by the swing PD instead, to the point where it last stood
pressed ``press_m`` into the ground, until it touches again: it carries no force meanwhile and the body's wrench is
spread over the others. Off by default: a foot unloaded by a body that tilts over it then stops pushing it back down
(docs/results.md, "A stance foot that lost its contact": a standing robot leaning into its command falls with it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FootHoldConfig:
    """When a stance foot counts as lost (ticks without contact in a row, after it touched in this stance) and how
    far below its last standing point it is pressed (m)."""

    lost_ticks: int = 5
    press_m: float = 0.01

    def __post_init__(self) -> None:
        if isinstance(self.lost_ticks, bool) or not (isinstance(self.lost_ticks, int) and self.lost_ticks >= 1):
            raise ValueError(f"FootHoldConfig.lost_ticks must be a whole number >= 1, got {self.lost_ticks!r}")
        if not (isinstance(self.press_m, int | float) and 0.0 <= self.press_m <= 0.05):
            raise ValueError(f"FootHoldConfig.press_m must be in [0, 0.05] m, got {self.press_m!r}")


class FootHold:
    """The stance feet's last standing points and how long each has been off the ground (one per run)."""

    def __init__(self, config: FootHoldConfig) -> None:
        self.config = config
        self.anchors_world = np.zeros((4, 3))  # where each stance foot last touched
        self.planted = np.zeros(4, dtype=bool)  # touched since its stance began
        self.lost = np.zeros(4, dtype=int)  # ticks off the ground since, in stance
        self.held_ticks = 0  # ticks with a foot held (the run's summary)

    def apply(self, stance: np.ndarray, contact: np.ndarray, feet_world: np.ndarray, swing_pos: np.ndarray,
              swing_vel: np.ndarray) -> None:
        """In place on ``stance`` (4,), ``swing_pos`` and ``swing_vel`` (4, 3): a lost stance foot becomes a swing
        foot tracking its anchor. ``contact`` (4,) the feet touching now, ``feet_world`` (4, 3) where they are."""
        held = False
        for leg in range(4):
            if not stance[leg]:
                self.planted[leg] = False
                self.lost[leg] = 0
                continue
            if contact[leg]:
                self.planted[leg] = True
                self.lost[leg] = 0
                self.anchors_world[leg] = feet_world[leg]
                continue
            if not self.planted[leg]:
                continue
            self.lost[leg] += 1
            if self.lost[leg] >= self.config.lost_ticks:
                stance[leg] = False
                swing_pos[leg] = self.anchors_world[leg]
                swing_pos[leg, 2] -= self.config.press_m
                swing_vel[leg] = 0.0
                held = True
        self.held_ticks += held


__all__ = ["FootHold", "FootHoldConfig"]
