"""The report's figures (matplotlib, Agg), each written to a PNG file: Fig. 5's success curves with their
95 % Wilson intervals, Table I's planner times, Table II's rates beside the paper's, the distributions
of the planner's and the optimizer's times per call, and beyond the paper the frontier's success curves per
planner and its narrow bars' success maps."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from contactnet.jobs.paper import reference
from contactnet.jobs.paper.results import Rate, SectionResult, group, rate_of, samples

COLORS = {"walk": "#1f6fd1", "trot": "#d1641f"}
PLANNER_STYLES = {"contactnet": ("#1f6fd1", "o"), "fixed": ("#d1641f", "s"), "heuristic": ("#7f7f7f", "v"),
                  "oracle": ("#2a9d4b", "D")}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _plain_log_axis(axis) -> None:  # noqa: ANN001
    """A log axis labelled with plain numbers (0.3, 1, 10), not powers of ten."""
    from matplotlib.ticker import FormatStrFormatter, LogLocator

    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FormatStrFormatter("%g"))
    axis.set_minor_formatter(FormatStrFormatter(""))


def _errors(rates: list[Rate]) -> np.ndarray:
    """Percent below and above each rate to its Wilson interval's ends (matplotlib's yerr)."""
    return np.array([[100 * (r.rate - r.interval[0]) for r in rates], [100 * (r.interval[1] - r.rate) for r in rates]])


def plot_fig5(section: SectionResult, path: Path) -> None:
    """Success (%) vs squares removed, one panel per gait, one curve per noise variance, 95 % Wilson bars."""
    plt = _pyplot()
    cells = group(section.records, lambda t: (t["gait"], t["noise"], t["removed"]))
    gaits = sorted({g for g, _, _ in cells}, key=["walk", "trot"].index)
    noises = sorted({noise for _, noise, _ in cells})
    fig, axes = plt.subplots(1, len(gaits), figsize=(4.2 * len(gaits), 3.6), squeeze=False, sharey=True)
    for ax, gait in zip(axes[0], gaits, strict=True):
        for i, noise in enumerate(noises):
            ns = sorted(n for g, v, n in cells if g == gait and v == noise)
            rates = [rate_of(cells[gait, noise, n]) for n in ns]
            x = np.asarray(ns, dtype=float) + (i - (len(noises) - 1) / 2) * 1.2
            label = "no noise" if noise == 0 else f"noise var {noise:g}"
            ax.errorbar(x, [100 * r.rate for r in rates], yerr=_errors(rates), marker="o" if noise == 0 else "s",
                        capsize=3, color=COLORS.get(gait), alpha=1.0 if noise == 0 else 0.55, label=label)
        ax.set_title(f"{gait}")
        ax.set_xlabel("squares removed n (of 300)")
        ax.set_ylim(0, 104)
        ax.grid(alpha=0.3)
        ax.legend(loc="lower left", fontsize=8)
    axes[0][0].set_ylabel("success %")
    trials = sorted({len(rs) for rs in cells.values()})
    each = f"{trials[0]} trial{'s' if trials[0] > 1 else ''}" if len(trials) == 1 else f"{trials[0]}-{trials[-1]} trials"
    fig.suptitle(f"Fig. 5 (ours): random field, {each} per point, 95 % Wilson intervals", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_table1(rows: list[tuple[int, dict[str, float]]], path: Path) -> None:
    """Mean planner time per attempt (ms) vs n: ours (solid) and the paper's Table I (dashed), per gait."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(5.4, 3.4))
    for gait in ("walk", "trot"):
        ours = [(n, ms[gait]) for n, ms in rows if not np.isnan(ms.get(gait, np.nan))]
        if ours:
            ax.plot(*zip(*ours, strict=True), marker="o", color=COLORS[gait], label=f"{gait}, ours")
        paper = sorted(reference.TABLE1_MS[gait].items())
        ax.plot(*zip(*paper, strict=True), linestyle="--", marker="x", color=COLORS[gait], alpha=0.6,
                label=f"{gait}, paper")
    ax.set_yscale("log")
    _plain_log_axis(ax.yaxis)
    ax.set_xlabel("squares removed n")
    ax.set_ylabel("planner ms (mean per attempt)")
    ax.set_title("Table I: planner time (3 steps) per attempt", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, ncols=2)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_table2(section: SectionResult, path: Path) -> None:
    """Success (%) of the acyclic and the fixed gait at n = 110: ours and the paper's, 95 % Wilson bars."""
    plt = _pyplot()
    ours = {planner: rate_of(rs) for (planner,), rs in group(section.records, lambda t: (t["planner"],)).items()}
    planners = [p for p in ("contactnet", "fixed") if p in ours] + [p for p in ours if p not in ("contactnet", "fixed")]
    fig, ax = plt.subplots(figsize=(5.0, 3.4))
    x = np.arange(len(planners))
    for offset, (label, rates, style) in zip((-0.18, 0.18), (
            ("ours", [ours[p] for p in planners], {"color": "#1f6fd1"}),
            ("paper", [reference.TABLE2.get(p, Rate(0, 0)) for p in planners], {"color": "#bbbbbb", "hatch": "//"})),
            strict=True):
        shown = [r for r in rates if r.trials]
        xs = [xi + offset for xi, r in zip(x, rates, strict=True) if r.trials]
        ax.bar(xs, [100 * r.rate for r in shown], width=0.34, yerr=_errors(shown), capsize=4, label=label, **style)
        for xi, r in zip(xs, shown, strict=True):
            ax.text(xi, 3, f"{r.successes}/{r.trials}", ha="center", fontsize=8,
                    bbox={"facecolor": "white", "edgecolor": "none", "pad": 1.0})
    names = {"contactnet": "optimized acyclic\n(ContactNet)", "fixed": "fixed cyclic"}
    ax.set_xticks(x, [names.get(p, p) for p in planners])
    ax.set_ylim(0, 122)
    ax.set_yticks(range(0, 101, 20))
    ax.set_ylabel("success %")
    ax.set_title("Table II: random field, n = 110, walk (95 % Wilson)", fontsize=10)
    ax.legend(loc="upper center", fontsize=8, ncols=2)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_times(sections: list[SectionResult], path: Path) -> None:
    """Box plots of the planner's and the optimizer's time per call, per section and gait (whiskers at the
    1st and 99th percentiles, log scale)."""
    plt = _pyplot()
    labels, planner, trajopt = [], [], []
    for section in sections:
        for (gait,), records in group(section.records, lambda t: (t["gait"],)).items():
            p, q = samples(records, "planner"), samples(records, "trajopt")
            if p.size and q.size:
                labels.append(f"{section.folder}, {gait}")
                planner.append(p)
                trajopt.append(q)
    fig, axes = plt.subplots(2, 1, figsize=(max(6.0, 0.75 * len(labels) + 1.5), 6.4), sharex=True)
    for ax, data, what in ((axes[0], planner, "planner, ms per plan (3 steps)"),
                           (axes[1], trajopt, "optimizer, ms per solve")):
        if data:
            ax.boxplot(data, whis=(1, 99), showfliers=False, medianprops={"color": "black"})
            ax.set_yscale("log")
            _plain_log_axis(ax.yaxis)
        ax.set_ylabel(what, fontsize=9)
        ax.grid(alpha=0.3, which="both", axis="y")
    axes[1].set_xticks(range(1, len(labels) + 1), labels, fontsize=7, rotation=35, ha="right")
    fig.suptitle("time per call (box: quartiles, whiskers: 1st-99th percentile)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _per_point(counts: set[int]) -> str:
    """"100 per point", "1-3 per point"."""
    low, high = min(counts), max(counts)
    return f"{low} per point" if low == high else f"{low}-{high} per point"


def plot_frontier(section: SectionResult, path: Path) -> None:
    """Beyond the paper: success (%) vs squares removed, one panel per gait, one curve per planner (shifted a
    little along n so that the bars do not hide each other), 95 % Wilson bars; the top axis in % of the field."""
    plt = _pyplot()
    cells = group(section.records, lambda t: (t["gait"], t["planner"], t["removed"]))
    gaits = list(dict.fromkeys(g for g, _, _ in cells))
    planners = list(dict.fromkeys(p for _, p, _ in cells))
    ns = sorted({n for _, _, n in cells})
    step = min(np.diff(ns), default=10)
    fig, axes = plt.subplots(1, len(gaits), figsize=(5.0 * len(gaits), 4.0), squeeze=False, sharey=True)
    for ax, gait in zip(axes[0], gaits, strict=True):
        for i, planner in enumerate(planners):
            xs = sorted(n for g, p, n in cells if (g, p) == (gait, planner))
            if not xs:
                continue
            rates = [rate_of(cells[gait, planner, n]) for n in xs]
            shift = (i - (len(planners) - 1) / 2) * 0.07 * step
            color, marker = PLANNER_STYLES.get(planner, (None, "o"))
            ax.errorbar(np.asarray(xs, dtype=float) + shift, [100 * r.rate for r in rates], yerr=_errors(rates),
                        marker=marker, markersize=4, capsize=3, color=color,
                        label=f"{planner}, {_per_point({r.trials for r in rates})}")
        ax.set_title(gait)
        ax.set_xticks(ns)
        ax.set_xlabel("squares removed n (of 300)")
        top = ax.secondary_xaxis("top", functions=(lambda n: n / 3.0, lambda share: 3.0 * share))
        top.set_xlabel("% of the field removed", fontsize=8)
        top.tick_params(labelsize=8)
        ax.set_ylim(-3, 104)
        ax.grid(alpha=0.3)
        ax.legend(loc="lower left", fontsize=8)
    axes[0][0].set_ylabel("success %")
    fig.suptitle("Beyond the paper: random field, success vs squares removed, 95 % Wilson intervals", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_narrow_map(section: SectionResult, path: Path) -> None:
    """The narrow bars: one bar width x last gap success map per gait and planner (the experiment's own
    ``success.png``, `contactnet.jobs.summary.plot_success`)."""
    from contactnet.jobs.summary import plot_success, summarize

    plot_success(summarize("narrow_map", section.records), path)
