"""Issue 11, findings 3 and 8 (the batch-job half), replayed as a hostile tester did them (finding 7, model
files: tests/test_hostile_model_files.py):

- 3: ``contactnet experiment`` rerun into the same ``--out`` with other models printed the old result without
  running anything. Trials are now keyed on everything that determines a result.
- 8: datagen said "complete" over a truncated shard listed in its manifest, and train then failed.

The model files and shards are made in tmp dirs; the shipped models are read, never written.
"""

from __future__ import annotations

import dataclasses
import io
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

import contactnet.jobs.datagen as datagen
import contactnet.jobs.experiment as experiment
from contactnet.cli import EXIT_USER_ERROR, main
from contactnet.jobs.datagen import DatagenConfig, DatasetDirError, generate, shard_name
from contactnet.jobs.experiment import ExperimentError, Trial, run_experiment, trial_inputs
from contactnet.jobs.runner import code_identity, file_sha256
from contactnet.jobs.train import DatasetError, load_dataset
from contactnet.motion.gait import WALK
from contactnet.planning.network import ModelFileError, Normalizer, load_model
from contactnet.planning.network_torch import ContactNet, save_model
from contactnet.registry import model_path


# ---- helpers -------------------------------------------------------------------------------------
def _save_random(path: Path, seed: int = 0, gait: str = "walk") -> Path:
    torch.manual_seed(seed)
    n_actions = 100 if gait == "walk" else 162
    u = np.random.default_rng(seed).normal(size=(50, 14))
    return save_model(path, ContactNet(n_actions), Normalizer.fit(u), {"gait": gait})


# ---- finding 3: experiment resume keys ----------------------------------------------------------
def _fake_run_trial(calls: list):
    """A stand-in for the PyBullet trial: succeeds only with the shipped model (by content)."""
    shipped = load_model(model_path("solo12", "walk")).identity

    def run(trial: Trial) -> dict:
        calls.append(trial.key)
        used = load_model(model_path(trial.robot, trial.gait, Path(trial.model_dir))).identity
        ok = used == shipped
        return {"key": trial.key, "trial": dataclasses.asdict(trial), "time_limit_s": 1.0, "success": ok,
                "fell": not ok, "fall_reason": None if ok else "base low", "reached_x": 1.0, "steps": 3,
                "planner_ms": {"median": 0.1, "mean": 0.1}, "rank_chosen": {"mean": 0.0, "max": 0},
                "unsafe_landings": 0}

    return run


@pytest.fixture
def model_dirs(tmp_path) -> tuple[Path, Path]:
    right, other = tmp_path / "right", tmp_path / "other"
    right.mkdir()
    shutil.copyfile(model_path("solo12", "walk"), right / "walk.pt")
    _save_random(other / "walk.pt", seed=3)
    return right, other


def _experiment(out: Path, models: Path) -> int:
    return main(["experiment", "narrow_stones", "--planners", "contactnet", "--out", str(out), "--model-dir",
                 str(models), "--workers", "1", "--quiet"])


def _successes(out: Path) -> int:
    (row,) = json.loads((out / "summary.json").read_text())["rows"]
    return row["successes"]


def test_3_a_rerun_with_other_models_runs_again(model_dirs, tmp_path, monkeypatch, capsys):
    right, other = model_dirs
    calls: list = []
    monkeypatch.setattr(experiment, "run_trial", _fake_run_trial(calls))
    out = tmp_path / "out"
    assert _experiment(out, other) == 0 and calls == ["narrow_stones/seed0/walk/contactnet/noise0"]
    assert _successes(out) == 0
    capsys.readouterr()
    assert _experiment(out, right) == 0  # the finding: this printed the old result without running anything
    assert len(calls) == 2 and _successes(out) == 1
    err = capsys.readouterr().err
    assert "1 trial(s)" in err and "with other model" in err and "running them again" in err
    assert len(err.strip().splitlines()) == 1
    assert _experiment(out, right) == 0 and len(calls) == 2  # same inputs: reused
    assert _experiment(out, other) == 0 and len(calls) == 2 and _successes(out) == 0  # its own record again
    records = [json.loads(line) for line in (out / "trials.jsonl").read_text().splitlines()]
    assert len(records) == 2 and records[0]["fingerprint"] != records[1]["fingerprint"]
    assert records[1]["inputs"]["model"] == load_model(right / "walk.pt").identity
    header = json.loads((out / "experiment.json").read_text())
    assert header["experiment"] == "narrow_stones" and header["code"] == code_identity()
    assert header["trials"] == {records[0]["key"]: records[0]["fingerprint"]}


