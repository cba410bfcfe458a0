"""The plan of the paper's evaluation: its sections (one experiment folder each), their trials at full scale,
and the same batches scaled down.

Each `Section` is one `contactnet.jobs.experiment` batch run into ``DIR/<folder>``. At scale 1 its cells (gait x
planner x removed squares x noise, or gait x push magnitude) get ``per_cell`` trials each, the paper's counts
where it gives them (a slow planner may get fewer: ``fewer``); ``scale`` keeps ``share(per_cell, scale)`` of them
(at least 1). Trial i of a cell has seed i (push: the i-th sampled push, ``contactnet.jobs.pushes``), so a scaled plan
is a prefix of the full one: a full run after a scaled one reuses its trials.

Beyond the paper, `FRONTIER_SECTIONS` (``contactnet experiment frontier``, and the last sections of the paper's
plan): the random field from 110 to 200 squares removed, where the paper's benchmark stops telling planners apart
(issue 32), and ``narrow_map`` extended to bars of 2 cm and last gaps of 30 cm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from contactnet.jobs.experiment import DEFAULT_HEIGHT_M, Trial, trials_of
from contactnet.registry import DEFAULT_ROBOT

FIG5_REMOVED = (50, 60, 70, 80, 90, 100)
#: The frontier: n = 110, 125, ..., 200 squares removed of 300 (37-67 %).
FRONTIER_REMOVED = tuple(range(110, 201, 15))
FRONTIER_SEEDS = 100  # per point at full scale (`contactnet experiment frontier --trials N`: N of them)
ORACLE_SEEDS = 20  # the oracle's per point (the cost evaluated online: hundreds of times slower a plan than ContactNet)
#: ``narrow_map`` extended: the README's 3-7 cm bars x 12-24 cm last gaps, and 2 cm bars and 27-30 cm gaps.
FRONTIER_WIDTHS_CM = (2.0, 3.0, 4.0, 5.0, 6.0, 7.0)
FRONTIER_GAPS_CM = (12.0, 15.0, 18.0, 21.0, 24.0, 27.0, 30.0)


@dataclass(frozen=True)
class Section:
    """One sub-experiment: ``experiment`` (a `contactnet.jobs.experiment` name) run into ``DIR/<folder>`` with these
    gaits, planners, removed squares, joint-velocity noise variances and push forces (``narrow_map``: bar widths
    and last gaps, default its own grid), ``per_cell`` trials per cell at scale 1 (seeds; push: sampled pushes),
    except the planners named in ``fewer`` (planner, trials per cell at scale 1)."""

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
    widths_cm: tuple[float, ...] | None = None
    gaps_cm: tuple[float, ...] | None = None
    fewer: tuple[tuple[str, int], ...] = ()

    def per_planner(self, scale: float = 1.0) -> dict[str, int]:
        """Trials per cell of each planner at ``scale``."""
        fewer = dict(self.fewer)
        return {p: share(fewer.get(p, self.per_cell), scale) for p in self.planners}

    def trials(self, scale: float = 1.0, model_dir: str | None = None, sim: str = "pybullet",
               robot: str = DEFAULT_ROBOT) -> list[Trial]:
        """The section's trials at ``scale`` (with the models of ``model_dir``, default the shipped ones) in the
        physics engine ``sim`` with ``robot``: its scenes at the robot's size (``registry.terrain_for``), its pushes
        and payloads the same fraction of its weight as Solo12's (`RobotSizing`)."""
        sizing = RobotSizing.of(robot)
        groups: dict[int, list[str]] = {}  # planners by trials per cell (one group unless some have fewer)
        for planner, n in self.per_planner(scale).items():
            groups.setdefault(n, []).append(planner)
        out: list[Trial] = []
        for noise in self.noises:
            for n, planners in groups.items():
                out += trials_of(self.experiment, n, self.gaits, tuple(planners), self.removed, noise,
                                 model_dir=model_dir, widths_cm=self.widths_cm, gaps_cm=self.gaps_cm,
                                 height_m=self.height_m, forces_n=sizing.forces(self.forces_n), sims=(sim,),
                                 robot=robot)
        return [sizing.sized_payload(t) for t in out]


