"""The command line: working subcommands work, user mistakes get one line and exit code 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from contactnet.cli import EXIT_USER_ERROR, main

REPO = Path(__file__).resolve().parent.parent


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "contactnet", *args], capture_output=True, text=True, cwd=REPO, timeout=600
    )


def test_terrain_check_prints_a_summary():
    result = run_cli("terrain", "check", "terrains/stepping_stones.json")
    assert result.returncode == 0, result.stderr
    assert "stepping_stones" in result.stdout


def test_terrain_check_by_name_and_random(capsys):
    assert main(["terrain", "check", "flat"]) == 0
    assert main(["terrain", "check", "random", "--removed", "80", "--seed", "3"]) == 0
    assert "random_80_3" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        ("{not json", "JSON"),
        ('{"name": "x", "start": [0, 0], "goal_x": 1}', "regions"),
        ('{"name": "x", "start": [0, 0], "goal_x": 1, "regions": [{"shape": "blob"}]}', "blob"),
    ],
)
def test_malformed_terrain_is_one_line_and_exit_2(tmp_path, content, needle):
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    result = run_cli("terrain", "check", str(bad))
    assert result.returncode == EXIT_USER_ERROR
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr and "bad.json" in lines[0] and needle in lines[0]
    assert bad.read_text() == content  # nothing touched


def test_unknown_terrain_name_is_a_user_error(capsys):
    assert main(["terrain", "check", "no_such_terrain"]) == EXIT_USER_ERROR
    assert "no_such_terrain" in capsys.readouterr().err


def test_terrain_render_writes_a_png(tmp_path):
    out = tmp_path / "stones.png"
    assert main(["terrain", "render", "stepping_stones", "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_terrain_save_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["terrain", "save", "random", "--removed", "10", "--out", str(out)]) == 0
    before = out.read_text()
    assert main(["terrain", "save", "flat", "--out", str(out)]) == EXIT_USER_ERROR
    assert out.read_text() == before
    assert "exists" in capsys.readouterr().err


@pytest.mark.parametrize(
    "args",
    [
        ["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic", "--vx", "5"],
        ["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic", "--duration", "-1"],
        ["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic", "--vx", "nan"],
        ["simulate", "--terrain", "flat", "--gait", "gallop", "--planner", "heuristic"],
        ["bench", "everything"],
        ["experiment", "random", "--sim", "pybullet,bullet"],
    ],
)
def test_bad_options_exit_2(args, capsys):
    with pytest.raises(SystemExit) as exc:
        main(args)
    assert exc.value.code == EXIT_USER_ERROR
    assert "Traceback" not in capsys.readouterr().err


def test_the_paper_runs_in_one_engine(tmp_path, capsys):
    out = tmp_path / "paper"
    assert main(["experiment", "paper", "--sim", "pybullet,mujoco", "--out", str(out)]) == EXIT_USER_ERROR
    assert "one engine" in capsys.readouterr().err and not out.exists()


@pytest.mark.slow
def test_bench_sim_json():
    result = run_cli("bench", "sim", "--json", "--runs", "1")  # one run per row (the default's rows, 5 and 3 runs)
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["benchmark"] == "sim"
    rows = {row["name"]: row for row in report["rows"]}
    from contactnet.registry import model_path

    shipped = [gait for gait in ("walk", "trot") if model_path("solo12", gait).exists()]
    # 5 standing (3 PyBullet, 2 MuJoCo), 2 heuristic whole-stack cases and 1 per shipped model, each in both engines
    assert len(rows) == 5 + 2 * (2 + len(shipped))
    for gait in shipped:
        assert f"solo12 whole stack: {gait} 0.05 m/s on stepping_stones, contactnet planner" in rows
        assert rows[f"solo12 whole stack in MuJoCo: {gait} 0.05 m/s on stepping_stones, contactnet planner"][
            "vs_pybullet"] > 0
    for row in rows.values():
        assert row["median_rtf"] > 0 and row["fell"] is False and row["runs"] == 1


@pytest.mark.parametrize("args, needle", [(["planner", "--runs", "1"], "--runs is an option of bench sim"),
                                          (["sim", "--sessions", "2"], "--sessions is an option of bench live")])
def test_bench_options_of_another_benchmark_are_one_line(args, needle, capsys):
    assert main(["bench", *args]) == EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1, err


def test_bad_push_is_a_user_error(capsys):
    args = ["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic", "--push", "1,2"]
    assert main(args) == EXIT_USER_ERROR
    assert "--push" in capsys.readouterr().err


@pytest.mark.parametrize("option, value, needle", [
    ("--mass-scale", "0", "--mass-scale"), ("--friction", "nan", "--friction"), ("--delay-ms", "500", "--delay-ms"),
    ("--payload", "1,2", "--payload"), ("--payload", "0.5,0.1,9", "payload_offset_xy_m"),
    ("--payload", "heavy", "--payload"), ("--torque-scale", "-1", "--torque-scale"),
])
def test_bad_model_mismatch_is_one_line_naming_the_option(option, value, needle, capsys):
    args = ["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic", "--duration", "0.2",
            option, value]
    try:
        code = main(args)
    except SystemExit as exc:  # argparse's own check
        code = exc.code
    assert code == EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert needle in err.strip().splitlines()[-1] and "Traceback" not in err  # the last line says what is wrong


def test_simulate_with_a_model_mismatch_walks_and_prints_json():
    result = run_cli("simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic", "--duration", "2",
                     "--mass-scale", "1.1", "--payload", "0.3,0.02,0", "--friction", "0.7", "--torque-scale", "0.9",
                     "--orientation-noise", "0.005", "--velocity-noise", "0.02", "--gyro-noise", "0.02",
                     "--delay-ms", "2", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert not report["fell"] and report["steps"] >= 2


def test_train_and_datagen_bad_paths_are_user_errors(tmp_path, capsys):
    missing = tmp_path / "no_dataset"
    assert main(["train", "--gait", "walk", "--data", str(missing), "--out", str(tmp_path / "m.pt")]) == EXIT_USER_ERROR
    assert "no_dataset" in capsys.readouterr().err
    a_file = tmp_path / "taken"
    a_file.write_text("x")
    assert main(["datagen", "--gait", "walk", "--episodes", "1", "--out", str(a_file)]) == EXIT_USER_ERROR
    assert "taken" in capsys.readouterr().err
    assert a_file.read_text() == "x"


@pytest.mark.parametrize("planner", ["contactnet", "fixed"])
def test_simulate_with_a_missing_or_broken_model_names_the_file(planner, tmp_path, capsys):
    missing = tmp_path / "nope.pt"
    args = ["simulate", "--terrain", "flat", "--gait", "walk", "--planner", planner, "--model", str(missing)]
    assert main(args) == EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert "nope.pt" in err and "no such file" in err and "Traceback" not in err
    broken = tmp_path / "walk.pt"
    broken.write_text("{ not a model")
    assert main(args[:-1] + [str(broken)]) == EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert "walk.pt" in err and "Traceback" not in err


@pytest.mark.parametrize(
    "args, message",
    [
        (["experiment", "moon", "--out", "x"], "invalid choice"),
        (["experiment", "random", "--out", "x", "--removed", "400"], "0..300"),
        (["experiment", "random", "--out", "x", "--gaits", "gallop"], "--gaits"),
        (["experiment", "random", "--out", "x", "--planners", "contactnet,magic"], "--planners"),
        (["experiment", "narrow_map", "--out", "x", "--widths-cm", "4,wide"], "--widths-cm"),
        (["experiment", "narrow_map", "--out", "x", "--gaps-cm", "12,99"], "[0, 40]"),
        (["experiment", "push", "--out", "x", "--impulse", "0"], "--impulse"),
        (["experiment", "push", "--out", "x", "--force", "150"], "--force"),
        (["experiment", "push", "--out", "x", "--push-seed", "-3"], "--push-seed"),
        (["experiment", "push", "--out", "x", "--crouch=-0.01"], "--crouch"),
    ],
)
def test_experiment_argument_errors(args, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(args)
    assert exc.value.code == EXIT_USER_ERROR
    assert message in capsys.readouterr().err


def test_every_experiment_is_a_choice_of_the_command_line():
    """The command line lists the experiments by hand (importing the jobs would slow every command's start):
    stone_grid was once left out."""
    from contactnet.cli import build_parser
    from contactnet.jobs.experiment import EXPERIMENTS

    sub = next(a for a in build_parser()._actions if a.dest == "command" or getattr(a, "choices", None)
               and "experiment" in a.choices)
    choices = next(a.choices for a in sub.choices["experiment"]._actions if a.dest == "name")
    assert set(choices) == {*EXPERIMENTS, "paper", "frontier"}


@pytest.mark.parametrize("command", [["experiment", "push"], ["simulate", "--terrain", "flat", "--gait", "walk",
                                                                  "--planner", "heuristic", "--duration", "1"]])
def test_a_crouch_too_deep_for_the_robot_is_one_line_before_running(command, tmp_path, capsys):
    code = main([*command, "--crouch", "0.1", *(["--out", str(tmp_path / "out")] if command[0] == "experiment" else [])])
    assert code == EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert "--crouch: crouch 0.1 m is more than a third of solo12's nominal CoM height" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "out").exists()


def test_experiment_with_a_missing_model_dir_fails_before_running(tmp_path, capsys):
    code = main(["experiment", "narrow_stones", "--out", str(tmp_path / "out"), "--model-dir", str(tmp_path / "no")])
    assert code == EXIT_USER_ERROR
    assert "--model-dir" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
@pytest.mark.parametrize("gait", ["walk", "trot"])
def test_simulate_contactnet_uses_the_shipped_model(gait):
    from contactnet.registry import model_path

    result = run_cli("simulate", "--terrain", "stepping_stones", "--gait", gait, "--planner", "contactnet",
                     "--duration", "3", "--json")
    if not model_path("solo12", gait).exists():  # not shipped yet: a one-line error naming the file
        assert result.returncode == EXIT_USER_ERROR
        assert f"{gait}.pt" in result.stderr and "Traceback" not in result.stderr
        return
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    # every step horizon a step or a stand (a model with the stand choice stands at times: contactnet.planning.stand)
    assert not report["fell"] and report["steps"] + report["stand_steps"] >= 8 and report["steps"] >= 3
    assert report["unsafe_landings"] == 0
    assert report["reached_x"] > 0.05 and report["planner_ms"]["median"] < 50
