"""Issue 11, findings 3, 7 and 8 (the batch-job half), replayed as a hostile tester did them:

- 3: ``contactnet experiment`` rerun into the same ``--out`` with other models printed the old result without
  running anything. Trials are now keyed on everything that determines a result.
- 7: a 204 KB model file declaring hidden sizes 20000 x 20000 reached 1.96 GB before being refused; flipped
  bytes in the weights (3,999 of 16,384 weights changed) loaded silently.
- 8: datagen said "complete" over a truncated shard listed in its manifest, and train then failed.

The model files and shards are made in tmp dirs; the shipped models are read, never written.
"""

from __future__ import annotations

import collections
import dataclasses
import io
import json
import pickle
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch

import contactnet.datagen as datagen
import contactnet.experiment as experiment
from contactnet.cli import EXIT_USER_ERROR, main
from contactnet.datagen import DatagenConfig, DatasetDirError, generate, shard_name
from contactnet.experiment import ExperimentError, Trial, run_experiment, trial_inputs
from contactnet.gait import WALK
from contactnet.jobs import code_identity, file_sha256
from contactnet.network import (
    MAX_HIDDEN_UNITS,
    ContactNet,
    ModelFileError,
    Normalizer,
    content_hash,
    load_model,
    rehash,
    save_model,
)
from contactnet.registry import model_path
from contactnet.train import DatasetError, load_dataset


# ---- finding 7: model files --------------------------------------------------------------------
def _save_random(path: Path, seed: int = 0, gait: str = "walk") -> Path:
    torch.manual_seed(seed)
    n_actions = 100 if gait == "walk" else 162
    u = np.random.default_rng(seed).normal(size=(50, 14))
    return save_model(path, ContactNet(n_actions), Normalizer.fit(u), {"gait": gait})


class _Storage:
    def __init__(self, key: str, numel: int) -> None:
        self.key, self.numel = key, numel


class _Tensor:
    """Pickles as torch does a tensor, on a storage that declares ``numel`` elements."""

    def __init__(self, storage: _Storage, shape: tuple[int, ...]) -> None:
        self.storage, self.shape = storage, shape

    def __reduce_ex__(self, protocol):  # noqa: ANN001, ANN204
        stride = (self.shape[1], 1) if len(self.shape) == 2 else (1,)
        return (torch._utils._rebuild_tensor_v2,
                (self.storage, 0, self.shape, stride, False, collections.OrderedDict()))


class _TorchPickler(pickle.Pickler):
    def persistent_id(self, obj):  # noqa: ANN001, ANN201
        if isinstance(obj, _Storage):
            return ("storage", torch.FloatStorage, obj.key, "cpu", obj.numel)
        return None


def _write_lying_storage_file(source: Path, path: Path, name: str, numel: int) -> None:
    """A torch archive like ``source`` whose ``name`` tensor declares a storage of ``numel`` floats while the
    archive holds its real (small) bytes: torch would allocate the declared size."""
    payload = torch.load(source, weights_only=True)
    records, state = {}, {}
    for i, (key, tensor) in enumerate(payload["state_dict"].items()):
        records[str(i)] = tensor.contiguous().numpy().tobytes()
        state[key] = _Tensor(_Storage(str(i), numel if key == name else tensor.numel()), tuple(tensor.shape))
    buffer = io.BytesIO()
    _TorchPickler(buffer, protocol=2).dump({**payload, "state_dict": state})
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as archive:
        archive.writestr("archive/data.pkl", buffer.getvalue())
        archive.writestr("archive/byteorder", "little")
        for key, data in records.items():
            archive.writestr(f"archive/data/{key}", data)
        archive.writestr("archive/version", "3\n")


_MEASURE = textwrap.dedent("""
    import json, resource, sys
    from contactnet.network import ModelFileError, load_model

    def vm_bytes():
        for line in open("/proc/self/status"):
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024

    # Any allocation of more than 1 GiB beyond what is mapped now fails: a loader that builds the declared
    # network (1.6 GB of float32 for 20000 x 20000) dies of it instead of being measured.
    limit = vm_bytes() + (1 << 30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    try:
        load_model(sys.argv[1])
        outcome = {"error": None}
    except ModelFileError as exc:
        outcome = {"error": "ModelFileError", "message": str(exc)}
    except BaseException as exc:
        outcome = {"error": type(exc).__name__, "message": str(exc)[:200]}
    outcome["peak_growth_kb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    print(json.dumps(outcome))
""")