@dataclass(frozen=True)
class RobotSizing:
    """How the plan's absolute numbers follow a robot other than Solo12 (the paper's): a push or a payload is
    the same fraction of the robot's weight (``weight_ratio``: its weight over
    `contactnet.robots.description.REFERENCE_WEIGHT_N`), a payload's offset from the base the same fraction of
    its size (``size_scale``); the scenes follow the robot's size in `contactnet.registry.terrain_for`. Solo12:
    both 1, the plan unchanged."""

    robot: str = DEFAULT_ROBOT
    weight_ratio: float = 1.0
    size_scale: float = 1.0

    @classmethod
    def of(cls, robot: str) -> RobotSizing:
        if robot == DEFAULT_ROBOT:
            return cls()
        from contactnet.registry import load_robot
        from contactnet.robots.description import REFERENCE_WEIGHT_N

        description = load_robot(robot).description
        return cls(robot, round(description.weight_n / REFERENCE_WEIGHT_N, 3), float(description.size_scale))

    def forces(self, forces_n: tuple[float, ...]) -> tuple[float, ...]:
        """Solo12's push forces (N) as this robot's (rounded to 0.1 N)."""
        return tuple(round(f * self.weight_ratio, 1) for f in forces_n)

    def sized_payload(self, trial: Trial) -> Trial:
        """``trial`` with its mismatch's payload (kg, offset m) sized for this robot."""
        m = trial.mismatch
        if self.weight_ratio == 1.0 and self.size_scale == 1.0 or m is None or not m.payload_kg:
            return trial
        offset = tuple(round(v * self.size_scale, 4) for v in m.payload_offset_xy_m)
        return replace(trial, mismatch=replace(m, payload_kg=round(m.payload_kg * self.weight_ratio, 3),
                                               payload_offset_xy_m=offset))


#: The paper's Sec. IV (and our terrains with heights and model mismatch), in the order of the report.
SEC4_SECTIONS = (
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

#: Beyond the paper: where its benchmark stops telling planners apart (``contactnet experiment frontier``).
FRONTIER_SECTIONS = (
    Section("frontier", "random", "Beyond the paper: the random field from 110 to 200 squares removed",
            FRONTIER_SEEDS, ("walk", "trot"), ("contactnet", "fixed", "heuristic", "oracle"),
            removed=FRONTIER_REMOVED, fewer=(("oracle", ORACLE_SEEDS),)),
    Section("frontier_narrow", "narrow_map", "Beyond the paper: narrow bars 2-7 cm wide x last gaps 12-30 cm, "
            "noise 0.01", 4, ("walk",), ("contactnet", "fixed"), noises=(0.01,), widths_cm=FRONTIER_WIDTHS_CM,
            gaps_cm=FRONTIER_GAPS_CM),
)
#: The whole plan of ``contactnet experiment paper``: the paper's Sec. IV, then the frontier.
PAPER_SECTIONS = SEC4_SECTIONS + FRONTIER_SECTIONS


def frontier_sections(gaits: tuple[str, ...] | None = None, planners: tuple[str, ...] | None = None,
                      removed: tuple[int, ...] | None = None, widths_cm: tuple[float, ...] | None = None,
                      gaps_cm: tuple[float, ...] | None = None) -> tuple[Section, ...]:
    """`FRONTIER_SECTIONS` with the gaits, planners (each section), squares removed (the field) or bar widths and
    last gaps (the narrow bars) given instead of the plan's; a planner of ``fewer`` keeps its fewer trials."""
    field, narrow = FRONTIER_SECTIONS
    both = {k: v for k, v in (("gaits", gaits), ("planners", planners)) if v}
    field = replace(field, **both, **({"removed": tuple(removed)} if removed else {}))
    narrow = replace(narrow, **both, **({"widths_cm": tuple(widths_cm)} if widths_cm else {}),
                     **({"gaps_cm": tuple(gaps_cm)} if gaps_cm else {}))
    return field, narrow


def share(per_cell: int, scale: float) -> int:
    """How many of a cell's ``per_cell`` trials run at ``scale`` (> 0; above 1: more than the plan's):
    rounded half up, at least 1."""
    if not 0.0 < scale < math.inf:
        raise ValueError(f"scale must be a positive number, got {scale}")
    return max(1, math.floor(per_cell * scale + 0.5))


def scaled(per_cell: int, scale: float) -> int:
    """`share` with ``scale`` in (0, 1]: the paper's ``--scale``."""
    if not 0.0 < scale <= 1.0:
        raise ValueError(f"scale must be in (0, 1], got {scale}")
    return share(per_cell, scale)


def plan_trials(sections: tuple[Section, ...] = PAPER_SECTIONS, scale: float = 1.0,
                model_dir: str | None = None, sim: str = "pybullet",
                robot: str = DEFAULT_ROBOT) -> dict[str, list[Trial]]:
    """Every section's trials at ``scale`` in the engine ``sim`` with ``robot``, by folder."""
    folders = [s.folder for s in sections]
    if len(set(folders)) != len(folders):
        raise ValueError("two sections have the same folder")
    share(1, scale)  # a bad scale is an error even without sections
    return {s.folder: s.trials(scale, model_dir, sim, robot) for s in sections}
