"""An experiment's summary: success per cell (gait, planner, scene, push, model mismatch, observer) with its 95 %
Wilson interval and the falls by reason, the success plot, and the table printed on stdout."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def _mismatch_label(record: dict) -> str:
    """The record's model mismatch, short ('' for the model itself)."""
    label = record.get("mismatch_label")
    if label is not None:
        return label
    from contactnet.sim.mismatch import ModelMismatch

    return ModelMismatch.from_dict(record["trial"].get("mismatch")).label()


def summarize(name: str, records: list[dict], wall_s: float = 0.0) -> dict:
    """Success rate (with its 95 % Wilson interval), the falls by reason and the planner's facts per cell: gait,
    planner, terrain, removed, noise, bar width, last gap, height, push (force and duration), observer and model
    mismatch."""
    from contactnet.jobs.outcome import falls_by_reason
    from contactnet.jobs.paper.stats import wilson_interval
    from contactnet.jobs.pushes import push_columns

    groups: dict[tuple, list[dict]] = {}
    for r in records:
        t = r["trial"]
        force = t.get("push_force_xy")
        duration = None if force is None else float(t.get("push_duration_s") or 1.0)
        group = (t["gait"], t["planner"], t.get("terrain"), t["removed"], t["noise"], t.get("bar_width_m"),
                 t.get("last_gap_m"), t.get("height_m"), None if force is None else round(math.hypot(*force), 3),
                 duration, t.get("observer", False), _mismatch_label(r), t.get("sim", "pybullet"))
        groups.setdefault(group, []).append(r)
    rows = []
    for (gait, planner, terrain, removed, noise, width_m, gap_m, height_m, push_n, duration, observer, mismatch, sim), rs in \
            sorted(groups.items(), key=lambda kv: tuple(map(str, kv[0]))):
        ranks = [r["rank_chosen"]["mean"] for r in rs if r["steps"]]
        successes = sum(bool(r["success"]) for r in rs)
        low, high = wilson_interval(successes, len(rs))
        rows.append({
            "gait": gait, "planner": planner, "terrain": terrain, "removed": removed, "noise": noise,
            "bar_width_m": width_m, "last_gap_m": gap_m, "height_m": height_m, "push_n": push_n, "trials": len(rs),
            "successes": successes,
            "success_rate": successes / len(rs),
            "success_low": round(low, 4), "success_high": round(high, 4),
            "falls": sum(r["fell"] for r in rs),
            "fall_reasons": falls_by_reason(rs),
            "mean_reached_x": float(np.mean([r["reached_x"] for r in rs])),
            "planner_ms_median": float(np.median([r["planner_ms"]["median"] for r in rs])),
            "planner_ms_mean": float(np.mean([r["planner_ms"]["mean"] for r in rs])),
            "rank_chosen_mean": float(np.mean(ranks)) if ranks else 0.0,
            "rank_chosen_max": max((r["rank_chosen"]["max"] for r in rs), default=0),
            "unsafe_landings": sum(r["unsafe_landings"] for r in rs),
            "max_height_change_m": max((r.get("max_height_change_m", 0.0) for r in rs), default=0.0),
            "failed_seeds": [r["trial"]["seed"] for r in rs if not r["success"]],
            **({"failed_pushes": [r["key"].split("/")[1] for r in rs if not r["success"]], "push_duration_s": duration,
                **push_columns(rs)} if push_n is not None else {}),
            "observer": bool(observer),
            **({"mismatch": mismatch} if mismatch else {}),
            "sim": sim,
        })
    return {"experiment": name, "rows": rows, "wall_time_s": wall_s}


