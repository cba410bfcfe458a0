"""Pushes sampled, not chosen: the push experiment's protocol, its summary and its polar plot.

Each trial pushes the base of a robot walking on ``push_field`` once. The push's start time is uniform over the
walk (after ``EARLIEST_S`` and early enough that the trial, ``SETTLE_S`` past the push's end, ends before the
robot would reach the goal at the commanded speed), its direction uniform on the circle (world frame,
horizontal), and its size one of:

- a sustained force of F newtons for ``FORCE_DURATION_S`` (``--force``), or
- an impulse of J newton-seconds over ``IMPULSE_DURATION_S`` (``--impulse``: a force of J / 0.1 s).

Sample k (a start time and a direction, drawn from the push seed, which is separate from the terrain's and the
noise's seeds) is the same for every gait and magnitude: the cells are paired, so a difference between them is
not a difference of luck in the moments drawn. Success is no fall by ``SETTLE_S`` after the push ends.

The summary gives, per gait, planner and magnitude, the successes with their 95 % Wilson interval, the push as
force (N), impulse (N s) and the velocity change it would give the free body (impulse / the robot's mass), and
the falls counted by reason; the polar plot gives success by direction (8 sectors) for each magnitude.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from contactnet.sim.world import IMPULSE_DURATION_S, Push

EARLIEST_S = 2.0
FORCE_DURATION_S = 1.0
SETTLE_S = 4.0
PUSH_FIELD_LENGTH_M = 3.0  # push_field: from the start (x = 0) to the goal (x = 3 m)
SECTORS = 8  # the polar plot's directions


@dataclass(frozen=True)
class PushSizes:
    """The magnitudes of a push experiment: sustained forces (N, for ``FORCE_DURATION_S``) and impulses (N s,
    over ``IMPULSE_DURATION_S``); and the seed of the push moments and directions."""

    forces_n: tuple[float, ...] = (5.0,)
    impulses_ns: tuple[float, ...] = ()
    seed: int = 0

    def __post_init__(self) -> None:
        if not self.forces_n and not self.impulses_ns:
            raise ValueError("a push experiment needs at least one force or impulse")
        for name, values, high in (("force", self.forces_n, 100.0), ("impulse", self.impulses_ns, 10.0)):
            if any(not (isinstance(v, int | float) and math.isfinite(v) and 0 < v <= high) for v in values):
                raise ValueError(f"push {name}s must be in (0, {high:g}], got {values!r}")
        if not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"the push seed must be a non-negative whole number, got {self.seed!r}")

    def pushes(self) -> list[tuple[float, float]]:
        """(force in N, duration in s) of each magnitude: the forces, then the impulses."""
        return ([(float(f), FORCE_DURATION_S) for f in self.forces_n]
                + [(float(j) / IMPULSE_DURATION_S, IMPULSE_DURATION_S) for j in self.impulses_ns])


def push_window_s(vx_m_s: float, length_m: float = PUSH_FIELD_LENGTH_M) -> tuple[float, float]:
    """The start times (s) a push is drawn from: after ``EARLIEST_S``, and so that the trial (the push and
    ``SETTLE_S`` after it) ends before the time the robot needs to reach the goal at ``vx_m_s`` (at least 10 s
    wide)."""
    walk_s = length_m / max(abs(vx_m_s), 1e-3)
    return EARLIEST_S, max(EARLIEST_S + 10.0, walk_s - FORCE_DURATION_S - SETTLE_S)


def sample_moments(n: int, seed: int, window_s: tuple[float, float]) -> list[tuple[float, float]]:
    """``n`` push samples (start time in s to the millisecond, direction in rad in [0, 2 pi)): the first ``m``
    of them are the same for every ``n >= m`` (a smaller run is a prefix of a larger one)."""
    rng = np.random.default_rng([seed, 27])
    draws = rng.random((n, 2))
    low, high = window_s
    return [(round(low + (high - low) * u, 3), 2 * math.pi * v) for u, v in draws]


def force_xy(force_n: float, angle_rad: float) -> tuple[float, float]:
    """The push's world-frame force (N), to 0.1 mN (clean numbers in keys and records)."""
    return Push.at_angle(0.0, angle_rad, force_n, FORCE_DURATION_S).force_world[:2]


