"""The report of a paper run: ``DIR/report.md`` (figures in ``DIR/report_plots/``) and ``DIR/report.html``, one
self-contained page (the figures embedded as base64 PNG, the style inline, no link to anything outside).

Every number comes from the stored trials (`contactnet.jobs.paper.results`): `write_report` runs nothing and can be
called again at any time (``contactnet report DIR``). Each result stands beside the paper's; success rates carry
their 95 % Wilson score interval. A run of ``contactnet experiment frontier`` (``"plan": "frontier"`` in paper.json)
gets the frontier's section alone, with the run, the outcomes and the times.
"""

from __future__ import annotations

import base64
import html as html_lib
import re
from pathlib import Path

import numpy as np

from contactnet.atomic import atomic_write_text
from contactnet.jobs.outcome import falls_text
from contactnet.jobs.paper import plots, reference
from contactnet.jobs.paper.frontier import frontier_section
from contactnet.jobs.paper.markdown import Report as _Report
from contactnet.jobs.paper.markdown import ms as _ms
from contactnet.jobs.paper.markdown import table
from contactnet.jobs.paper.results import (
    SectionResult,
    group,
    load_results,
    mean_of_trial_means,
    models,
    outcome,
    outcomes,
    rate_of,
    samples,
)
from contactnet.sim.world import ENGINE_NAMES

UNEVEN = ("stairs", "raised_stones", "random_heights")


def _paper_table2(planner: str) -> str:
    """The paper's Table II row: its counts and printed rate, with the Wilson interval of the counts."""
    if planner not in reference.TABLE2:
        return "-"
    rate = reference.TABLE2[planner]
    low, high = rate.interval
    return (f"{rate.successes} / {rate.trials} ({reference.TABLE2_PERCENT[planner]:.1f} %, "
            f"{100 * low:.1f}-{100 * high:.1f})")


def _load(load: dict | None) -> str:
    """The machine's load average at a run's start and end (other work on the machine slows trials down)."""
    if not isinstance(load, dict):
        return "-"
    return " / ".join("-" if load.get(k) is None else f"{load[k]:.1f}" for k in ("start", "end"))


def _seconds(s: float) -> str:
    return f"{s / 3600:.2f} h" if s >= 3600 else f"{s / 60:.1f} min" if s >= 60 else f"{s:.0f} s"


# ---- the parts ---------------------------------------------------------------------------------
def _intro(r: _Report) -> None:
    planned = sum(s.planned for s in r.sections.values())
    stored = sum(len(s.records) for s in r.sections.values())
    full = sum(s.full for s in r.sections.values())
    scale = r.header.get("scale", 1.0)
    engine = f"{ENGINE_NAMES.get(r.header.get('sim', 'pybullet'), 'PyBullet')} {r.header.get('sim_version', '')}"
    if r.plan == "frontier":
        r.add(f"# {FRONTIER_TITLE}", "",
              f"Beyond the paper's evaluation: where its benchmark stops telling planners apart, run in {engine} by "
              "`contactnet experiment frontier` (also the last section of `contactnet experiment paper`). A success "
              "rate reads *successes / trials (rate, 95 % Wilson score interval)*.", "")
    else:
        r.add(f"# {PAPER_TITLE}", "",
              "The experiments of Bratta et al., *ContactNet: Online Multi-Contact Planning for Acyclic Legged Robot "
              f"Locomotion*, Sec. IV, run in {engine} by `contactnet experiment paper`, each result beside the "
              "paper's, and beyond it the frontier. A success rate reads *successes / trials (rate, 95 % Wilson "
              "score interval)*.", "")
    robot = r.header.get("robot", "solo12")
    if robot != "solo12":
        r.add(f"**Robot: {robot}**, not the paper's Solo12: every scene is built at its size, every push and payload "
              "is the same fraction of its weight as Solo12's (`contactnet.jobs.paper.plan.RobotSizing`), its own "
              "models plan. The paper's figures beside the results are Solo12's.", "")
    if scale < 1.0:
        whose = "the paper's numbers of attempts" if r.plan == "paper" else "the plan's numbers of trials"
        r.add(f"**Scaled run**: scale {scale:g}, {planned} of the full plan's {full} trials ({whose} are those at "
              "scale 1): the intervals are wide and the targets are not yet judged at the full scale.", "")
    if stored < planned:
        r.add(f"**Incomplete**: {stored} of the {planned} planned trials are stored (an interrupted run); run the "
              "same command again to finish.", "")