def test_3_the_key_covers_code_settings_and_old_logs(model_dirs, tmp_path, monkeypatch, capsys):
    right, _ = model_dirs
    calls: list = []
    monkeypatch.setattr(experiment, "run_trial", _fake_run_trial(calls))
    out = tmp_path / "out"
    trial = Trial("narrow_stones", "narrow_stones", None, 0, "walk", "contactnet", model_dir=str(right))
    run_experiment("narrow_stones", out, [trial], workers=1, progress=False)
    # A log written before this change: the same key, no fingerprint. Not reused.
    log = out / "trials.jsonl"
    record = json.loads(log.read_text())
    del record["fingerprint"], record["inputs"]
    log.write_text(json.dumps(record) + "\n")
    capsys.readouterr()
    run_experiment("narrow_stones", out, [trial], workers=1, progress=False)
    assert len(calls) == 2 and "logged before trials recorded their inputs" in capsys.readouterr().err
    # Another code, another vx (not in the trial's key): run again, saying why.
    monkeypatch.setattr(experiment, "code_identity", lambda: {**code_identity(), "sources": "0" * 64})
    run_experiment("narrow_stones", out, [trial], workers=1, progress=False)
    assert len(calls) == 3 and "with other code" in capsys.readouterr().err
    faster = dataclasses.replace(trial, vx=0.1)
    assert faster.key == trial.key
    run_experiment("narrow_stones", out, [faster], workers=1, progress=False)
    assert len(calls) == 4 and "with other settings" in capsys.readouterr().err
    # The model's path does not matter, its content does.
    moved = tmp_path / "moved"
    shutil.copytree(right, moved)
    run_experiment("narrow_stones", out, [dataclasses.replace(faster, model_dir=str(moved))], workers=1,
                   progress=False)
    assert len(calls) == 4 and capsys.readouterr().err == ""
    with pytest.raises(ExperimentError, match="holds the experiment 'narrow_stones', not 'stepping_stones'; use "
                                              "another --out"):
        run_experiment("stepping_stones", out, [trial], workers=1, progress=False)


def test_3_trial_inputs_name_everything_that_determines_a_result(model_dirs):
    right, other = model_dirs
    base = Trial("random", "random", 80, 3, "walk", "contactnet", model_dir=str(right))
    inputs = trial_inputs(base)
    assert set(inputs) == {"trial", "terrain", "gait", "model", "code", "sim"}
    assert inputs["trial"]["seed"] == 3 and "model_dir" not in inputs["trial"]
    assert inputs["sim"].startswith("pybullet ") and "sim" not in inputs["trial"]  # the engine and its version
    mujoco = dataclasses.replace(base, sim="mujoco")
    assert trial_inputs(mujoco)["sim"].startswith("mujoco ") and mujoco.key == base.key + "/mujoco"
    assert inputs["model"] == load_model(right / "walk.pt").identity
    assert inputs["code"] == code_identity() and len(inputs["code"]["sources"]) == 64
    assert trial_inputs(dataclasses.replace(base, model_dir=str(other)))["model"] != inputs["model"]
    assert trial_inputs(dataclasses.replace(base, seed=4))["terrain"] != inputs["terrain"]  # another field
    assert trial_inputs(dataclasses.replace(base, removed=50))["terrain"] != inputs["terrain"]
    assert trial_inputs(dataclasses.replace(base, gait="trot", model_dir=None))["gait"] != inputs["gait"]
    assert trial_inputs(dataclasses.replace(base, planner="heuristic"))["model"] is None
    with pytest.raises(ModelFileError, match="no such file"):
        trial_inputs(dataclasses.replace(base, model_dir=str(right.parent)))


@pytest.mark.slow
def test_3_real_trials_rerun_with_other_models(model_dirs, tmp_path):
    # The finding, in PyBullet: narrow_stones with a random network, then with the shipped one.
    right, other = model_dirs
    out = tmp_path / "out"
    trial = Trial("narrow_stones", "narrow_stones", None, 0, "walk", "contactnet", model_dir=str(other))
    first = run_experiment("narrow_stones", out, [trial], workers=1, progress=False)
    second = run_experiment("narrow_stones", out, [dataclasses.replace(trial, model_dir=str(right))], workers=1,
                            progress=False)
    records = [json.loads(line) for line in (out / "trials.jsonl").read_text().splitlines()]
    assert len(records) == 2  # the second run ran
    assert [r["inputs"]["model"] for r in records] == [load_model(p / "walk.pt").identity for p in (other, right)]
    assert second["rows"][0]["successes"] == int(records[1]["success"])
    assert first["rows"][0]["successes"] == int(records[0]["success"])


# ---- finding 8: datagen trusts a truncated shard -------------------------------------------------
TINY = DatagenConfig(gait="walk", episodes=3, instances_per_episode=4, episodes_per_shard=1, seed=5)


def _fake_shard_arrays(config: DatagenConfig, shard: int):
    """Stand-in for the PyBullet episodes: deterministic arrays per (seed, shard)."""
    rng = np.random.default_rng([config.seed, shard])
    n = config.instances_per_episode * len(config.shard_episodes(shard))
    u = rng.normal(size=(n, 14)).astype(np.float32)
    V = rng.uniform(0, 1, size=(n, WALK.n_choices)).astype(np.float32)
    return u, V, np.full(n, shard, dtype=np.int32), 0


