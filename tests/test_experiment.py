"""`contactnet experiment`: the trial list, one real trial in PyBullet, resuming, the summary and plot."""

from __future__ import annotations

import json

import pytest

from contactnet.experiment import ExperimentError, Trial, run_experiment, summarize, trials_of


def test_trials_of_defaults_and_errors():
    random = trials_of("random")
    assert len(random) == 2 * 3 * 20  # walk and trot, contactnet / fixed / heuristic, 20 seeds
    assert {t.removed for t in random} == {80} and {t.seed for t in random} == set(range(20))
    assert len({t.key for t in random}) == len(random)
    stones = trials_of("stepping_stones", planners=("contactnet",))
    assert [(t.terrain, t.gait, t.planner, t.seed) for t in stones] == [("stepping_stones", "walk", "contactnet", 0)]
    assert len(trials_of("random", trials=3, gaits=("walk",), planners=("fixed",), removed=(50, 100))) == 6
    with pytest.raises(ExperimentError, match="unknown experiment"):
        trials_of("moon")


def record(gait, planner, seed, success, rank=1.0):
    return {"key": f"{gait}{planner}{seed}", "trial": {"gait": gait, "planner": planner, "removed": 80,
                                                      "noise": 0.0, "seed": seed},
            "success": success, "fell": not success, "reached_x": 1.0, "steps": 10,
            "planner_ms": {"median": 0.1, "mean": 0.2}, "rank_chosen": {"mean": rank, "max": 3},
            "unsafe_landings": 0}


def test_summarize_counts_per_group():
    rows = summarize("random", [record("walk", "contactnet", s, s != 2) for s in range(4)]
                     + [record("walk", "fixed", s, s == 0) for s in range(4)])["rows"]
    by_planner = {r["planner"]: r for r in rows}
    assert by_planner["contactnet"]["successes"] == 3 and by_planner["contactnet"]["success_rate"] == 0.75
    assert by_planner["contactnet"]["failed_seeds"] == [2]
    assert by_planner["fixed"]["falls"] == 3


@pytest.mark.slow
def test_a_real_trial_is_logged_summarized_and_not_rerun(tmp_path):
    # The blind heuristic planner falls into the first gap of narrow_stones within a couple of seconds.
    trials = [Trial("narrow_stones", "narrow_stones", None, 0, "walk", "heuristic")]
    summary = run_experiment("narrow_stones", tmp_path, trials, workers=1, progress=False)
    (row,) = summary["rows"]
    assert row["trials"] == 1 and row["successes"] == 0 and row["falls"] == 1
    log = (tmp_path / "trials.jsonl").read_text().splitlines()
    assert len(log) == 1 and json.loads(log[0])["fall_reason"]
    assert (tmp_path / "success.png").stat().st_size > 1000
    assert json.loads((tmp_path / "summary.json").read_text())["rows"][0]["falls"] == 1
    # Resume: nothing to do, the log is not touched; a line cut by a kill is dropped and rerun.
    run_experiment("narrow_stones", tmp_path, trials, workers=1, progress=False)
    assert (tmp_path / "trials.jsonl").read_text().splitlines() == log
    (tmp_path / "trials.jsonl").write_text(log[0][: len(log[0]) // 2])
    again = run_experiment("narrow_stones", tmp_path, trials, workers=1, progress=False)
    assert again["rows"][0]["falls"] == 1
    lines = (tmp_path / "trials.jsonl").read_text().splitlines()
    assert json.loads(lines[-1])["key"] == trials[0].key