def _summary(r: _Report) -> None:
    rows = []
    fig5 = r.section("fig5")
    if fig5:
        cells = group(fig5.records, lambda t: (t["gait"], t["noise"], t["removed"]))
        for gait in ("walk", "trot"):
            clean = {n: rate_of(rs) for (g, noise, n), rs in cells.items() if g == gait and noise == 0}
            if not clean:
                continue
            n_low = min(clean, key=lambda n: (clean[n].rate, n))
            target = ">= 95 % at every n" if gait == "walk" else "reported"
            met = r.met(all(c.rate >= 0.95 for c in clean.values())) if gait == "walk" else ""
            rows.append([f"Fig. 5, {gait}, no noise: lowest over n = {min(clean)}-{max(clean)}",
                         f"n = {n_low}: {clean[n_low].text()}", reference.SAYS[f"fig5 {gait}"], target, met])
        for gait in ("walk", "trot"):
            by_noise = {noise: rate_of([x for (g, v, _), rs in cells.items() if g == gait and v == noise for x in rs])
                        for noise in sorted({v for (g, v, _) in cells if g == gait})}
            if len(by_noise) > 1:
                rows.append([f"Fig. 5, {gait}, all n: without / with noise",
                             " / ".join(f"{rate.text()}" for rate in by_noise.values()), reference.SAYS["fig5 noise"],
                             "", ""])
    table2 = r.section("table2")
    if table2:
        by_planner = {p: rate_of(rs) for (p,), rs in group(table2.records, lambda t: (t["planner"],)).items()}
        for planner in reference.TABLE2:
            if planner in by_planner:
                percent = reference.TABLE2_PERCENT[planner]
                target = f">= {percent:.1f} %" if planner == "contactnet" else ""
                met = r.met(by_planner[planner].rate >= percent / 100) if planner == "contactnet" else ""
                rows.append([f"Table II, n = 110, {'acyclic' if planner == 'contactnet' else 'fixed gait'}",
                             by_planner[planner].text(), _paper_table2(planner), target, met])
    push = r.section("push")
    if push:
        falls = sum(bool(x["fell"]) for x in push.records)
        rows.append(["Push 5 N for 1 s, random moments and directions: falls", f"{falls} of {len(push.records)}",
                     reference.SAYS["push"], "0 falls", r.met(falls == 0)])
    robustness = r.section("robustness")
    if robustness:
        from contactnet.sim.mismatch import ModelMismatch

        field = [x for x in robustness.records if x["trial"]["terrain"] == "random"]
        cells = group(field, lambda t: (t["gait"], ModelMismatch.from_dict(t.get("mismatch")).label()))
        for gait in ("walk", "trot"):
            mine = {label: rate_of(rs) for (g, label), rs in cells.items() if g == gait and label}
            if mine:
                worst = min(mine, key=lambda label: mine[label].rate)
                rows.append([f"Model mismatch, {gait}, random field n = 80: the worst", f"{worst}: {mine[worst].text()}",
                             "-", ">= 95 % each", r.met(all(m.rate >= 0.95 for m in mine.values()))])
    for folder in ("stepping_stones", "narrow_stones"):
        scene = r.section(folder)
        if scene:
            by_planner = group(scene.records, lambda t: (t["planner"],))
            ours = "; ".join(f"{p}: {rate_of(rs).successes} / {len(rs)} crossed" for (p,), rs in by_planner.items())
            rows.append([scene.title, ours, reference.SAYS[folder], "", ""])
    r.add("## Summary", "")
    if rows:
        r.add(*table(["result", "ours", "paper", "target (issue 15)", "met"], rows))
        if r.scaled:
            r.add("(yes) / (no): met or not on this scaled run; the targets are for the paper's numbers of trials.", "")
    else:
        r.add("*No stored trials yet.*", "")


