"""The plan of the paper's evaluation: its sections (one experiment folder each), their trials at full scale,
and the same batches scaled down.

Each `Section` is one `contactnet.jobs.experiment` batch run into ``DIR/<folder>``. At scale 1 its cells (gait x
planner x removed squares x noise, or gait x push magnitude) get ``per_cell`` trials each, the paper's counts
where it gives them; ``scale`` keeps ``scaled(per_cell, scale)`` of them (at least 1). Trial i of a cell has
seed i (push: the i-th sampled push, ``contactnet.jobs.pushes``), so a scaled plan is a prefix of the full one: a
full run after a scaled one reuses its trials.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from contactnet.jobs.experiment import DEFAULT_HEIGHT_M, Trial, trials_of

FIG5_REMOVED = (50, 60, 70, 80, 90, 100)


@dataclass(frozen=True)
class Section:
    """One sub-experiment: ``experiment`` (a `contactnet.jobs.experiment` name) run into ``DIR/<folder>`` with these
    gaits, planners, removed squares, joint-velocity noise variances and push forces, ``per_cell`` trials per
    cell at scale 1 (seeds; push: sampled pushes)."""

    folder: str
    experiment: str
    title: str
    per_cell: int
    gaits: tuple[str, ...]
    planners: tuple[str, ...]
    removed: tuple[int, ...] = (80,)
    noises: tuple[float, ...] = (0.0,)
    forces_n: tuple[float, ...] = (5.0,)
    height_m: float = DEFAULT_HEIGHT_M

    def trials(self, scale: float = 1.0, model_dir: str | None = None, sim: str = "pybullet") -> list[Trial]:
        """The section's trials at ``scale`` (with the models of ``model_dir``, default the shipped ones) in the
        physics engine ``sim``."""
        n = scaled(self.per_cell, scale)
        out: list[Trial] = []
        for noise in self.noises:
            out += trials_of(self.experiment, n, self.gaits, self.planners, self.removed, noise,
                             model_dir=model_dir, height_m=self.height_m, forces_n=self.forces_n, sims=(sim,))
        return out


#: The paper's Sec. IV (and our terrains with heights), in the order of the report.
PAPER_SECTIONS = (
    Section("fig5", "random", "Fig. 5: random field, success vs squares removed", 100, ("walk", "trot"),
            ("contactnet",), removed=FIG5_REMOVED, noises=(0.0, 0.01)),
    Section("table2", "random", "Table II: acyclic vs fixed gait, 110 squares removed", 300, ("walk",),
            ("contactnet", "fixed"), removed=(110,)),
    Section("push", "push", "Push recovery: 5 N for 1 s at random moments and directions", 200, ("walk", "trot"),
            ("contactnet",)),
    Section("stepping_stones", "stepping_stones", "Stepping stones (Fig. 2, 4)", 1, ("walk",),
            ("contactnet", "fixed")),
    Section("narrow_stones", "narrow_stones", "Narrow stones (Fig. 6)", 1, ("walk",), ("contactnet", "fixed")),
    Section("stairs", "stairs", "Stairs: 3 steps up and 3 down, 5 cm risers", 1, ("walk", "trot"),
            ("contactnet", "fixed")),
    Section("raised_stones", "raised_stones", "Raised stones: tops within +-6 cm", 5, ("walk", "trot"),
            ("contactnet", "fixed")),
    Section("random_heights", "random_heights", "Random field with heights: tops within +-3 cm, 80 removed", 20,
            ("walk", "trot"), ("contactnet", "fixed")),
    Section("robustness", "robustness", "Model mismatch: each alone, on the random field (80 removed) and the stones",
            100, ("walk", "trot"), ("contactnet",)),
)


def scaled(per_cell: int, scale: float) -> int:
    """How many of a cell's ``per_cell`` trials run at ``scale``: rounded half up, at least 1."""
    if not 0.0 < scale <= 1.0:
        raise ValueError(f"scale must be in (0, 1], got {scale}")
    return max(1, math.floor(per_cell * scale + 0.5))


def plan_trials(sections: tuple[Section, ...] = PAPER_SECTIONS, scale: float = 1.0,
                model_dir: str | None = None, sim: str = "pybullet") -> dict[str, list[Trial]]:
    """Every section's trials at ``scale`` in the engine ``sim``, by folder."""
    folders = [s.folder for s in sections]
    if len(set(folders)) != len(folders):
        raise ValueError("two sections have the same folder")
    return {s.folder: s.trials(scale, model_dir, sim) for s in sections}
