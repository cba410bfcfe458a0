"""`contactnet experiment`: the trial list, one real trial in PyBullet, resuming, the summary and plot."""

from __future__ import annotations

import csv
import dataclasses
import json

import numpy as np
import pytest

from contactnet.jobs.experiment import (
    ExperimentError,
    Trial,
    run_experiment,
    run_trial,
    trial_inputs,
    trials_of,
)
from contactnet.jobs.summary import format_summary, plot_success, summarize


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


def test_the_robot_is_in_the_key_only_when_it_is_not_solo12():
    # Logs written before trials had a robot must still resume: a Solo12 trial keeps its old key.
    (solo,) = trials_of("stepping_stones", planners=("contactnet",))
    assert solo.robot == "solo12" and solo.key == "stepping_stones/seed0/walk/contactnet/noise0"
    (go2,) = trials_of("stepping_stones", planners=("contactnet",), robot="go2")
    assert go2.robot == "go2" and go2.key == "stepping_stones/seed0/walk/contactnet/noise0/go2"
    assert {t.robot for t in trials_of("narrow_map", robot="go2") + trials_of("random", robot="go2")} == {"go2"}
    random = trials_of("random", trials=1, gaits=("walk",), planners=("fixed",), removed=(50,))
    assert random[0].key == "random/50/seed0/walk/fixed/noise0"


def test_the_stacks_parts_are_in_the_key_and_the_inputs_only_when_on():
    def one(**parts):  # noqa: ANN003, ANN202
        (trial,) = trials_of("stepping_stones", gaits=("walk",), planners=("heuristic",), **parts)
        return trial

    plain, no_observer, retarget, both = one(), one(observer=False), one(retarget=True), one(observer=False,
                                                                                              retarget=True)
    assert (plain.observer, plain.retarget, both.observer, both.retarget) == (True, False, False, True)  # defaults
    assert plain.key == "stepping_stones/seed0/walk/heuristic/noise0"  # the default stack: as before either part
    assert (no_observer.key, retarget.key, both.key) == tuple(plain.key + s for s in
                                                             ("/no-observer", "/retarget", "/no-observer/retarget"))
    assert "retarget" not in trial_inputs(plain)["trial"] and "observer" not in trial_inputs(plain)["trial"]
    assert trial_inputs(retarget)["trial"]["retarget"] is True
    assert trial_inputs(no_observer)["trial"]["observer"] is False
    crouched = one(crouch_m=0.03)
    assert crouched.key == plain.key + "/crouch0.03" and trial_inputs(crouched)["trial"]["crouch_m"] == 0.03
    assert "crouch_m" not in trial_inputs(plain)["trial"]  # the robot's default: as before the option existed
    assert one(crouch_m=0.0).key == plain.key + "/crouch0"  # the nominal height, asked for: not the default
    unheld = one(foot_hold=False)
    assert plain.foot_hold and unheld.key == plain.key + "/no-foot-hold"
    assert trial_inputs(unheld)["trial"]["foot_hold"] is False
    assert "foot_hold" not in trial_inputs(plain)["trial"]  # on, the default: named only when off


def test_each_engine_runs_the_same_trials_and_the_summary_puts_them_side_by_side():
    both = trials_of("random", trials=2, gaits=("walk",), planners=("contactnet",), sims=("pybullet", "mujoco"))
    pybullet = [t for t in both if t.sim == "pybullet"]
    mujoco = [t for t in both if t.sim == "mujoco"]
    assert len(pybullet) == len(mujoco) == 2 and len({t.key for t in both}) == 4
    assert [dataclasses.replace(t, sim="pybullet") for t in mujoco] == pybullet  # same seeds, terrains, everything
    assert all(t.key.endswith("/mujoco") for t in mujoco) and not any("mujoco" in t.key for t in pybullet)
    with pytest.raises(ValueError, match="unknown physics engine"):
        trials_of("random", sims=("bullet",))
    records = [{**record("walk", "contactnet", t.seed, t.sim == "pybullet" or t.seed == 0), "key": t.key,
                "trial": {**record("walk", "contactnet", t.seed, True)["trial"], "sim": t.sim}} for t in both]
    rows = summarize("random", records)["rows"]
    assert sorted((r["sim"], r["successes"]) for r in rows) == [("mujoco", 1), ("pybullet", 2)]
    assert "mujoco" in format_summary(summarize("random", records))