def _load_measured(path: Path) -> dict:
    """load_model(path) in a fresh process under an address-space cap; its error and peak-memory growth."""
    result = subprocess.run([sys.executable, "-c", _MEASURE, str(path)], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and RLIMIT_AS")
def test_7a_a_small_file_declaring_huge_hidden_sizes_is_refused_before_anything_is_built(tmp_path):
    path = tmp_path / "walk.pt"
    payload = torch.load(_save_random(tmp_path / "good.pt"), weights_only=True)
    payload["hidden"] = [20000, 20000]  # the tester's file: the real weights, a lying architecture
    torch.save(payload, path)
    assert path.stat().st_size < 250_000
    outcome = _load_measured(path)
    assert outcome["error"] == "ModelFileError", outcome
    message = outcome["message"]
    assert "\n" not in message and str(path) in message
    assert message.endswith(f"hidden sizes [20000, 20000] exceed the limit (8 layers of at most "
                            f"{MAX_HIDDEN_UNITS} units)")
    assert outcome["peak_growth_kb"] < 64 * 1024, outcome  # not 1.96 GB: under 64 MB


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and RLIMIT_AS")
def test_7a_a_stored_tensor_declaring_a_huge_storage_is_refused_before_it_is_read(tmp_path):
    path = tmp_path / "walk.pt"
    _write_lying_storage_file(_save_random(tmp_path / "good.pt"), path, "layers.2.weight", 400_000_000)
    assert path.stat().st_size < 250_000
    assert torch.load(path, map_location="meta", weights_only=True)["state_dict"]["layers.2.weight"] \
        .untyped_storage().nbytes() == 1_600_000_000  # what torch would allocate
    outcome = _load_measured(path)
    assert outcome["error"] == "ModelFileError", outcome
    assert outcome["message"].endswith("state_dict['layers.2.weight'] is stored in 1600000000 bytes, more than "
                                       "its shape (128, 128) needs")
    assert outcome["peak_growth_kb"] < 64 * 1024, outcome


def test_7a_other_oversized_declarations_are_one_line_errors(tmp_path):
    good = _save_random(tmp_path / "good.pt")
    payload = torch.load(good, weights_only=True)
    cases = {
        "many layers": ({**payload, "hidden": [16] * 9}, "exceed the limit"),
        "huge metadata": ({**payload, "metadata": {**payload["metadata"], "pad": list(range(300_000))}},
                          "bytes of metadata, more than 1048576"),
        "tensor outside the state dict": ({**payload, "metadata": {**payload["metadata"], "x": torch.zeros(3)}},
                                          "holds tensors outside state_dict"),
        "bad hash": ({**payload, "content_hash": "md5:1234"}, "is not 'sha256:' and 64 hex digits"),
        "bool sizes": ({**payload, "hidden": [True, 128, 128]}, "are not a list of positive integers"),
    }
    for name, (edited, expected) in cases.items():
        path = tmp_path / f"{name.replace(' ', '_')}.pt"
        torch.save(edited, path)
        with pytest.raises(ModelFileError) as info:
            load_model(path)
        message = str(info.value)
        assert expected in message and "\n" not in message and len(message) < 300, (name, message)
    big = tmp_path / "big.pt"
    with open(big, "wb") as handle:  # sparse: no disk used
        handle.truncate(2 * 1024**3)
    with pytest.raises(ModelFileError, match="larger than the largest allowed network needs"):
        load_model(big)


def _flip_weights(path: Path, name: str, count: int) -> Path:
    """Change ``count`` of the values of tensor ``name`` in the file's bytes (the low byte of each)."""
    tensor = torch.load(path, weights_only=True)["state_dict"][name]
    data = bytearray(path.read_bytes())
    start = bytes(data).find(tensor.numpy().tobytes())
    assert start > 0
    for i in range(count):
        data[start + 4 * i] ^= 0x5A
    out = path.with_name(f"flipped-{path.name}")
    out.write_bytes(bytes(data))
    return out


def test_7b_flipped_weights_fail_the_content_hash(tmp_path, capsys):
    path = _save_random(tmp_path / "walk.pt")
    original = torch.load(path, weights_only=True)
    assert original["content_hash"] == load_model(path).content_hash
    assert original["content_hash"].startswith("sha256:") and len(original["content_hash"]) == 71
    flipped = _flip_weights(path, "layers.2.weight", 3999)
    raw = torch.load(flipped, weights_only=True)  # torch itself loads it silently (no CRC check)
    changed = (raw["state_dict"]["layers.2.weight"] != original["state_dict"]["layers.2.weight"]).sum()
    assert int(changed) == 3999 and raw["state_dict"]["layers.2.weight"].numel() == 16384
    with pytest.raises(ModelFileError) as info:
        load_model(flipped)
    assert str(info.value) == f"model file {flipped}: content hash mismatch: the file was changed after it was saved"
    capsys.readouterr()
    assert main(["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "contactnet", "--model", str(flipped)]) \
        == EXIT_USER_ERROR  # the finding: exit 0 and a different behaviour
    err = capsys.readouterr().err.strip()
    assert err.endswith("content hash mismatch: the file was changed after it was saved") and "\n" not in err


def test_7b_the_hash_covers_the_normalizer_and_the_robot_but_not_the_training_facts(tmp_path):
    path = _save_random(tmp_path / "walk.pt")
    payload = torch.load(path, weights_only=True)
    normalizer = {**payload["normalizer"], "high": [v + 1.0 for v in payload["normalizer"]["high"]]}
    for name, edited in {"normalizer": {**payload, "normalizer": normalizer},
                         "robot": {**payload, "metadata": {**payload["metadata"], "robot": "go2"}}}.items():
        torch.save(edited, tmp_path / f"{name}.pt")
        with pytest.raises(ModelFileError, match="content hash mismatch"):
            load_model(tmp_path / f"{name}.pt")
    torch.save({**payload, "metadata": {**payload["metadata"], "test_top5": 0.99}}, tmp_path / "facts.pt")
    assert load_model(tmp_path / "facts.pt").content_hash == payload["content_hash"]
    loaded = load_model(path)
    assert content_hash("walk", "solo12", [128, 128, 128], loaded.torch_model.state_dict(),
                        loaded.normalizer) == payload["content_hash"]


@pytest.mark.parametrize("gait", ["walk", "trot"])
def test_7b_the_shipped_models_have_no_hash_still_load_and_can_be_rehashed_elsewhere(gait, tmp_path):
    shipped = model_path("solo12", gait)
    before = file_sha256(shipped)
    loaded = load_model(shipped, expect_gait=gait)
    assert "content_hash" not in torch.load(shipped, weights_only=True)  # saved before hashes: nothing to verify
    assert loaded.content_hash is None and loaded.identity == f"file-sha256:{before}"
    copy = tmp_path / f"{gait}.pt"
    shutil.copyfile(shipped, copy)
    rehash(copy)
    again = load_model(copy, expect_gait=gait, expect_robot="solo12")
    assert again.content_hash is not None and again.identity == again.content_hash
    for a, b in zip(loaded.torch_model.state_dict().values(), again.torch_model.state_dict().values(), strict=True):
        assert torch.equal(a, b)
    u = np.random.default_rng(1).normal(size=(20, 14))
    np.testing.assert_array_equal(loaded.net.scores_batch(u), again.net.scores_batch(u))
    with pytest.raises(ModelFileError, match="content hash mismatch"):
        load_model(_flip_weights(copy, "layers.2.weight", 3999))
    assert file_sha256(shipped) == before  # the shipped file is not rewritten


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
    assert set(inputs) == {"trial", "terrain", "gait", "model", "code"}
    assert inputs["trial"]["seed"] == 3 and "model_dir" not in inputs["trial"]
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
    V = rng.uniform(0, 1, size=(n, WALK.n_actions)).astype(np.float32)
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
