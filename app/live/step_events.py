"""What the planner did besides stepping, as viewers see it (issue 14): it may *stand* for a step horizon (all
four feet down: a `StepRecord` with no legs), a step may be *useless* (its feet land less than 2 cm from where
they lifted off), and with retargeting on a swing's landing may move during the swing (`contactnet.planning.retarget`).

`StepEvents` reads a `Locomotion` (from the thread that owns it: the live session's, or a plain loop's for a
recording) and keeps the run's counts (`StepCounts`) and the recent retargets (`RetargetFlash`, flashed at
their new landing in the 3D view for `FLASH_S` of simulated time: `app/scene/marks.py`). Retargeting is a
`LocomotionConfig` setting, off by default like the library's (`loco_config`, `use_retarget`).
"""

from __future__ import annotations

import dataclasses
from collections import deque
from dataclasses import dataclass

import numpy as np

from contactnet.locomotion import Locomotion, LocomotionConfig
from contactnet.planning.observer import DEFAULT_OBSERVER
from contactnet.planning.retarget import RetargetConfig, RetargetedSwing
from contactnet.records import StepCounts

#: A retargeted swing's new landing flashes this long (s, simulated time).
FLASH_S = 1.0
FLASHES_KEPT = 8


@dataclass(frozen=True)
class RetargetFlash:
    """One swing retargeted during its swing: the leg, when, and its landing before and after (foot-ball
    centres, world frame, m)."""

    t_s: float  # simulated time of the retarget
    leg: int  # 0..3 (FL FR HL HR)
    old_world: np.ndarray  # (3,)
    new_world: np.ndarray  # (3,)


@dataclass(frozen=True)
class LiveCounts(StepCounts):
    """The run's counters so far (`contactnet.records.StepCounts`; a useless step is known a step later), and the
    step horizons planned."""

    plans: int = 0  #: step horizons planned (steps and stands)


def loco_config(retarget: bool, base: LocomotionConfig = LocomotionConfig(),
                observer: bool | None = None) -> LocomotionConfig:
    """``base`` with swing retargeting on (the library's `RetargetConfig`) or off, and the disturbance observer on
    (`DEFAULT_OBSERVER`) or off (None: as in ``base``)."""
    config = dataclasses.replace(base, retarget=RetargetConfig() if retarget else None)
    if observer is not None:
        config = dataclasses.replace(config, observer=DEFAULT_OBSERVER if observer else None)
    return config


def use_observer(loco: Locomotion, on: bool) -> None:
    """Turn the disturbance observer on (`DEFAULT_OBSERVER`, a fresh estimate) or off for a running Locomotion."""
    if (loco.config.observer is not None) != on:
        loco.set_observer(DEFAULT_OBSERVER if on else None)


def use_retarget(loco: Locomotion, on: bool) -> None:
    """Turn swing retargeting on or off for a running Locomotion (read at its next re-solve: no restart)."""
    if (loco.config.retarget is not None) != on:
        loco.config = loco_config(on, loco.config)


class StepEvents:
    """Counts and retarget flashes of one Locomotion's run (one thread; `reset` at a restart)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self._records: object = None  # the Locomotion's records list (a new one after its reset)
        self._closed = 0  # records counted for good (all but the last: its `useless` is known a plan later)
        self._stand = self._useless = self._captured = 0
        self._flashes: deque[RetargetFlash] = deque(maxlen=FLASHES_KEPT)
        self._seen: deque[tuple[float, int]] = deque(maxlen=4 * FLASHES_KEPT)

    def update(self, loco: Locomotion) -> tuple[LiveCounts, tuple[RetargetFlash, ...]]:
        """The counts now, and the retargets of the last `FLASH_S` (oldest first)."""
        records = loco.records
        if records is not self._records or len(records) < self._closed:
            self.reset()
            self._records = records
        closed = max(self._closed, len(records) - 1)
        for record in records[self._closed : closed]:
            self._stand += record.stand
            self._useless += record.useless
            self._captured += record.captured
        self._closed = closed
        last_stand = bool(records) and records[-1].stand
        last_captured = bool(records) and records[-1].captured
        plan = loco.plan
        for leg, swing in (plan.swings.items() if plan is not None else ()):
            if isinstance(swing, RetargetedSwing) and (swing.t_retarget_s, leg) not in self._seen:
                self._seen.append((swing.t_retarget_s, leg))
                self._flashes.append(RetargetFlash(float(swing.t_retarget_s), int(leg),
                                                   np.array(swing.base.end_world, dtype=float),
                                                   np.array(swing.end_world, dtype=float)))
        now = loco.t_s
        counts = LiveCounts(plans=len(records), stand_steps=self._stand + last_stand, useless_steps=self._useless,
                            swing_retargets=loco.swing_retargets, capture_steps=self._captured + last_captured)
        return counts, tuple(f for f in self._flashes if 0.0 <= now - f.t_s < FLASH_S)


__all__ = ["FLASH_S", "LiveCounts", "RetargetFlash", "StepEvents", "loco_config", "use_observer", "use_retarget"]