def test_a_trial_s_scene_is_at_its_robot_s_size_unless_scaled():
    from contactnet.jobs.experiment import _terrain

    (solo,) = trials_of("stepping_stones", planners=("contactnet",))
    assert "scale" not in trial_inputs(solo)["trial"]  # Solo12's trials resume as before
    (scaled,) = trials_of("stepping_stones", planners=("contactnet",), scale=1.2)
    assert scaled.key == solo.key + "/x1.2" and trial_inputs(scaled)["terrain"] != trial_inputs(solo)["terrain"]
    base = _terrain("stepping_stones", None, 0, None, None)
    go2 = _terrain("stepping_stones", None, 0, None, None, robot="go2")
    assert 1.2 < go2.goal_x / base.goal_x < 1.4


def test_the_terrains_with_heights_have_their_experiments():
    stairs = trials_of("stairs", planners=("contactnet",))
    assert [(t.terrain, t.gait, t.seed, t.height_m) for t in stairs] == [("stairs", "walk", 0, None),
                                                                       ("stairs", "trot", 0, None)]
    raised = trials_of("raised_stones", gaits=("walk",), planners=("contactnet",), noise=0.01)
    assert [t.seed for t in raised] == [0, 1, 2, 3, 4] and {t.noise for t in raised} == {0.01}
    assert raised[1].key == "raised_stones/seed1/walk/contactnet/noise0.01"
    fields = trials_of("random_heights", planners=("contactnet",), height_m=0.04)
    assert len(fields) == 2 * 20 and {(t.removed, t.height_m) for t in fields} == {(80, 0.04)}
    assert fields[0].key == "random_heights/80/h0.04/seed0/walk/contactnet/noise0"
    # every trial's terrain is the one its seed names, with heights (seed 0 of raised_stones: the shipped file)
    from contactnet.jobs.experiment import _terrain
    from contactnet.terrain import resolve

    field = _terrain("random_heights", 80, 3, None, None, 0.04)
    assert field.to_dict() == resolve("random_heights", removed=80, seed=3, height_m=0.04).to_dict()
    tops = {region["z"] for region in field.regions if "z" in region}
    assert len(tops) > 10 and max(abs(z - field.surface_z) for z in tops) <= 0.04 + 1e-9
    for seed in (0, 1, 4):  # the scenes' seed is the noise's: the shipped stones every time
        assert _terrain("raised_stones", None, seed, None, None).to_dict() == resolve("raised_stones").to_dict()
    assert resolve("raised_stones", seed=1).to_dict() != resolve("raised_stones").to_dict()  # simulate --seed 1


def test_narrow_map_trials_cover_the_grid():
    trials = trials_of("narrow_map", widths_cm=(4.0, 5.5), gaps_cm=(18.0,), noise=0.01, trials=2)
    assert len(trials) == 2 * 1 * 2 * 2  # widths x gaps x (contactnet, fixed) x seeds
    assert {t.planner for t in trials} == {"contactnet", "fixed"} and {t.gait for t in trials} == {"walk"}
    assert {(t.terrain, t.bar_width_m, t.last_gap_m) for t in trials} == {
        ("narrow_stones_w4_g18", 0.04, 0.18), ("narrow_stones_w5.5_g18", 0.055, 0.18)}
    assert len({t.key for t in trials}) == len(trials)
    assert len(trials_of("narrow_map")) == 5 * 5 * 2  # the default 3-7 cm x 12-24 cm grid, one seed


