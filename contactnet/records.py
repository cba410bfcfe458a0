"""What a run of the locomotion loop records: one ``StepRecord`` per planned step horizon, the ``Snapshot`` a viewer
draws at one instant, and timing statistics."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from contactnet.planning.ranking import PlannedStep

#: A step whose swinging feet all land closer than this to where they lifted off is useless (``useless_steps``).
USELESS_STEP_M = 0.02


@dataclass
class StepRecord:
    """One executed step: what was planned and what it cost."""

    t_s: float
    legs: tuple[str, ...]
    footholds_xy_world: np.ndarray
    planner_s: float
    rank: int | None
    discarded: int
    safe_landing: bool
    # Largest rise or drop (m) of the tops under a swinging foot from lift-off to touchdown, measured at the
    # next plan (NaN until then).
    height_change_m: float = math.nan
    # How far (m, horizontally) the swinging feet moved from lift-off, the most of them, measured at the next plan
    # (NaN until then; 0 for standing).
    moved_m: float = math.nan
    # The planner shifted this step's candidates towards the capture point after a push (contactnet.planning.capture).
    captured: bool = False
    # The loop stood on four feet instead of this step because a push was on (contactnet.planning.brace).
    braced: bool = False

    @property
    def stand(self) -> bool:
        """The planner chose not to step: no leg swung during this step horizon."""
        return not self.legs

    @property
    def useless(self) -> bool:
        """A step whose swinging feet all landed less than ``USELESS_STEP_M`` from where they lifted off."""
        return bool(self.legs) and self.moved_m < USELESS_STEP_M


@dataclass(frozen=True)
class StepCounts:
    """A run's step counters, declared once: `Locomotion.summary`, the web tool's live view and end-of-run card and
    its API all report these (a new counter is a field here, and its count in `of_run`)."""

    stand_steps: int = 0  #: step horizons the planner chose to stand (no leg swung)
    useless_steps: int = 0  #: steps whose feet landed less than `USELESS_STEP_M` from where they lifted off
    swing_retargets: int = 0  #: swings whose landing moved during the swing
    capture_steps: int = 0  #: steps whose candidates moved towards the capture point after a push

    @classmethod
    def of_run(cls, records: list[StepRecord], swing_retargets: int) -> StepCounts:
        """The counts of a run's records (and its swing retargets, which the loop counts as they happen)."""
        return cls(stand_steps=sum(r.stand for r in records), useless_steps=sum(r.useless for r in records),
                   swing_retargets=int(swing_retargets), capture_steps=sum(r.captured for r in records))

    def as_dict(self) -> dict[str, int]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass
class Snapshot:
    """Everything a viewer needs at one instant (world frame)."""

    t_s: float
    q: np.ndarray  # (19,) pinocchio configuration
    com_pos: np.ndarray
    com_vel: np.ndarray
    stance: np.ndarray  # (4,) bool, planned
    foot_contact: np.ndarray  # (4,) bool, measured
    forces: np.ndarray  # (4, 3) commanded ground reaction forces
    planned_steps: list[PlannedStep]
    com_plan: np.ndarray  # (N+1, 3) planned CoM positions
    vel_cmd_xy: tuple[float, float]
    fell: bool
    fall_reason: str | None
    reached_goal: bool
    last_planner_ms: float
    last_trajopt_ms: float
    steps: int
    candidates: Any = None  # the ranking planner's CandidateRanking of the current step (None: no ranking)


def records_summary(records: list[StepRecord]) -> dict:
    """The parts of a run's summary (``Locomotion.summary``) that its step records give: the legs of each step that
    swung, the chosen actions' ranks, the landings known unsafe, the largest rise or drop of a step and the steps
    braced."""
    ranks = [r.rank for r in records if r.rank is not None]
    return {
        "gait_sequence": [list(r.legs) for r in records if r.legs],
        "rank_chosen": {"mean": float(np.mean(ranks)) if ranks else 0.0, "max": int(max(ranks)) if ranks else 0},
        "unsafe_landings": sum(not r.safe_landing for r in records),
        "max_height_change_m": max((r.height_change_m for r in records if not math.isnan(r.height_change_m)),
                                   default=0.0),
        "brace_steps": sum(r.braced for r in records),
    }


def summary_stats(values_s: list[float]) -> dict[str, float]:
    """mean / median / p99 / max in milliseconds (zeros when empty)."""
    if not values_s:
        return {"mean": 0.0, "median": 0.0, "p99": 0.0, "max": 0.0}
    ms = np.asarray(values_s) * 1e3
    return {
        "mean": float(ms.mean()),
        "median": float(np.median(ms)),
        "p99": float(np.percentile(ms, 99)),
        "max": float(ms.max()),
    }


__all__ = ["USELESS_STEP_M", "Snapshot", "StepCounts", "StepRecord", "records_summary", "summary_stats"]