def _run(r: _Report) -> None:
    runs = r.header.get("runs", [])
    r.add("## Run", "")
    rows = [[run.get("started_utc", "?"), f"`{run.get('command', '')}`", run.get("trials_run", 0),
             run.get("trials_reused", 0), _seconds(run.get("wall_s", 0.0)),
             "-" if run.get("cpu_s") is None else _seconds(run["cpu_s"]),
             f"{run.get('trials_run', 0) / max(run.get('wall_s', 0.0), 1e-9):.3f}" if run.get("trials_run") else "-",
             f"{run.get('workers')} ({run.get('engine', 'local')})", _load(run.get("load_average")),
             "yes" if run.get("interrupted") else ""]
            for run in runs]
    r.add(*table(["started (UTC)", "command", "trials run", "reused", "wall time", "CPU time", "trials/s",
                  "workers (engine)",
                  "load average start / end", "interrupted"], rows))
    wall = sum(run.get("wall_s", 0.0) for run in runs)
    ran = sum(run.get("trials_run", 0) for run in runs)
    r.add(f"Total: {ran} trials run in {_seconds(wall)} of wall time ({ran / max(wall, 1e-9):.3f} trials/s).", "")
    _estimate(r, wall)
    if not runs:
        r.add("No run is recorded in paper.json yet (the first run is still going, or was killed before it could "
              "record itself).", "")
    last = runs[-1] if runs else {}
    code = last.get("code") or _code_of_trials(r)
    r.add("**Code**: " + ", ".join([f"git `{code.get('git_describe') or 'not a git checkout'}`",
                                    f"commit `{code.get('git_commit') or '-'}`",
                                    f"contactnet {code.get('contactnet', '?')}",
                                    f"sources sha256 `{str(code.get('sources', '?'))[:16]}`"]) + ".", "")
    records = [x for s in r.sections.values() for x in s.records]
    identities = {str(((x.get("inputs") or {}).get("code") or {}).get("sources", "?"))[:16] for x in records}
    if len(identities) > 1:
        r.add(f"The stored trials were run by {len(identities)} versions of the code (sources "
              f"{', '.join(sorted(identities))}).", "")
    found = models(records)
    if found:
        r.add(*table(["gait", "model (content sha256)", "trials"],
                     [[gait, f"`{identity}`", count] for gait, counts in sorted(found.items())
                      for identity, count in counts.most_common()]))
    m = last.get("machine", {})
    if m:
        packages = ", ".join(f"{k} {v}" for k, v in m.get("packages", {}).items() if v)
        r.add(f"**Machine**: {m.get('cpu')}, {m.get('cores')} cores ({m.get('usable_cores')} usable), "
              f"{m.get('memory_gb')} GB, {m.get('os')}; Python {m.get('python')}; {packages}.", "")


def _code_of_trials(r: _Report) -> dict:
    """The code version the stored trials name (their resume keys'), when no run is recorded."""
    for s in r.sections.values():
        for x in s.records:
            code = (x.get("inputs") or {}).get("code")
            if isinstance(code, dict):
                return {"contactnet": code.get("contactnet"), "sources": code.get("sources")}
    return {}


def _estimate(r: _Report, wall_s: float) -> None:
    """The full plan's wall time, estimated from the stored trials' mean time per section (in their workers):
    at the parallelism the runs achieved on this machine as loaded as it was, and on an idle machine from the CPU
    time the runs used per second of trial (all usable cores busy)."""
    if r.header.get("scale", 1.0) >= 1.0 or wall_s <= 0:
        return
    records = [x for s in r.sections.values() for x in s.records]
    worker_s = sum(x.get("trial_wall_s", 0.0) for x in records)
    if worker_s <= 0:
        return
    full_worker_s = sum(s.full * np.mean([x.get("trial_wall_s", 0.0) for x in s.records])
                        for s in r.sections.values() if s.records)
    parallel = worker_s / wall_s
    text = (f"Estimate for the full plan ({sum(s.full for s in r.sections.values())} trials), from each section's "
            f"mean trial time here times its full number of trials: {_seconds(full_worker_s / parallel)} at this "
            f"run's parallelism ({parallel:.2f} trials at a time, the machine as loaded as it was)")
    runs = r.header.get("runs", [])
    timed = {i for i, run in enumerate(runs) if run.get("cpu_s") and run.get("engine", "local") == "local"}
    timed_worker_s = sum(x.get("trial_wall_s", 0.0) for x in records if x.get("paper_run") in timed)
    cores = (runs[-1].get("machine") or {}).get("usable_cores") if runs else None
    if timed_worker_s > 0 and cores:
        cpu_share = sum(runs[i]["cpu_s"] for i in timed) / timed_worker_s
        text += (f"; {_seconds(full_worker_s * cpu_share / cores)} on {cores} idle cores (the runs used "
                 f"{cpu_share:.2f} CPU s per trial second)")
    r.add(text + ".", "")