def plot_success(summary: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = summary["rows"]
    if any(r.get("bar_width_m") is not None for r in rows):
        _plot_success_maps(rows, summary["experiment"], path, plt)
        return
    labels = [f"{r['gait']}\n{r['planner']}" + (f"\n{r['removed']} removed" if r["removed"] is not None else "")
              + (f"\n{r['terrain']}" if len({x.get('terrain') for x in rows}) > 1 else "")
              + (f"\npush {r['push_n']:g} N" if r.get("push_n") is not None else "")
              + (f" x {r['push_duration_s']:g} s" if r.get("push_duration_s") not in (None, 1.0) else "")
              + (f"\n{r['mismatch']}" if r.get("mismatch") else "")
              + (f"\n{r['sim']}" if r.get("sim", "pybullet") != "pybullet" else "")
              + ("" if r.get("observer", True) else "\nno observer") for r in rows]
    fig, ax = plt.subplots(figsize=(max(4.0, 1.2 * len(rows)), 3.6))
    bars = ax.bar(range(len(rows)), [100 * r["success_rate"] for r in rows], color="#3b7dd8")
    for bar, r in zip(bars, rows, strict=True):
        ax.text(bar.get_x() + bar.get_width() / 2, bar.get_height() + 1, f"{r['successes']}/{r['trials']}",
                ha="center", fontsize=8)
    ax.set_xticks(range(len(rows)), labels, fontsize=8)
    ax.set_ylim(0, 110)
    ax.set_ylabel("success %")
    ax.set_title(f"experiment {summary['experiment']}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_success_maps(rows: list[dict], experiment: str, path: Path, plt) -> None:  # noqa: ANN001
    """One bar width x last gap success map per (gait, planner), cells labelled successes/trials."""
    panels = sorted({(r["gait"], r["planner"]) for r in rows})
    widths_m = sorted({r["bar_width_m"] for r in rows})
    gaps_m = sorted({r["last_gap_m"] for r in rows})
    fig, axes = plt.subplots(1, len(panels), figsize=(0.9 * len(gaps_m) * len(panels) + 1.5, 0.7 * len(widths_m) + 1.4),
                             squeeze=False)
    for ax, (gait, planner) in zip(axes[0], panels, strict=True):
        rate = np.full((len(widths_m), len(gaps_m)), np.nan)
        for r in rows:
            if (r["gait"], r["planner"]) == (gait, planner):
                i, j = widths_m.index(r["bar_width_m"]), gaps_m.index(r["last_gap_m"])
                rate[i, j] = r["success_rate"]
                ax.text(j, i, f"{r['successes']}/{r['trials']}", ha="center", va="center", fontsize=8)
        ax.imshow(rate, vmin=0.0, vmax=1.0, cmap="RdYlGn", origin="lower", aspect="auto")
        ax.set_xticks(range(len(gaps_m)), [f"{100 * g:g}" for g in gaps_m])
        ax.set_yticks(range(len(widths_m)), [f"{100 * w:g}" for w in widths_m])
        ax.set_xlabel("gap before the last bar (cm)")
        ax.set_ylabel("bar width (cm)")
        ax.set_title(f"{gait}, {planner}")
    fig.suptitle(f"experiment {experiment}: crossings / trials", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def format_summary(summary: dict) -> str:
    from contactnet.bench import format_table

    rows = summary["rows"]
    scene = ("bar_width_m", "last_gap_m") if any(r.get("bar_width_m") is not None for r in rows) else ("removed",)
    scene += ("height_m",) if any(r.get("height_m") is not None for r in rows) else ()
    scene = (("terrain",) if len({r.get("terrain") for r in rows}) > 1 else ()) + scene
    scene += ("push_n", "push_duration_s", "push_ns", "push_dv_m_s") if any(
        r.get("push_n") is not None for r in rows) else ()
    scene += ("mismatch",) if any(r.get("mismatch") for r in rows) else ()
    scene += ("sim",) if any(r.get("sim", "pybullet") != "pybullet" for r in rows) else ()
    keep = ("gait", "planner", *scene, "noise", "successes", "trials", "success_rate", "success_low", "falls",
            "planner_ms_median", "rank_chosen_mean", "rank_chosen_max", "unsafe_landings")
    keep += ("max_height_change_m",) if any(r.get("max_height_change_m") for r in rows) else ()
    keep += ("observer",) if not all(r.get("observer", True) for r in rows) else ()  # shown when one is off
    return format_table([{k: r.get(k) for k in keep} for r in rows])