def record(gait, planner, seed, success, rank=1.0, **scene):
    return {"key": f"{gait}{planner}{seed}{scene}", "trial": {"gait": gait, "planner": planner, "removed": 80,
                                                              "noise": 0.0, "seed": seed, **scene},
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


def test_narrow_map_summary_table_and_success_maps(tmp_path):
    records = [record("walk", planner, seed, planner == "contactnet" or width < 0.05, removed=None,
                      bar_width_m=width, last_gap_m=gap)
               for planner in ("contactnet", "fixed") for width in (0.04, 0.06) for gap in (0.12, 0.21)
               for seed in range(2)]
    summary = summarize("narrow_map", records)
    cells = {(r["planner"], r["bar_width_m"], r["last_gap_m"]): r for r in summary["rows"]}
    assert len(cells) == 8 and all(r["trials"] == 2 for r in cells.values())
    assert cells["fixed", 0.06, 0.21]["successes"] == 0 and cells["fixed", 0.04, 0.12]["successes"] == 2
    table = format_summary(summary)
    assert "bar_width_m" in table and "last_gap_m" in table and "removed" not in table
    plot_success(summary, tmp_path / "map.png")
    assert (tmp_path / "map.png").stat().st_size > 5000


@pytest.mark.slow
@pytest.mark.parametrize("planner, crosses", [("contactnet", True), ("fixed", False)])
def test_narrow_stones_needs_the_acyclic_gait(planner, crosses):
    # The paper's Fig. 6 with the shipped walk model: choosing the leg as well as the foothold crosses the
    # narrow bars; the same network held to the cyclic leg order (swing in place when the leg has no safe
    # cell) falls.
    result = run_trial(Trial("narrow_stones", "narrow_stones", None, 0, "walk", planner))
    assert result["success"] is crosses and result["fell"] is not crosses
    if planner == "contactnet":  # (the fixed gait's last swing in place is on a foot that crept off the bar)
        assert result["unsafe_landings"] == 0 and result["rank_chosen"]["max"] > 0


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


def test_push_trials_are_sampled_moments_and_directions_paired_across_cells():
    from contactnet.jobs.pushes import IMPULSE_DURATION_S, push_window_s

    trials = trials_of("push")
    assert len(trials) == 2 * 10  # walk and trot, 10 pushes of 5 N each
    assert {t.terrain for t in trials} == {"push_field"} and {t.planner for t in trials} == {"contactnet"}
    assert len({t.key for t in trials}) == len(trials)
    low, high = push_window_s(0.05)
    assert (low, high) == (2.0, 55.0)  # the 3 m walk takes 60 s; the trial ends 5 s after the push starts
    walk = [t for t in trials if t.gait == "walk"]
    assert all(low <= t.push_t0_s <= high for t in walk)
    assert {round(abs(complex(*t.push_force_xy)), 3) for t in trials} == {5.0}
    angles = np.degrees(np.angle([complex(*t.push_force_xy) for t in walk]))
    assert len({int((a % 360) // 90) for a in angles}) >= 3  # directions spread over the circle, not the axes
    # The same moments and directions for every gait and magnitude (paired cells), a prefix for fewer trials.
    trot = [t for t in trials if t.gait == "trot"]
    assert [(t.push_t0_s, t.push_force_xy) for t in walk] == [(t.push_t0_s, t.push_force_xy) for t in trot]
    several = trials_of("push", trials=4, gaits=("walk",), forces_n=(5.0, 10.0), impulses_ns=(1.25,))
    assert len(several) == 3 * 4
    sustained = [t for t in several if t.push_duration_s == 1.0]
    impulses = [t for t in several if t.push_duration_s == IMPULSE_DURATION_S]
    assert {round(abs(complex(*t.push_force_xy)), 3) for t in sustained} == {5.0, 10.0}
    assert {round(abs(complex(*t.push_force_xy)), 3) for t in impulses} == {12.5}  # 1.25 N s over 0.1 s
    assert [t.push_t0_s for t in impulses] == [t.push_t0_s for t in walk[:4]]
    assert "x0.1s" in impulses[0].key and "x" not in sustained[0].key.split("/")[1].split("@")[1]
    other_seed = trials_of("push", trials=4, gaits=("walk",), push_seed=1)
    assert [t.push_t0_s for t in other_seed] != [t.push_t0_s for t in walk[:4]]


def test_push_summary_gives_intervals_velocity_change_and_fall_reasons(tmp_path):
    from test_paper import _record

    from contactnet.jobs.pushes import by_sector, plot_polar

    def record(k, angle_deg, duration, force, success):
        fx, fy = force * np.cos(np.radians(angle_deg)), force * np.sin(np.radians(angle_deg))
        trial = {"gait": "walk", "planner": "contactnet", "terrain": "push_field", "removed": None, "noise": 0.0,
                 "seed": k, "push_force_xy": [fx, fy], "push_t0_s": 5.0 + k, "push_duration_s": duration}
        out = _record(f"push_field/p{k}@{duration}/{force}", trial, success)
        out["robot_mass_kg"] = 2.5
        if not success:
            out["fell"], out["fall_reason"] = True, "base tilted (roll -0.90, pitch 0.18 rad)"
        return out

    records = [record(k, 45.0 * k, 1.0, 5.0, k != 2) for k in range(8)]
    records += [record(k, 10.0 + 45.0 * k, 0.1, 12.5, True) for k in range(8)]
    rows = {r["push_duration_s"]: r for r in summarize("push", records)["rows"]}
    sustained, impulse = rows[1.0], rows[0.1]
    assert (sustained["successes"], sustained["trials"], sustained["push_kind"]) == (7, 8, "force")
    assert 0.5 < sustained["success_low"] < 0.875 < sustained["success_high"] <= 1.0
    assert sustained["fall_reasons"] == {"base tilted over": 1}
    assert (impulse["push_kind"], impulse["push_ns"], impulse["push_dv_m_s"]) == ("impulse", 1.25, 0.5)
    assert sustained["push_dv_m_s"] == 2.0
    assert by_sector(records[:8]) == [(1, 1), (1, 1), (0, 1), (1, 1), (1, 1), (1, 1), (1, 1), (1, 1)]
    plot_polar(records, tmp_path / "polar.png")
    assert (tmp_path / "polar.png").stat().st_size > 10_000
    table = format_summary(summarize("push", records))
    assert "push_dv_m_s" in table and "success_low" in table


def test_robustness_trials_are_each_mismatch_on_the_field_and_the_stones():
    from contactnet.jobs.experiment import ROBUSTNESS_CASES
    from contactnet.sim.mismatch import ModelMismatch

    trials = trials_of("robustness", trials=3, gaits=("walk",))
    assert {t.mismatch for t in trials} == set(ROBUSTNESS_CASES)
    for case in ROBUSTNESS_CASES:
        mine = [t for t in trials if t.mismatch == case]
        field = [t for t in mine if t.terrain == "random"]
        stones = [t for t in mine if t.terrain == "stepping_stones"]
        assert [t.seed for t in field] == [0, 1, 2] and {t.removed for t in field} == {80}
        assert len(stones) == (3 if case.sensor_noise else 1)
    assert len({t.key for t in trials}) == len(trials)
    heavy = ModelMismatch(mass_scale=1.2)
    one = trials_of("robustness", trials=2, gaits=("trot",), mismatch=heavy)
    assert {t.mismatch for t in one} == {heavy} and one[0].key.endswith("/mass1.2")
    assert {t.mismatch for t in trials_of("random", trials=2, mismatch=heavy)} == {heavy}


def test_a_push_trial_succeeds_when_the_robot_stands_the_push(tmp_path):
    """Success on ``push`` is "no fall by PUSH_SETTLE_S after the push", not the goal (3 m away)."""
    gentle = Trial("push", "push_field", None, 0, "walk", "contactnet", push_t0_s=0.2, push_force_xy=(0.5, 0.0))
    hard = Trial("push", "push_field", None, 1, "walk", "contactnet", push_t0_s=0.2, push_force_xy=(0.0, 150.0))
    summary = run_experiment("push", tmp_path, [gentle, hard], workers=1, progress=False)
    records = {json.loads(line)["key"]: json.loads(line) for line in (tmp_path / "trials.jsonl").read_text().splitlines()}
    assert records[gentle.key]["success"] and not records[gentle.key]["fell"]
    assert records[gentle.key]["sim_time_s"] == pytest.approx(0.2 + 1.0 + 4.0, abs=0.01)
    assert not records[hard.key]["success"] and records[hard.key]["fell"]
    rows = {row["push_n"]: row for row in summary["rows"]}
    assert rows[0.5]["successes"] == 1 and rows[150.0]["falls"] == 1
    assert rows[150.0]["failed_pushes"] == ["push0,150@0.2"]
    assert "push_n" in format_summary(summary)


def test_a_stored_trial_is_rebuilt_exactly_and_a_missing_one_is_named(tmp_path):
    """``trial_from_record`` inverts the record's JSON (tuples, the mismatch); ``find_record`` finds a trial in a
    folder or a paper run's section folders, and names the folder and key it cannot find."""
    from dataclasses import asdict

    from contactnet.jobs.replay import find_record, trial_from_record
    from contactnet.sim.mismatch import ModelMismatch

    trial = Trial("push", "push_field", None, 3, "trot", "contactnet", push_t0_s=4.5, push_force_xy=(1.5, -2.0),
                  mismatch=ModelMismatch(payload_kg=0.3, payload_offset_xy_m=(0.02, -0.01), friction=0.6),
                  observer=True)
    record = json.loads(json.dumps({"key": trial.key, "trial": asdict(trial), "success": True}))
    assert trial_from_record(record) == trial
    section = tmp_path / "push"
    section.mkdir()
    (section / "trials.jsonl").write_text(json.dumps(record) + "\n")
    assert find_record(tmp_path, trial.key) == record  # a paper run: DIR/<section>/trials.jsonl
    assert find_record(section, trial.key) == record
    with pytest.raises(ExperimentError, match="no trial 'nope'"):
        find_record(section, "nope")
    with pytest.raises(ExperimentError, match="no trials.jsonl"):
        find_record(tmp_path / "empty", trial.key)
    bad = {**record, "trial": {**record["trial"], "warp_drive": 1}}
    with pytest.raises(ExperimentError, match="warp_drive"):
        trial_from_record(bad)


@pytest.mark.slow
def test_replay_runs_a_stored_trial_again_with_the_same_outcome(tmp_path, capsys):
    """`contactnet replay DIR KEY` runs a logged trial again (here a fall under a hard push with a payload):
    on the same code, the same outcome at the same place."""
    from contactnet.cli import main
    from contactnet.sim.mismatch import ModelMismatch

    hard = Trial("push", "push_field", None, 1, "walk", "contactnet", push_t0_s=0.2, push_force_xy=(0.0, 150.0),
                 mismatch=ModelMismatch(payload_kg=0.2, payload_offset_xy_m=(0.03, 0.0)))
    run_experiment("push", tmp_path, [hard], workers=1, progress=False)
    stored = json.loads((tmp_path / "trials.jsonl").read_text().splitlines()[0])
    assert main(["replay", str(tmp_path), hard.key, "--json"]) == 0
    both = json.loads(capsys.readouterr().out)
    assert both["stored"]["fall_reason"] == stored["fall_reason"]
    assert both["now"]["fell"] and both["now"]["fall_reason"] == stored["fall_reason"]
    assert both["now"]["reached_x"] == pytest.approx(stored["reached_x"], abs=1e-9)
    assert main(["replay", str(tmp_path), hard.key]) == 0
    text = capsys.readouterr().out
    assert text.count("fell: ") == 2 and hard.key in text
    trace = tmp_path / "fall.csv"  # traced: the same fall, and the trace ends where the run fell, the push on
    assert main(["replay", str(tmp_path), hard.key, "--json", "--trace", str(trace), "--trace-every-ms", "5"]) == 0
    traced = json.loads(capsys.readouterr().out)["now"]
    assert traced["fall_reason"] == stored["fall_reason"] and traced["reached_x"] == stored["reached_x"]
    with trace.open() as handle:
        rows = list(csv.DictReader(handle))
    assert float(rows[-1]["t_s"]) == pytest.approx(traced["sim_time_s"])
    assert {float(r["push_fy_n"]) for r in rows if 0.21 <= float(r["t_s"]) <= traced["sim_time_s"]} == {150.0}
    assert main(["replay", str(tmp_path), "push_field/none"]) != 0
    assert "no trial 'push_field/none'" in capsys.readouterr().err