def _fig5(r: _Report) -> None:
    r.add("## Fig. 5: random field, success vs squares removed", "",
          "1.5 x 0.5 m of 300 squares of 5 x 5 cm, n removed at random (seed i = terrain i), vx = 0.05 m/s, "
          "ContactNet; without and with joint-velocity noise of variance 0.01. Paper: " + reference.SAYS["fig5"]
          + "; 100 attempts per point.", "")
    section = r.section("fig5")
    if not section:
        return r.missing("fig5")
    r.figure("fig5", "Fig. 5, ours: success vs n", lambda p: plots.plot_fig5(section, p))
    cells = group(section.records, lambda t: (t["removed"], t["gait"], t["noise"]))
    columns = sorted({(g, v) for _, g, v in cells}, key=lambda c: (["walk", "trot"].index(c[0]), c[1]))
    rows = [[n] + [rate_of(cells.get((n, g, v), [])).text() for g, v in columns]
            for n in sorted({n for n, _, _ in cells})]
    r.add(*table(["n removed"] + [f"{g}, " + ("no noise" if v == 0 else f"noise {v:g}") for g, v in columns], rows))


def _table1(r: _Report) -> None:
    r.add("## Table I: planner time per attempt", "",
          "The mean time of one plan (3 network evaluations and the safety checks) in each attempt, averaged over "
          "the attempts (the paper's statistic), on Fig. 5's noise-free trials; beside it the median over every "
          "plan. Ours runs in a worker process that shares its core with the physics; an attempt's first plan "
          "includes the network's warm-up.", "")
    section = r.section("fig5")
    if not section:
        return r.missing("fig5")
    cells = group([x for x in section.records if x["trial"]["noise"] == 0], lambda t: (t["removed"], t["gait"]))
    ns = sorted({n for n, _ in cells})
    means = [(n, {g: mean_of_trial_means(cells.get((n, g), []), "planner_ms") for g in ("walk", "trot")}) for n in ns]
    rows = []
    for n, mean in means:
        row = [n]
        for gait in ("walk", "trot"):
            calls = samples(cells.get((n, gait), []), "planner")
            row += [_ms(mean[gait]), _ms(float(np.median(calls)) if calls.size else np.nan),
                    _ms(reference.TABLE1_MS[gait].get(n, np.nan))]
        rows.append(row)
    r.add(*table(["n removed", "walk: ours mean", "walk: ours median", "walk: paper", "trot: ours mean",
                  "trot: ours median", "trot: paper"], rows))
    r.figure("table1", "Table I: planner time per attempt, ours and the paper's", lambda p: plots.plot_table1(means, p))


def _table2(r: _Report) -> None:
    r.add("## Table II: acyclic vs fixed gait, n = 110", "",
          "The same random fields (seed i = terrain i) with 110 squares removed, walk: ContactNet choosing leg and "
          "foothold (optimized acyclic) and the same network held to a fixed leg order (fixed cyclic). The paper prints "
          "93.6 % for its 281 / 300 (93.67 %).", "")
    section = r.section("table2")
    if not section:
        return r.missing("table2")
    by_planner = group(section.records, lambda t: (t["planner"],))
    names = {"contactnet": "optimized acyclic", "fixed": "fixed cyclic"}
    rows = [[names.get(p, p), len(rs), rate_of(rs).successes, rate_of(rs).text(),
             _paper_table2(p)] for (p,), rs in by_planner.items()]
    r.add(*table(["gait", "attempts", "successes", "ours", "paper"], rows))
    seeds = {p: {x["trial"]["seed"]: bool(x["success"]) for x in rs} for (p,), rs in by_planner.items()}
    if {"contactnet", "fixed"} <= set(seeds):
        both = sorted(set(seeds["contactnet"]) & set(seeds["fixed"]))
        pairs = [(seeds["contactnet"][s], seeds["fixed"][s]) for s in both]
        r.add(f"On the {len(both)} terrains both ran: both crossed {pairs.count((True, True))}, only the acyclic "
              f"{pairs.count((True, False))}, only the fixed {pairs.count((False, True))}, neither "
              f"{pairs.count((False, False))}.", "")
    r.figure("table2", "Table II: ours beside the paper's", lambda p: plots.plot_table2(section, p))


