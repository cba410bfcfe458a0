"""The report's section beyond the paper: the frontier (``contactnet experiment frontier``, the last section of
``contactnet experiment paper``; the plan: `contactnet.jobs.paper.plan.FRONTIER_SECTIONS`).

The random field from 110 to 200 squares removed, one success curve per planner with 95 % Wilson intervals, the
difference between ContactNet and the fixed gait with its interval (Newcombe's, `contactnet.jobs.paper.stats`) and
the terrains only one of them crossed, issue 32's targets, the failures by reason and the planner's times per n;
then ``narrow_map`` down to 2 cm bars and up to 30 cm gaps. Like the rest of the report, made from the stored trials.
"""

from __future__ import annotations

import numpy as np

from contactnet.jobs.outcome import falls_text
from contactnet.jobs.paper import plots
from contactnet.jobs.paper.markdown import Report, ms, table
from contactnet.jobs.paper.plan import FRONTIER_SEEDS, ORACLE_SEEDS
from contactnet.jobs.paper.results import SectionResult, group, rate_of, samples
from contactnet.jobs.paper.stats import difference_interval


def frontier_section(r: Report) -> None:
    r.add("## Beyond the paper: the frontier", "",
          "The paper's random field stops at n = 100 squares removed (Table II: 110), where the planners here cross "
          "nearly every time: a benchmark every planner passes no longer tells them apart. This section goes on: "
          "the same 1.5 x 0.5 m field of 300 squares of 5 x 5 cm with n = 110, 125, ..., 200 removed (37-67 % of "
          "the squares; seed i = terrain i, the same terrains for every planner), walk and trot at vx = 0.05 m/s, no "
          "noise, with ContactNet, the fixed gait (the same network held to a fixed leg order), the blind heuristic "
          "and the oracle. The oracle evaluates the ranking cost V of every action online and takes the cheapest safe "
          "one for each of the plan's three steps in turn: greedy on the cost, it is **no upper bound** on what a "
          "planner can do (a step cheap now may leave no ground for the next), and it is hundreds of times slower a "
          f"plan (the times below), so it runs on fewer seeds: {ORACLE_SEEDS} per point against {FRONTIER_SEEDS} "
          "at full scale.", "",
          "Command: `contactnet experiment frontier --out DIR` (this section alone; `--trials N`: N seeds per point, "
          "the oracle and the narrow bars in proportion; `--scale S`), or `contactnet experiment paper --out DIR` "
          "(the paper's evaluation and this).", "")
    field = r.section("frontier")
    if not field:
        r.missing("frontier")
    else:
        _frontier_field(r, field)
    _frontier_narrow(r)


def _frontier_field(r: Report, field: SectionResult) -> None:
    r.figure("frontier", "Beyond the paper: success vs squares removed, per planner",
             lambda p: plots.plot_frontier(field, p))
    cells = group(field.records, lambda t: (t["gait"], t["removed"], t["planner"]))
    planners = list(dict.fromkeys(p for _, _, p in cells))
    pair = {"contactnet", "fixed"} <= set(planners)
    rows = []
    for gait, n in dict.fromkeys((g, n) for g, n, _ in cells):
        row = [gait, n] + [rate_of(cells.get((gait, n, p), [])).text() for p in planners]
        if pair:
            a, b = rate_of(cells.get((gait, n, "contactnet"), [])), rate_of(cells.get((gait, n, "fixed"), []))
            low, high = difference_interval(a.successes, a.trials, b.successes, b.trials)
            crossed = {p: {x["trial"]["seed"]: bool(x["success"]) for x in cells.get((gait, n, p), [])}
                       for p in ("contactnet", "fixed")}
            both = set(crossed["contactnet"]) & set(crossed["fixed"])
            only = [sum(crossed[p][s] and not crossed[q][s] for s in both)
                    for p, q in (("contactnet", "fixed"), ("fixed", "contactnet"))]
            row += ["-" if not (a.trials and b.trials) else
                    f"{100 * (a.rate - b.rate):+.1f} ({100 * low:+.1f} to {100 * high:+.1f})", f"{only[0]} / {only[1]}"]
        rows.append(row)
    extra = ["ContactNet - fixed, points (95 %)", "same terrains: only ContactNet / only fixed"] if pair else []
    r.add(*table(["gait", "n removed", *planners, *extra], rows))
    if pair:
        r.add("The difference's interval is Newcombe's hybrid score interval from the two Wilson intervals; it treats "
              "the two planners' trials as independent, while they ran on the same terrains (seed by seed), so it is "
              "conservative: the last column counts the terrains only one of the two crossed.", "")
    _frontier_targets(r, cells)
    r.add("Outcomes and planner times over all n (a plan: 3 steps; the trial's wall time in its worker):", "")
    rows = []
    for (gait, planner), rs in group(field.records, lambda t: (t["gait"], t["planner"])).items():
        calls = samples(rs, "planner")
        rows.append([gait, planner, rate_of(rs).text(), falls_text(rs),
                     *(ms(float(np.percentile(calls, q))) if calls.size else "-" for q in (50, 99)),
                     f"{np.mean([x.get('trial_wall_s', np.nan) for x in rs]):.1f}"])
    r.add(*table(["gait", "planner", "crossed, all n", "failures by reason", "planner ms median", "p99",
                  "mean trial s"], rows))
    by_n = group(field.records, lambda t: (t["removed"], t["gait"], t["planner"]))
    columns = list(dict.fromkeys((g, p) for _, g, p in by_n))
    rows = []
    for n in dict.fromkeys(n for n, _, _ in by_n):
        medians = [samples(by_n.get((n, g, p), []), "planner") for g, p in columns]
        rows.append([n, *(ms(float(np.median(m))) if m.size else "-" for m in medians)])
    r.add("Planner median ms per plan by n (a plan's time should not grow with the holes):", "",
          *table(["n removed", *(f"{g}, {p}" for g, p in columns)], rows))


