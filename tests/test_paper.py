"""`contactnet experiment paper` and its report: the plan at scale 1 and 0.1, the Wilson interval, the report
of stored trials (numbers, self-contained html), and a tiny real run end to end (layout, resume, report); beyond the
paper, `contactnet experiment frontier`: its plan, the difference interval, its report section, a tiny real run."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from contactnet.cli import main
from contactnet.jobs.experiment import ExperimentError
from contactnet.jobs.paper.plan import (
    FRONTIER_SECTIONS,
    PAPER_SECTIONS,
    RobotSizing,
    Section,
    frontier_sections,
    plan_trials,
    scaled,
    share,
)
from contactnet.jobs.paper.report import write_report
from contactnet.jobs.paper.results import outcome
from contactnet.jobs.paper.run import run_paper
from contactnet.jobs.paper.stats import difference_interval, wilson_interval


# ---- Wilson interval -----------------------------------------------------------------------------
@pytest.mark.parametrize("successes, trials, low, high", [
    # Newcombe (1998), Stat. Med. 17:857-872, Table I, method 3 (Wilson score, no continuity correction)
    (81, 263, 0.2553, 0.3662), (15, 148, 0.0624, 0.1605), (0, 20, 0.0, 0.1611), (1, 29, 0.0061, 0.1718),
    # the paper's Table II
    (281, 300, 0.9032, 0.9591), (256, 300, 0.8088, 0.8889),
])
def test_wilson_interval_known_values(successes, trials, low, high):
    found = wilson_interval(successes, trials)
    assert found == pytest.approx((low, high), abs=6e-5)


def test_wilson_interval_edges_and_scipy():
    assert wilson_interval(0, 0) == (0.0, 1.0)
    assert wilson_interval(5, 5)[1] == 1.0 and wilson_interval(0, 5)[0] == 0.0
    assert wilson_interval(50, 100, 0.99)[0] < wilson_interval(50, 100)[0]  # wider at 99 %
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(3, 2)
    stats = pytest.importorskip("scipy.stats")
    for k, n in ((0, 7), (3, 7), (7, 7), (93, 100), (1, 300)):
        ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
        assert wilson_interval(k, n) == pytest.approx((ci.low, ci.high), abs=1e-12)


@pytest.mark.parametrize("a, n, b, m, low, high", [
    # Newcombe (1998), Stat. Med. 17:873-890, Table II, method 10 (hybrid score, no continuity correction)
    (56, 70, 48, 80, 0.0524, 0.3339), (9, 10, 3, 10, 0.1705, 0.8090), (6, 7, 2, 7, 0.0582, 0.8062),
    (5, 56, 0, 29, -0.0381, 0.1926), (0, 10, 0, 20, -0.1611, 0.2775), (0, 10, 0, 10, -0.2775, 0.2775),
])
def test_difference_interval_known_values(a, n, b, m, low, high):
    found = difference_interval(a, n, b, m)
    assert found == pytest.approx((low, high), abs=6e-5)
    assert difference_interval(b, m, a, n) == pytest.approx((-found[1], -found[0]), abs=1e-12)  # b - a: mirrored
    assert difference_interval(3, 3, 0, 0) == (-1.0, 1.0)


# ---- the plan ------------------------------------------------------------------------------------
# The paper's Sec. IV, then the frontier (issue 32): the random field at n = 110..200 (7 points x 2 gaits x (3
# planners x 100 seeds + the oracle x 20)) and narrow_map over 6 widths x 7 gaps x 2 planners x 4 seeds.
FULL = {"fig5": 2400, "table2": 600, "push": 400, "stepping_stones": 2, "narrow_stones": 2, "stairs": 4,
        "raised_stones": 20, "random_heights": 80, "robustness": 1422, "frontier": 4480, "frontier_narrow": 336}
TENTH = {"fig5": 240, "table2": 60, "push": 40, "stepping_stones": 2, "narrow_stones": 2, "stairs": 4,
         "raised_stones": 4, "random_heights": 8, "robustness": 162, "frontier": 448, "frontier_narrow": 84}


def test_the_plan_has_the_papers_counts_and_scales_as_a_prefix():
    full, tenth, tiny = plan_trials(scale=1.0), plan_trials(scale=0.1), plan_trials(scale=1e-6)
    assert {k: len(v) for k, v in full.items()} == FULL and sum(FULL.values()) == 4930 + 4816
    assert {k: len(v) for k, v in tenth.items()} == TENTH
    fig5 = full["fig5"]
    assert {(t.gait, t.planner, t.noise) for t in fig5} == {(g, "contactnet", v) for g in ("walk", "trot")
                                                            for v in (0.0, 0.01)}
    assert sorted({t.removed for t in fig5}) == [50, 60, 70, 80, 90, 100] and {t.seed for t in fig5} == set(range(100))
    table2 = full["table2"]
    assert {(t.removed, t.gait) for t in table2} == {(110, "walk")}
    assert {t.seed for t in table2 if t.planner == "fixed"} == {t.seed for t in table2 if t.planner == "contactnet"}
    assert {round(abs(complex(*t.push_force_xy)), 3) for t in full["push"]} == {5.0}  # 200 sampled pushes a gait
    assert len({t.push_force_xy for t in full["push"]}) == 200
    assert {t.seed for t in tenth["fig5"]} == set(range(10))  # seed i of a batch = i
    for folder in FULL:  # a scaled run is a prefix of the full one: a full run reuses its trials
        assert {t.key for t in tenth[folder]} <= {t.key for t in full[folder]}
        def cell(t):
            push = t.push_force_xy and round(abs(complex(*t.push_force_xy)), 3)
            return t.gait, t.planner, t.terrain, t.removed, t.noise, push, t.mismatch

        cells = {cell(t) for t in full[folder]}
        assert {cell(t) for t in tiny[folder]} == cells
        assert len(tiny[folder]) == len(cells)  # at least (and here exactly) one trial per cell


def test_the_frontier_plan_has_its_points_and_fewer_oracle_seeds():
    plan = plan_trials(FRONTIER_SECTIONS)
    field, narrow = plan["frontier"], plan["frontier_narrow"]
    assert sorted({t.removed for t in field}) == [110, 125, 140, 155, 170, 185, 200]
    assert {(t.terrain, t.noise) for t in field} == {("random", 0.0)} and {t.gait for t in field} == {"walk", "trot"}
    seeds = {p: {t.seed for t in field if t.planner == p and t.gait == "trot" and t.removed == 200}
             for p in ("contactnet", "fixed", "heuristic", "oracle")}
    assert seeds == {"contactnet": set(range(100)), "fixed": set(range(100)), "heuristic": set(range(100)),
                     "oracle": set(range(20))}  # the slow oracle on the first 20 terrains only
    assert sorted({round(100 * t.bar_width_m) for t in narrow}) == [2, 3, 4, 5, 6, 7]
    assert sorted({round(100 * t.last_gap_m) for t in narrow}) == [12, 15, 18, 21, 24, 27, 30]
    assert {(t.gait, t.planner, t.noise) for t in narrow} == {("walk", p, 0.01) for p in ("contactnet", "fixed")}
    assert {t.seed for t in narrow} == set(range(4))
    # --trials 3: 3 seeds per point, the oracle and narrow_map in proportion (at least 1)
    three = plan_trials(FRONTIER_SECTIONS, scale=0.03)
    assert len(three["frontier"]) == 7 * 2 * (3 * 3 + 1) and len(three["frontier_narrow"]) == 6 * 7 * 2
    assert {t.key for t in three["frontier"]} <= {t.key for t in field}  # a prefix: the full run reuses it
    assert len(plan_trials(FRONTIER_SECTIONS, scale=2.0)["frontier"]) == 7 * 2 * (3 * 200 + 40)  # --trials 200
    # chosen gaits, planners, points and cells instead of the plan's; the oracle keeps its fewer seeds
    mine = plan_trials(frontier_sections(("walk",), ("contactnet", "oracle"), (140, 170), (2.0,), (30.0,)))
    assert {(t.planner, t.removed) for t in mine["frontier"]} == {(p, n) for p in ("contactnet", "oracle")
                                                                 for n in (140, 170)}
    assert len(mine["frontier"]) == 2 * (100 + 20)
    assert {(t.terrain, t.planner) for t in mine["frontier_narrow"]} == {("narrow_stones_w2_g30", "contactnet"),
                                                                         ("narrow_stones_w2_g30", "oracle")}


def test_scaled_rounds_half_up_and_keeps_one():
    assert [scaled(100, 0.1), scaled(300, 0.1), scaled(5, 0.1), scaled(10, 0.05), scaled(100, 0.02)] == [10, 30, 1,
                                                                                                           1, 2]
    assert scaled(20, 0.1) == 2 and scaled(20, 0.125) == 3 and scaled(5, 1.0) == 5
    with pytest.raises(ValueError, match="scale"):
        scaled(10, 0.0)
    with pytest.raises(ValueError, match="scale"):
        scaled(10, 1.5)
    assert share(20, 0.03) == 1 and share(100, 2.0) == 200  # beyond 1: the frontier's --trials above 100
    with pytest.raises(ValueError, match="scale"):
        share(10, 0.0)


def test_outcomes_name_the_kind_of_fall():
    def rec(success, fell, reason=None, push=None):
        return {"success": success, "fell": fell, "fall_reason": reason, "trial": {"push_force_xy": push}}

    assert outcome(rec(True, False)) == "reached the goal"
    assert outcome(rec(True, False, push=[5.0, 0.0])) == "stood the push"
    assert outcome(rec(False, False)) == "time limit before the goal"
    assert outcome(rec(False, True, "base height 0.050 m below 0.1 m")) == "fell: base too low"
    assert outcome(rec(False, True, "base tilted (roll 1.20, pitch 0.00 rad)")) == "fell: base tilted over"
    gap = "non-foot contact: FR_LOWER_LEG on an edge at x 0.44, y -0.14 m (the FR foot stepped into a gap)"
    assert outcome(rec(False, True, gap)) == "fell: a foot stepped into a gap"
    assert outcome(rec(False, True, "non-foot contact: BASE on an edge at x 1, y 0 m")) == \
        "fell: a leg or the body hit an edge"


# ---- the report of stored trials (no simulation) ---------------------------------------------------
def _record(key, trial, success, planner_ms=0.3):
    return {"key": key, "trial": trial, "fingerprint": f"fp-{key}", "success": success, "fell": not success,
            "fall_reason": None if success else "base tilted (roll 1.00, pitch 0.00 rad)", "reached_x": 1.0,
            "sim_time_s": 30.0, "wall_time_s": 10.0, "trial_wall_s": 11.0, "steps": 90,
            "planner_ms": {"mean": planner_ms, "median": planner_ms}, "trajopt_ms": {"mean": 4.0, "median": 4.0},
            "rank_chosen": {"mean": 2.0, "max": 9}, "unsafe_landings": 0, "trajopt_failures": 0,
            "max_height_change_m": 0.0, "planner_ms_samples": [planner_ms] * 5, "trajopt_ms_samples": [4.0, 5.0],
            "inputs": {"model": f"file-sha256:model-of-{trial['gait']}", "code": {"contactnet": "0.1.0",
                                                                                   "sources": "abc"}},
            "paper_run": 0}


def _stored_run(out: Path) -> None:
    """A paper folder written by hand: Fig. 5 walk 9/10 at n = 50 (and 10/10 at 60), Table II 281/300 and
    256/300, one push that fell; plus a record of other code in the log that must not count."""
    def trial(**kw):
        return {"gait": "walk", "planner": "contactnet", "removed": None, "noise": 0.0, "seed": 0,
                "push_force_xy": None, "push_t0_s": None, **kw}

    sections = {
        "fig5": ("random", [_record(f"r/{n}/{s}", trial(removed=n, seed=s), not (n == 50 and s == 3), 0.5)
                            for n in (50, 60) for s in range(10)]),
        "table2": ("random", [_record(f"r/110/{s}/{p}", trial(removed=110, seed=s, planner=p),
                                      s < (281 if p == "contactnet" else 256)) for p in ("contactnet", "fixed")
                              for s in range(300)]),
        "push": ("push", [_record(f"p/{i}", trial(push_force_xy=[0.0, 5.0], push_t0_s=4.0 + 1.5 * i), i != 1)
                          for i in range(4)]),
    }
    header = {"format": "contactnet-paper-v1", "scale": 0.5, "runs": [
        {"command": "contactnet experiment paper --out X --scale 0.5", "started_utc": "2026-01-01T00:00:00+00:00",
         "wall_s": 3600.0, "cpu_s": 2000.0, "trials_run": 624, "trials_reused": 0, "workers": 2, "engine": "local",
         "interrupted": False, "code": {"git_describe": "v1-3-gabc", "git_commit": "abc", "contactnet": "0.1.0",
                                        "sources": "abc"},
         "machine": {"cpu": "Test CPU", "cores": 2, "usable_cores": 2, "python": "3.11", "packages": {}}}],
        "sections": []}
    for folder, (experiment, records) in sections.items():
        (out / folder).mkdir(parents=True)
        (out / folder / "experiment.json").write_text(json.dumps(
            {"format": "contactnet-experiment-v1", "experiment": experiment,
             "trials": {r["key"]: r["fingerprint"] for r in records}}))
        stale = {**records[0], "fingerprint": "other code", "success": not records[0]["success"]}
        (out / folder / "trials.jsonl").write_text("".join(json.dumps(r) + "\n" for r in [stale, *records]))
        header["sections"].append({"folder": folder, "experiment": experiment, "title": folder,
                                   "trials": len(records), "trials_full": 2 * len(records)})
    (out / "paper.json").write_text(json.dumps(header))


def _assert_self_contained(html: str) -> None:
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", html, re.I)
    assert "<link" not in html and "<script" not in html
    assert all(src.startswith("data:image/png;base64,") for src in re.findall(r'src="([^"]*)"', html))


def test_the_report_has_the_model_mismatch_cells_and_the_worst(tmp_path):
    _stored_run(tmp_path)
    heavy, slippery = {"mass_scale": 1.2}, {"friction": 0.5}

    def trial(seed, mismatch, terrain="random"):
        return {"gait": "walk", "planner": "contactnet", "terrain": terrain, "removed": 80, "noise": 0.0,
                "seed": seed, "push_force_xy": None, "push_t0_s": None, **({"mismatch": mismatch} if mismatch else {})}

    records = [_record(f"m/{k}/{s}", trial(s, m), not (k == 1 and s < 2)) for k, m in enumerate((None, heavy, slippery))
               for s in range(10)]
    records.append(_record("m/stones", trial(0, heavy, "stepping_stones"), True))
    folder = tmp_path / "robustness"
    folder.mkdir()
    (folder / "experiment.json").write_text(json.dumps({"format": "contactnet-experiment-v1",
                                                        "experiment": "robustness",
                                                        "trials": {r["key"]: r["fingerprint"] for r in records}}))
    (folder / "trials.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))
    header = json.loads((tmp_path / "paper.json").read_text())
    header["sections"].append({"folder": "robustness", "experiment": "robustness", "title": "robustness",
                               "trials": len(records), "trials_full": len(records)})
    (tmp_path / "paper.json").write_text(json.dumps(header))
    md = write_report(tmp_path)[0].read_text()
    assert "| walk | random | none (the model) | 10 / 10 (100.0 %, 72.2-100.0) | - |" in md
    assert "| walk | random | mass1.2 | 8 / 10 (80.0 %, 49.0-94.3) | base tilted over: 2 |" in md
    assert "| walk | stepping_stones | mass1.2 | 1 / 1 " in md
    assert "| Model mismatch, walk, random field n = 80: the worst | mass1.2: 8 / 10 (80.0 %, 49.0-94.3) |" in md


def test_the_report_of_stored_trials_has_the_numbers_beside_the_papers(tmp_path):
    _stored_run(tmp_path)
    md_path, html_path = write_report(tmp_path)
    md = md_path.read_text()
    assert "| 50 | 9 / 10 (90.0 %, 59.6-98.2) |" in md and "| 60 | 10 / 10 (100.0 %, 72.2-100.0) |" in md
    # Table II: ours beside the paper's (the same counts here), with Wilson intervals
    assert "| optimized acyclic | 300 | 281 | 281 / 300 (93.7 %, 90.3-95.9) | 281 / 300 (93.6 %, 90.3-95.9) |" in md
    assert "| fixed cyclic | 300 | 256 | 256 / 300 (85.3 %, 80.9-88.9) | 256 / 300 (85.3 %, 80.9-88.9) |" in md
    assert "| >= 93.6 % | (yes) |" in md  # the target, judged on a scaled run
    assert "only the acyclic 25, only the fixed 0" in md
    assert "| walk | 5 N x 1 s | 5 | - | 3 / 4 (75.0 %, 30.1-95.4) | base tilted over: 1 |" in md  # one push fell
    assert "| Push 5 N for 1 s, random moments and directions: falls | 1 of 4 |" in md
    assert (tmp_path / "report_plots" / "push_polar.png").exists()
    assert "| walk: ours mean |" in md and "| 50 | 0.500 | 0.500 | 1.272 |" in md  # Table I
    assert re.search(r"\| fell: base tilted over \| 1 \| 63 \| 1 \|", md)  # outcomes by section
    assert "`contactnet experiment paper --out X --scale 0.5`" in md and "v1-3-gabc" in md and "Test CPU" in md
    assert "file-sha256:model-of-walk" in md and "Estimate for the full plan (1248 trials)" in md
    # 624 trials of 11 s in 3600 s of wall time with 2000 CPU s; the full plan has twice the trials
    assert "2.00 h at this run's parallelism (1.91 trials at a time" in md
    assert "33.3 min on 2 idle cores (the runs used 0.29 CPU s per trial second)" in md  # 2 x 2000 CPU s / 2
    assert "Scaled run" in md and "Incomplete" not in md
    html = html_path.read_text()
    _assert_self_contained(html)
    assert html.count("data:image/png;base64,") == 5  # Fig. 5, Table I, Table II, pushes by direction, times
    assert "<table>" in html and "281 / 300" in html
    for name in ("fig5", "table1", "table2", "times"):
        assert (tmp_path / "report_plots" / f"{name}.png").stat().st_size > 5000


def test_report_errors_are_one_line(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    assert "no paper.json" in capsys.readouterr().err
    (tmp_path / "experiment.json").write_text("{}")
    with pytest.raises(ExperimentError, match="single experiment"):
        run_paper(tmp_path, 0.1)
    assert main(["experiment", "paper", "--out", str(tmp_path / "x"), "--trials", "3"]) == 2
    assert "drop --trials" in capsys.readouterr().err
    for option, value in (("--force", "7.5"), ("--impulse", "1"), ("--mass-scale", "1.2"), ("--delay-ms", "3")):
        assert main(["experiment", "paper", "--out", str(tmp_path / "x"), option, value]) == 2
        assert f"drop {option}" in capsys.readouterr().err  # the plan fixes the pushes and the robot
    for option in ("--no-observer", "--retarget"):  # ... and runs the default stack (was: --observer ignored)
        assert main(["experiment", "paper", "--out", str(tmp_path / "x"), option]) == 2
        assert f"drop {option}" in capsys.readouterr().err
    assert main(["experiment", "random", "--out", str(tmp_path / "y"), "--scale", "0.1"]) == 2
    assert "experiment paper" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["experiment", "paper", "--out", str(tmp_path / "z"), "--scale", "2"])
    assert "--scale" in capsys.readouterr().err


# ---- a tiny real run --------------------------------------------------------------------------------
# The blind heuristic falls within a few simulated seconds on these terrains: three short PyBullet trials.
TINY = (
    Section("fig5", "random", "Fig. 5 (tiny)", 100, ("walk",), ("heuristic",), removed=(110,)),
    Section("table2", "random", "Table II (tiny)", 300, ("walk",), ("heuristic",), removed=(110,)),
    Section("narrow_stones", "narrow_stones", "Narrow stones (tiny)", 1, ("walk",), ("heuristic",)),
)


@pytest.mark.slow
def test_a_tiny_paper_run_end_to_end_resumes_and_reports(tmp_path, capsys):
    out = tmp_path / "paper"
    first = run_paper(out, scale=0.001, workers=1, progress=False, sections=TINY, command="tiny run")
    assert first["ran"] == 3 and first["trials"] == 3
    for folder in ("fig5", "table2", "narrow_stones"):
        for name in ("experiment.json", "trials.jsonl", "summary.json", "success.png"):
            assert (out / folder / name).is_file(), f"{folder}/{name}"
    assert {p.name for p in out.iterdir()} >= {"paper.json", "report.md", "report.html", "report_plots"}
    logs = {folder: (out / folder / "trials.jsonl").read_text() for folder in ("fig5", "table2", "narrow_stones")}
    records = [json.loads(line) for text in logs.values() for line in text.splitlines()]
    assert len(records) == 3 and not any(r["success"] for r in records)
    assert all(r["planner_ms_samples"] and r["trajopt_ms_samples"] and r["trial_wall_s"] > 0 for r in records)
    # Resume: nothing runs again, the logs are untouched, the run is recorded.
    again = run_paper(out, scale=0.001, workers=1, progress=False, sections=TINY, command="tiny run")
    assert again["ran"] == 0
    assert {folder: (out / folder / "trials.jsonl").read_text() for folder in logs} == logs
    # A trial lost (as if killed before it was logged) runs again, alone.
    (out / "table2" / "trials.jsonl").write_text("")
    assert run_paper(out, scale=0.001, workers=1, progress=False, sections=TINY, command="tiny run")["ran"] == 1
    assert (out / "table2" / "trials.jsonl").read_text().count("\n") == 1
    header = json.loads((out / "paper.json").read_text())
    assert [run["trials_run"] for run in header["runs"]] == [3, 0, 1] and header["runs"][1]["trials_reused"] == 3
    logs["table2"] = (out / "table2" / "trials.jsonl").read_text()
    # The report: the trials' own numbers; regenerated from the stored trials by the command line.
    (out / "report.md").unlink()
    assert main(["report", str(out)]) == 0 and "report.html" in capsys.readouterr().out
    md = (out / "report.md").read_text()
    assert "| 110 | 0 / 1 (0.0 %, 0.0-79.3) |" in md  # Fig. 5's table: the stored trial
    by_folder = {folder: [outcome(json.loads(line)) for line in text.splitlines()] for folder, text in logs.items()}
    for reason in {o for found in by_folder.values() for o in found}:  # outcomes by reason, per section
        counts = [found.count(reason) or "" for found in by_folder.values()]
        assert f"| {reason} | {' | '.join(map(str, counts))} |" in md
    assert "| heuristic | 1 | 0 | 0 / 1 (0.0 %, 0.0-79.3) | - |" in md  # Table II: ours, the paper's has no row
    assert "`tiny run`" in md
    _assert_self_contained((out / "report.html").read_text())
    assert main(["experiment", "paper", "--out", str(out), "--report-only"]) == 0


@pytest.mark.slow
def test_a_tiny_paper_run_in_mujoco_says_so_and_keeps_to_its_folder(tmp_path):
    out = tmp_path / "paper"
    first = run_paper(out, scale=0.001, workers=1, progress=False, sections=TINY[2:], command="tiny", sim="mujoco")
    assert first["ran"] == 1
    record = json.loads((out / "narrow_stones" / "trials.jsonl").read_text())
    assert record["key"].endswith("/mujoco") and record["inputs"]["sim"].startswith("mujoco ")
    header = json.loads((out / "paper.json").read_text())
    assert header["sim"] == "mujoco" and header["sim_version"] == record["inputs"]["sim"].split()[1]
    assert "run in MuJoCo" in (out / "report.md").read_text()
    with pytest.raises(ExperimentError, match="holds a run in mujoco"):  # one engine per folder: no mixed report
        run_paper(out, scale=0.001, workers=1, progress=False, sections=TINY[2:], command="tiny")


def test_the_plan_for_another_robot_sizes_its_pushes_payloads_and_scenes():
    # Solo12: the plan as the paper's (forces 5 N, payload 0.5 kg at 5 cm); Go2: the same fractions of its weight
    # (13.7 kg / 2.5 kg) and size, every trial Go2's (its scenes built at its size by registry.terrain_for).
    solo, go2 = (plan_trials(PAPER_SECTIONS, 0.01, robot=robot) for robot in ("solo12", "go2"))
    assert RobotSizing.of("solo12") == RobotSizing()
    sizing = RobotSizing.of("go2")
    assert 6.0 < sizing.weight_ratio < 7.0 and 1.2 < sizing.size_scale < 1.5
    assert {t.robot for ts in go2.values() for t in ts} == {"go2"}
    assert {k: len(v) for k, v in solo.items()} == {k: len(v) for k, v in go2.items()}
    for a, b in zip(solo["push"], go2["push"], strict=True):
        assert a.push_t0_s == b.push_t0_s
        assert abs(float(np.hypot(*a.push_force_xy)) - 5.0) < 1e-3  # components rounded to 0.1 mN
        assert abs(float(np.hypot(*b.push_force_xy)) - round(5.0 * sizing.weight_ratio, 1)) < 1e-3
    payloads = [(a.mismatch, b.mismatch) for a, b in zip(solo["robustness"], go2["robustness"], strict=True)
                if a.mismatch.payload_kg]
    assert payloads and all(b.payload_kg == round(a.payload_kg * sizing.weight_ratio, 3) and
                            b.payload_offset_xy_m[0] == round(a.payload_offset_xy_m[0] * sizing.size_scale, 4)
                            for a, b in payloads)
    unchanged = [(a.mismatch, b.mismatch) for a, b in zip(solo["robustness"], go2["robustness"], strict=True)
                 if not a.mismatch.payload_kg]
    assert all(a == b for a, b in unchanged)  # relative mismatches (mass x 1.2, friction, ...) stay as they are


def test_a_paper_folder_keeps_to_one_robot_and_the_command_names_it(tmp_path, capsys):
    out = tmp_path / "paper"
    out.mkdir()
    (out / "paper.json").write_text(json.dumps({"format": "contactnet-paper-v1", "robot": "go2", "runs": [{}]}))
    with pytest.raises(ExperimentError, match="holds a run of go2"):
        run_paper(out, scale=0.01, sections=FRONTIER_SECTIONS, plan="frontier")
    assert main(["experiment", "frontier", "--out", str(out), "--robot", "solo12", "--trials", "1"]) == 2
    assert "holds a run of go2" in capsys.readouterr().err


# ---- beyond the paper: the frontier ------------------------------------------------------------------
def _stored_frontier(out: Path) -> None:
    """A frontier folder written by hand (plan "frontier", scale 0.1): on the field, walk at n = 110 and 200
    (ContactNet 10 and 7 of 10, the fixed gait 9 and 2, the oracle 2 and 0 of 2) and trot at n = 200 (ContactNet
    4 of 10 behind the fixed gait's 6); narrow bars of 2 and 5 cm before last gaps of 12 and 30 cm, one seed."""
    def trial(**kw):
        return {"gait": "walk", "planner": "contactnet", "terrain": "random", "removed": None, "noise": 0.0,
                "seed": 0, "push_force_xy": None, "push_t0_s": None, **kw}

    crossed = {("walk", 110, "contactnet"): 10, ("walk", 200, "contactnet"): 7, ("walk", 110, "fixed"): 9,
               ("walk", 200, "fixed"): 2, ("walk", 110, "oracle"): 2, ("walk", 200, "oracle"): 0,
               ("trot", 200, "contactnet"): 4, ("trot", 200, "fixed"): 6}
    field = [_record(f"random/{n}/seed{s}/{g}/{p}", trial(gait=g, removed=n, seed=s, planner=p), s < k,
                     planner_ms=150.0 if p == "oracle" else 0.3)
             for (g, n, p), k in crossed.items() for s in range(2 if p == "oracle" else 10)]
    narrow = [_record(f"w{w}/g{g}/{p}", trial(terrain=f"narrow_stones_w{w}_g{g}", planner=p, noise=0.01,
                                                bar_width_m=w / 100, last_gap_m=g / 100),
                      (w, g) == (5, 12) or (p == "contactnet" and (w, g) != (2, 30)))
              for p in ("contactnet", "fixed") for w in (2, 5) for g in (12, 30)]
    header = {"format": "contactnet-paper-v1", "plan": "frontier", "scale": 0.1, "runs": [], "sections": []}
    for folder, experiment, records in (("frontier", "random", field), ("frontier_narrow", "narrow_map", narrow)):
        (out / folder).mkdir(parents=True)
        (out / folder / "experiment.json").write_text(json.dumps(
            {"format": "contactnet-experiment-v1", "experiment": experiment,
             "trials": {r["key"]: r["fingerprint"] for r in records}}))
        (out / folder / "trials.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))
        header["sections"].append({"folder": folder, "experiment": experiment, "title": folder,
                                   "trials": len(records), "trials_full": 10 * len(records)})
    (out / "paper.json").write_text(json.dumps(header))


def test_the_frontier_report_has_its_curves_gap_targets_and_narrow_bars(tmp_path):
    _stored_frontier(tmp_path)
    md_path, html_path = write_report(tmp_path)
    md = md_path.read_text()
    assert md.startswith("# ContactNet beyond the paper: the frontier") and "## Fig. 5" not in md
    assert "## Beyond the paper: the frontier" in md and "**no upper bound**" in md
    assert "`contactnet experiment frontier --out DIR`" in md
    # one row per gait and n, a column per planner, ContactNet minus fixed with Newcombe's interval, the paired count
    assert ("| walk | 200 | 7 / 10 (70.0 %, 39.7-89.2) | 2 / 10 (20.0 %, 5.7-51.0) | 0 / 2 (0.0 %, 0.0-65.8) "
            "| +50.0 (+6.6 to +74.0) | 5 / 0 |") in md
    assert "| trot | 200 | 4 / 10 (40.0 %, 16.8-68.7) | 6 / 10 " in md and "| -20.0 (-52.8 to +20.6) | 0 / 2 |" in md
    assert "| ContactNet, walk, n = 200 | 7 / 10 (70.0 %, 39.7-89.2) | >= 90 % (goal) | (no) |" in md
    assert "| ContactNet >= fixed gait, walk, every n | at all 2 n | at every n | (yes) |" in md
    assert "| ContactNet >= fixed gait, trot, every n | behind at n = 200 | at every n | (no) |" in md
    assert "| walk | oracle | 2 / 4 (50.0 %, 15.0-85.0) | base tilted over: 2 | 150.000 | 150.000 |" in md
    assert "| 110 | 0.300 | 0.300 | 150.000 | - | - |" in md  # planner medians by n; trot ran at 200 only
    # narrow bars: the README's grid (3-7 cm x 12-24 cm) apart, then the 2 cm bars and the 27-30 cm gaps
    assert ("| walk | contactnet | 3 / 4 (75.0 %, 30.1-95.4) | 1 / 1 (100.0 %, 20.7-100.0) | 1 / 2 (50.0 %, 9.5-90.5) "
            "| 1 / 2 (50.0 %, 9.5-90.5) | base tilted over: 1 |") in md
    assert "| walk | fixed | 1 / 4 (25.0 %, 4.6-69.9) | 1 / 1 (100.0 %, 20.7-100.0) | 0 / 2 " in md
    for name in ("frontier", "frontier_narrow", "times"):
        assert (tmp_path / "report_plots" / f"{name}.png").stat().st_size > 5000
    html = html_path.read_text()
    _assert_self_contained(html)
    assert "<title>ContactNet beyond the paper: the frontier</title>" in html
    assert html.count("data:image/png;base64,") == 3


def test_the_paper_report_ends_with_the_frontier_and_a_paper_run_refuses_frontier(tmp_path):
    _stored_run(tmp_path)
    md = write_report(tmp_path)[0].read_text()
    assert md.index("## Table II") < md.index("## Beyond the paper: the frontier") < md.index("## Outcomes by reason")
    assert "*Not in this run (no stored trials of `frontier`).*" in md  # a run made before the frontier was planned
    with pytest.raises(ExperimentError, match="holds the paper's run"):
        run_paper(tmp_path, 0.1, sections=FRONTIER_SECTIONS, plan="frontier")


def test_frontier_options_errors_are_one_line(tmp_path, capsys):
    out = str(tmp_path / "x")
    for option, value in (("--noise", "0.01"), ("--mass-scale", "1.2"), ("--height", "0.02")):
        assert main(["experiment", "frontier", "--out", out, option, value]) == 2
        assert f"drop {option}" in capsys.readouterr().err  # the plan fixes the noise, the mismatch, the terrains
    assert main(["experiment", "frontier", "--out", out, "--trials", "3", "--scale", "0.1"]) == 2
    assert "--scale or --trials, not both" in capsys.readouterr().err
    assert main(["experiment", "paper", "--out", out, "--removed", "140"]) == 2  # the paper's plan stays fixed
    assert "drop --removed" in capsys.readouterr().err
    assert main(["experiment", "frontier", "--out", out, "--sections", "fig5"]) == 2  # not a section of its plan
    err = capsys.readouterr().err.strip()
    assert "no section 'fig5'" in err and "frontier, frontier_narrow" in err and len(err.splitlines()) == 1
    assert main(["experiment", "random", "--out", out, "--sections", "fig5"]) == 2
    assert "--sections" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["experiment", "paper", "--out", out, "--sections", "fig6"])
    assert "--sections: expected a comma-separated list of fig5, table2" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_a_tiny_frontier_run_writes_its_section_and_resumes(tmp_path, capsys):
    # The blind heuristic falls within a second or two at n = 200 and on 2 cm bars: two short PyBullet trials.
    out = tmp_path / "frontier"
    args = ["experiment", "frontier", "--out", str(out), "--trials", "1", "--gaits", "walk", "--planners",
            "heuristic", "--removed", "200", "--widths-cm", "2", "--gaps-cm", "30", "--workers", "1", "--quiet"]
    assert main(args) == 0
    assert "2 trials run of 2" in capsys.readouterr().out
    header = json.loads((out / "paper.json").read_text())
    assert header["plan"] == "frontier" and header["scale"] == 0.01
    assert [(s["folder"], s["trials"], s["trials_full"]) for s in header["sections"]] == [
        ("frontier", 1, 100), ("frontier_narrow", 1, 4)]
    assert header["runs"][0]["command"] == (f"contactnet experiment frontier --out {out} --trials 1 --gaits walk "
                                            "--planners heuristic --removed 200 --widths-cm 2 --gaps-cm 30 --workers 1")
    (field,) = [json.loads(line) for line in (out / "frontier" / "trials.jsonl").read_text().splitlines()]
    (bars,) = [json.loads(line) for line in (out / "frontier_narrow" / "trials.jsonl").read_text().splitlines()]
    assert field["key"] == "random/200/seed0/walk/heuristic/noise0" and not field["success"]
    assert bars["key"] == "narrow_stones_w2_g30/seed0/walk/heuristic/noise0.01" and not bars["success"]
    md = (out / "report.md").read_text()
    assert "## Beyond the paper: the frontier" in md and "| walk | 200 | 0 / 1 (0.0 %, 0.0-79.3) |" in md
    assert "### Narrow bars" in md and "| walk | heuristic | 0 / 1 (0.0 %, 0.0-79.3) | - | 0 / 1 " in md
    assert (out / "report_plots" / "frontier.png").stat().st_size > 5000
    assert main(args) == 0 and "0 trials run of 2" in capsys.readouterr().out  # resumed: nothing runs again
    assert len((out / "frontier" / "trials.jsonl").read_text().splitlines()) == 1
    # one section alone (a new gap on the bars): only its trial runs; the report keeps the field's stored trial
    field_log = (out / "frontier" / "trials.jsonl").read_text()
    alone = [*args[:args.index("--gaps-cm")], "--gaps-cm", "27", "--workers", "1", "--quiet",
             "--sections", "frontier_narrow"]
    assert main(alone) == 0 and "1 trials run of 1" in capsys.readouterr().out
    assert (out / "frontier" / "trials.jsonl").read_text() == field_log
    header = json.loads((out / "paper.json").read_text())
    assert [s["folder"] for s in header["sections"]] == ["frontier", "frontier_narrow"]
    assert header["runs"][-1]["sections"] == ["frontier_narrow"] and "--sections frontier_narrow" in header["runs"][-1]["command"]
    assert "| walk | 200 | 0 / 1 (0.0 %, 0.0-79.3) |" in (out / "report.md").read_text()
    # the paper's run may follow in the same folder (its plan holds the frontier); not the other way round
    assert json.loads((out / "paper.json").read_text())["runs"][1]["trials_reused"] == 2