def _push(r: _Report) -> None:
    from contactnet.jobs.pushes import plot_polar, push_facts

    r.add("## Push recovery", "",
          "Walk and trot at vx = 0.05 m/s on `push_field` (10 x 10 cm holes); one push per trial, at a start time "
          "drawn uniformly over the walk (after 2 s) and a direction drawn uniformly on the circle "
          "(`contactnet.jobs.pushes`; the same draws for both gaits); success = no fall 4 s after the push. The "
          "velocity change is the push's impulse over the robot's mass (what it would do to the free body). "
          "Paper: " + reference.SAYS["push"] + ".", "")
    section = r.section("push")
    if not section:
        return r.missing("push")

    def size(t: dict) -> tuple:
        facts = push_facts({"trial": t})
        return facts["push_n"], facts["push_duration_s"]

    cells = group(section.records, lambda t: (t["gait"], *size(t)))
    rows = []
    for (gait, force, duration), rs in cells.items():
        dv = push_facts(rs[0])["push_dv_m_s"]
        rows.append([gait, f"{force:g} N x {duration:g} s", f"{force * duration:g}", "-" if dv is None else f"{dv:g}",
                     rate_of(rs).text(), falls_text(rs)])
    r.add(*table(["gait", "push", "impulse (N s)", "velocity change (m/s)", "no fall", "falls by reason"], rows))
    r.figure("push_polar", "success by push direction", lambda p: plot_polar(section.records, p))


def _robustness(r: _Report) -> None:
    from contactnet.sim.mismatch import ModelMismatch

    r.add("## A robot that is not the model (beyond the paper)", "",
          "Each trial's simulated robot differs from the model its planner and controller use in one way they do "
          "not know (`contactnet.sim.mismatch`): heavier (every link's mass and inertia), a payload fixed to the base "
          "off its centre, less friction, weaker motors, noisy base sensors (orientation, linear and angular "
          "velocity), a late control loop. Walk and trot at 0.05 m/s on the random field (80 squares removed, one "
          "terrain per seed) and across the stepping stones. Target on the field: >= 95 % for each mismatch.", "")
    section = r.section("robustness")
    if not section:
        return r.missing("robustness")

    def label(t: dict) -> str:
        return ModelMismatch.from_dict(t.get("mismatch")).label() or "none (the model)"

    rows = []
    for (gait, terrain, mismatch), rs in group(section.records, lambda t: (t["gait"], t["terrain"], label(t))).items():
        rows.append([gait, terrain, mismatch, rate_of(rs).text(), falls_text(rs)])
    r.add(*table(["gait", "terrain", "mismatch", "crossed", "failures by reason"], rows))


def _stones(r: _Report) -> None:
    r.add("## Stepping stones and narrow stones", "")
    for folder in ("stepping_stones", "narrow_stones"):
        section = r.section(folder)
        r.add(f"### {section.title if section else folder}", "", "Paper: " + reference.SAYS[folder] + ".", "")
        if not section:
            r.missing(folder)
            continue
        rows = [[p, g, rate_of(rs).text(), "; ".join(sorted({outcome(x) for x in rs})),
                 f"{np.mean([x['reached_x'] for x in rs]):.2f}",
                 f"{np.mean([x['rank_chosen']['mean'] for x in rs]):.1f} / {max(x['rank_chosen']['max'] for x in rs)}",
                 _ms(mean_of_trial_means(rs, "planner_ms")), sum(x["unsafe_landings"] for x in rs)]
                for (p, g), rs in group(section.records, lambda t: (t["planner"], t["gait"])).items()]
        r.add(*table(["planner", "gait", "crossed", "outcome", "reached x (m)", "rank chosen mean / max",
                      "planner ms (mean)", "unsafe landings"], rows))


def _uneven(r: _Report) -> None:
    r.add("## Terrain with heights (beyond the paper)", "",
          "The paper's terrains are flat; these have tops at several heights (the same network, trained on flat "
          "ground). Success = the goal reached without a fall.", "")
    rows = []
    for folder in UNEVEN:
        section = r.section(folder)
        if not section:
            continue
        r.add(f"- `{folder}`: {section.title}")
        for (g, p), rs in group(section.records, lambda t: (t["gait"], t["planner"])).items():
            rows.append([folder, g, p, rate_of(rs).text(), sum(bool(x["fell"]) for x in rs),
                         f"{max(x.get('max_height_change_m', 0.0) for x in rs) * 100:.1f}"])
    if rows:
        r.add("", *table(["experiment", "gait", "planner", "crossed", "falls", "largest step up/down (cm)"], rows))
    else:
        r.missing(", ".join(UNEVEN))


def _outcomes(r: _Report) -> None:
    r.add("## Outcomes by reason", "", "Every stored trial by what became of it (the referee's fall reason, "
          "grouped).", "")
    present = [s for s in r.sections.values() if s.records]
    counts = {s.folder: outcomes(s.records) for s in present}
    reasons = sorted({reason for c in counts.values() for reason in c}, key=lambda x: (x.startswith("fell"), x))
    rows = [[reason] + [counts[s.folder].get(reason, 0) or "" for s in present] for reason in reasons]
    r.add(*table(["outcome"] + [s.folder for s in present], rows))