def _frontier_targets(r: Report, cells: dict[tuple, list[dict]]) -> None:
    """Issue 32's targets, judged on the stored trials (in parentheses on a scaled run)."""
    rows = []
    for gait in ("walk", "trot"):
        for n, goal, target in ((170, 0.95, ">= 95 %"), (200, 0.90, ">= 90 % (goal)")):
            rate = rate_of(cells.get((gait, n, "contactnet"), []))
            if rate.trials:
                rows.append([f"ContactNet, {gait}, n = {n}", rate.text(), target, r.met(rate.rate >= goal)])
        pairs = [(n, rate_of(rs), rate_of(cells.get((g, n, "fixed"), []))) for (g, n, p), rs in cells.items()
                 if g == gait and p == "contactnet" and cells.get((g, n, "fixed"))]
        if pairs:
            behind = [n for n, a, b in pairs if a.rate < b.rate]
            rows.append([f"ContactNet >= fixed gait, {gait}, every n",
                         "behind at n = " + ", ".join(map(str, behind)) if behind else f"at all {len(pairs)} n",
                         "at every n", r.met(not behind)])
    if rows:
        r.add(*table(["target (issue 32)", "ours", "target", "met"], rows))


def _in_readme_grid(trial: dict) -> bool:
    """A narrow_map cell of the README's grid (bars 3-7 cm x last gaps 12-24 cm)."""
    from contactnet.jobs.experiment import NARROW_MAP_GAPS_CM, NARROW_MAP_WIDTHS_CM

    return (round(100 * trial["bar_width_m"], 6) in NARROW_MAP_WIDTHS_CM
            and round(100 * trial["last_gap_m"], 6) in NARROW_MAP_GAPS_CM)


def _frontier_narrow(r: Report) -> None:
    r.add("### Narrow bars: `narrow_map` down to 2 cm bars and up to 30 cm gaps", "",
          "The narrow-stones scene (the paper's Fig. 6) with all three bars w wide and the gap before the last bar g "
          "long, over w = 2-7 cm and g = 12-30 cm (the README's map: 3-7 cm x 12-24 cm), joint-velocity noise "
          "variance 0.01, 4 seeds per cell at full scale; a bar narrower than the 5 cm candidate spacing plus twice "
          "the 8 mm edge margin may hold no candidate of the leg whose turn it is.", "")
    narrow = r.section("frontier_narrow")
    if not narrow:
        return r.missing("frontier_narrow")
    r.figure("frontier_narrow", "narrow bars: crossings per cell, per planner",
             lambda p: plots.plot_narrow_map(narrow, p))
    rows = []
    for (gait, planner), rs in group(narrow.records, lambda t: (t["gait"], t["planner"])).items():
        parts = ([x for x in rs if _in_readme_grid(x["trial"])],
                 [x for x in rs if x["trial"]["bar_width_m"] < 0.025],
                 [x for x in rs if x["trial"]["last_gap_m"] > 0.245])
        rows.append([gait, planner, rate_of(rs).text(), *(rate_of(part).text() for part in parts), falls_text(rs)])
    r.add(*table(["gait", "planner", "every cell", "the README's 3-7 cm x 12-24 cm (target >= 95 %)",
                  "2 cm bars", "gaps of 27-30 cm", "failures by reason"], rows))