@pytest.fixture
def fake_episodes(monkeypatch):
    monkeypatch.setattr(datagen, "shard_arrays", _fake_shard_arrays)


def test_8_resume_regenerates_a_truncated_shard_and_train_names_it(tmp_path, fake_episodes, capsys):
    out = tmp_path / "walk"
    manifest = generate(out, TINY, workers=1, progress=False)
    for name in manifest["shards"]:
        stats = manifest["shard_stats"][name]
        assert stats["bytes"] == (out / name).stat().st_size and stats["sha256"] == file_sha256(out / name)
    assert manifest["code"] == code_identity() and len(manifest["gait_spec"]) == 64
    shard = out / shard_name(1)
    good = shard.read_bytes()
    shard.write_bytes(good[: len(good) // 2])  # the finding: a truncated shard listed in the manifest
    with pytest.raises(DatasetError) as info:
        load_dataset(out)
    message = str(info.value)
    assert message.startswith(f"{shard}: not the shard datagen wrote: {len(good) // 2} bytes where {len(good)} "
                              "were written (truncated)") and "\n" not in message
    assert main(["train", "--gait", "walk", "--data", str(out), "--out", str(tmp_path / "m.pt"), "--epochs", "1",
                 "--quiet"]) == EXIT_USER_ERROR
    assert "shard-00001.npz: not the shard datagen wrote" in capsys.readouterr().err
    kept = {p.name: p.stat().st_mtime_ns for p in out.glob("shard-*.npz") if p != shard}
    again = generate(out, TINY, workers=1, progress=False)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "1 shard(s)" in err[0] and "shard-00001.npz" in err[0] and "truncated" in err[0]
    assert again["complete"] and shard.read_bytes() == good  # regenerated, the same data
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("shard-*.npz") if p != shard} == kept
    assert load_dataset(out).n_instances == 12


def test_8_a_shard_changed_in_place_is_caught_by_its_hash(tmp_path, fake_episodes, capsys):
    out = tmp_path / "walk"
    generate(out, TINY, workers=1, progress=False)
    shard = out / shard_name(2)
    data = bytearray(shard.read_bytes())
    data[len(data) // 2] ^= 0xFF  # same size
    shard.write_bytes(bytes(data))
    with pytest.raises(DatasetError, match=r"shard-00002\.npz: not the shard datagen wrote: sha256 .* \(changed\)"):
        load_dataset(out)
    capsys.readouterr()
    assert generate(out, TINY, workers=1, progress=False)["complete"]
    assert "shard-00002.npz: sha256" in capsys.readouterr().err
    load_dataset(out)


def test_8_resume_refuses_other_code_and_manifests_that_do_not_say(tmp_path, fake_episodes, monkeypatch):
    out = tmp_path / "walk"
    generate(out, dataclasses.replace(TINY, episodes=2), workers=1, progress=False)  # incomplete: 2 of 3
    manifest_path = out / "manifest.json"
    written = manifest_path.read_text()
    monkeypatch.setattr(datagen, "code_identity", lambda: {**code_identity(), "sources": "0" * 64})
    with pytest.raises(DatasetDirError) as info:
        generate(out, dataclasses.replace(TINY, episodes=2), workers=1, progress=False)
    assert str(info.value) == (f"{out} holds a dataset made with other code (sources differ); use another "
                               "--out, or the same code to resume")
    monkeypatch.undo()
    monkeypatch.setattr(datagen, "shard_arrays", _fake_shard_arrays)
    old = json.loads(written)
    del old["code"], old["gait_spec"]  # a manifest written before this change
    manifest_path.write_text(json.dumps(old))
    with pytest.raises(DatasetDirError, match="made before datasets recorded the code that made them; use "
                                              "another --out"):
        generate(out, dataclasses.replace(TINY, episodes=2), workers=1, progress=False)
    # train still reads an old dataset: it has no recorded sizes or hashes to check
    for stats in old["shard_stats"].values():
        del stats["bytes"], stats["sha256"]
    manifest_path.write_text(json.dumps(old))
    assert load_dataset(out).n_instances == 8


@pytest.mark.slow
def test_8_real_datagen_regenerates_a_truncated_shard_identically(tmp_path, capsys):
    config = DatagenConfig(gait="walk", episodes=2, instances_per_episode=3, episodes_per_shard=1, seed=11)
    out = tmp_path / "walk"
    generate(out, config, workers=1, progress=False)
    shard = out / shard_name(0)
    good = shard.read_bytes()
    shard.write_bytes(good[:100])
    capsys.readouterr()
    assert generate(out, config, workers=1, progress=False)["complete"]
    assert "shard-00000.npz" in capsys.readouterr().err
    with np.load(io.BytesIO(good)) as before, np.load(shard) as after:
        for key in ("u", "V", "episode"):
            np.testing.assert_array_equal(before[key], after[key])
    assert load_dataset(out).n_instances > 0