def _times(r: _Report) -> None:
    r.add("## Planner and optimizer times", "",
          "Every planner call (3 steps) and every optimizer solve of the stored trials, in ms.", "")
    present = [s for s in r.sections.values() if s.records]
    if not present:
        return
    r.figure("times", "time per call of the planner and the optimizer", lambda p: plots.plot_times(present, p))
    rows = []
    for s in present:
        for (gait,), rs in group(s.records, lambda t: (t["gait"],)).items():
            p, q = samples(rs, "planner"), samples(rs, "trajopt")
            if not p.size or not q.size:
                continue
            rows.append([s.folder, gait, p.size, *(_ms(v) for v in np.percentile(p, [50, 90, 99])), _ms(p.max()),
                         q.size, *(_ms(v) for v in np.percentile(q, [50, 99])), _ms(q.max()),
                         sum(x.get("trajopt_failures", 0) for x in rs)])
    r.add(*table(["section", "gait", "plans", "planner median", "p90", "p99", "max", "solves", "optimizer median",
                  "p99", "max", "optimizer failures"], rows))
    r.add("## Trial times", "")
    rows = [[s.folder, len(s.records), f"{np.mean([x.get('trial_wall_s', np.nan) for x in s.records]):.1f}",
             f"{np.mean([x['sim_time_s'] for x in s.records]):.1f}",
             f"{sum(x['sim_time_s'] for x in s.records) / max(sum(x['wall_time_s'] for x in s.records), 1e-9):.1f}"]
            for s in present]
    r.add(*table(["section", "trials", "mean trial wall time (s, in its worker)", "mean simulated time (s)",
                  "simulated / loop wall time"], rows))


PAPER_TITLE = "ContactNet: the paper's evaluation (Sec. IV), reproduced"
FRONTIER_TITLE = "ContactNet beyond the paper: the frontier"


def build_markdown(out: Path, header: dict, sections: dict[str, SectionResult]) -> str:
    """The report's markdown (its figures written to ``out/report_plots``)."""
    r = _Report(out, header, sections)
    parts = ((_intro, _run, frontier_section, _outcomes, _times) if r.plan == "frontier" else
             (_intro, _summary, _run, _fig5, _table1, _table2, _push, _robustness, _stones, _uneven, frontier_section,
              _outcomes, _times))
    for part in parts:
        part(r)
    return "\n".join(r.lines).rstrip() + "\n"


STYLE = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222;line-height:1.45}
table{border-collapse:collapse;margin:0.5em 0 1em;font-size:0.9em}th,td{border:1px solid #ccc;padding:0.25em 0.6em;
text-align:left;vertical-align:top}th{background:#f2f4f7}img{max-width:100%;border:1px solid #eee}
code{background:#f5f5f5;padding:0 0.2em;font-size:0.92em;word-break:break-all}h1{font-size:1.6em}h2{margin-top:1.6em;
border-bottom:1px solid #ddd}"""


def to_html(markdown: str, out: Path) -> str:
    """One self-contained page of the report: the markdown rendered, its figures embedded as base64 PNG."""
    from markdown_it import MarkdownIt

    body = MarkdownIt("commonmark", {"html": False}).enable("table").render(markdown)

    def embed(match: re.Match) -> str:
        data = base64.b64encode((out / html_lib.unescape(match.group(1))).read_bytes()).decode()
        return f'src="data:image/png;base64,{data}"'

    body = re.sub(r'src="(report_plots/[^"]+\.png)"', embed, body)
    title = FRONTIER_TITLE if markdown.startswith(f"# {FRONTIER_TITLE}") else "ContactNet: the paper's evaluation"
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{title}</title>'
            f"<style>{STYLE}</style></head><body>\n{body}</body></html>\n")


def write_report(out_dir: str | Path) -> tuple[Path, Path]:
    """Write ``report.md`` and ``report.html`` of the paper run in ``out_dir`` from its stored trials; returns
    their paths."""
    out = Path(out_dir)
    header, sections = load_results(out)
    markdown = build_markdown(out, header, sections)
    atomic_write_text(out / "report.md", markdown)
    atomic_write_text(out / "report.html", to_html(markdown, out))
    return out / "report.md", out / "report.html"