def push_facts(record: dict) -> dict:
    """A push trial's push as force (N), duration (s), impulse (N s), the velocity change it would give the
    free body (m/s: impulse / the robot's mass, when the record has it) and its direction (deg, [0, 360))."""
    t = record["trial"]
    fx, fy = t["push_force_xy"]
    force = math.hypot(fx, fy)
    duration = float(t.get("push_duration_s") or FORCE_DURATION_S)
    mass = record.get("robot_mass_kg")
    return {"push_n": round(force, 3), "push_duration_s": duration, "push_ns": round(force * duration, 4),
            "push_dv_m_s": None if not mass else round(force * duration / mass, 4),
            "push_deg": math.degrees(math.atan2(fy, fx)) % 360.0}


def push_columns(records: list[dict]) -> dict:
    """The summary row's push columns for the records of one cell (one magnitude): its kind, impulse and the
    free body's velocity change (the success interval and the falls are every row's)."""
    facts = push_facts(records[0])
    return {"push_kind": "impulse" if facts["push_duration_s"] < FORCE_DURATION_S else "force",
            "push_ns": facts["push_ns"], "push_dv_m_s": facts["push_dv_m_s"]}


def by_sector(records: list[dict], sectors: int = SECTORS) -> list[tuple[int, int]]:
    """(successes, trials) per direction sector, sector 0 centred on +x, counter-clockwise."""
    out = [[0, 0] for _ in range(sectors)]
    for r in records:
        deg = push_facts(r)["push_deg"]
        k = int(((deg + 180.0 / sectors) % 360.0) // (360.0 / sectors))
        out[k][0] += bool(r["success"])
        out[k][1] += 1
    return [(s, n) for s, n in out]


def plot_polar(records: list[dict], path) -> None:  # noqa: ANN001 - a path-like
    """Success by push direction: one polar panel per gait (and planner), one line per magnitude (the sectors'
    success rates, with every failed push as a cross at its direction, outside the 100 % ring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells: dict[tuple, dict[tuple, list[dict]]] = {}
    for r in records:
        t = r["trial"]
        facts = push_facts(r)
        panel = (t["gait"], t["planner"]) + ((r.get("mismatch_label") or "",) if r.get("mismatch_label") else ())
        cells.setdefault(panel, {}).setdefault((facts["push_duration_s"], facts["push_n"]), []).append(r)
    panels = sorted(cells)
    fig, axes = plt.subplots(1, max(1, len(panels)), subplot_kw={"projection": "polar"},
                             figsize=(4.2 * max(1, len(panels)), 4.8), squeeze=False)
    width = 2 * math.pi / SECTORS
    centres = np.arange(SECTORS + 1) * width
    for ax, panel in zip(axes[0], panels, strict=False):
        for (duration, force), rs in sorted(cells[panel].items()):
            counts = by_sector(rs)
            rate = [100.0 * s / n if n else np.nan for s, n in counts]
            label = (f"{force:g} N x {duration:g} s" if duration >= FORCE_DURATION_S
                     else f"{force * duration:g} N s ({push_facts(rs[0])['push_dv_m_s'] or 0:g} m/s)")
            label += f": {sum(s for s, _ in counts)}/{len(rs)}"
            line, = ax.plot(centres, [*rate, rate[0]], marker="o", label=label)
            failed = [math.radians(push_facts(r)["push_deg"]) for r in rs if not r["success"]]
            ax.plot(failed, [110.0] * len(failed), "x", color=line.get_color(), markersize=7)
        ax.set_ylim(0, 115)
        ax.set_yticks([25, 50, 75, 100], ["25", "50", "75", "100 %"], fontsize=7)
        ax.set_title(", ".join(panel), fontsize=10)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), fontsize=7)
    fig.suptitle("success by push direction\n(x: a failed push; 0 deg = +x, the walking direction)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
