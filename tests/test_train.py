"""Training: dataset loading and its errors, the split, a short training run that learns, the command."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

import contactnet.jobs.train as train_module
from contactnet import registry
from contactnet.jobs.train import (
    DATASET_FORMAT,
    Dataset,
    DatasetError,
    TrainConfig,
    _FlatAdam,
    load_dataset,
    split_rows,
    train,
    train_command,
)
from contactnet.planning.network import INPUT_NAMES, ContactNet, ModelFileError, load_model, topk_accuracy

N_ACTIONS = {"walk": 100, "trot": 162}


def synthetic(n_episodes: int = 60, per_episode: int = 25, gait: str = "walk", seed: int = 0):
    """u, V, episode where V is a known function of u: the squared distance of a 2-D projection of u to
    one fixed point per candidate, so the cheapest candidates are learnable."""
    rng = np.random.default_rng(seed)
    n = n_episodes * per_episode
    u = rng.normal(size=(n, 14)) * 0.1
    u[:, 8] += 0.23
    projection = np.random.default_rng(99).normal(size=(14, 2))
    centers = np.random.default_rng(98).normal(size=(N_ACTIONS[gait], 2)) * 0.3
    z = u @ projection
    V = ((z[:, None, :] - centers[None]) ** 2).sum(-1)
    V[rng.random(V.shape) < 0.02] = np.inf  # a few infeasible candidates
    episode = np.repeat(np.arange(n_episodes), per_episode).astype(np.int32)
    return u.astype(np.float32), V.astype(np.float32), episode


def write_dataset(directory: Path, u, V, episode, gait: str = "walk", n_shards: int = 2, **manifest) -> Path:
    """A dataset directory in the datagen format (manifest + shards)."""
    directory.mkdir(parents=True, exist_ok=True)
    names = []
    for i, rows in enumerate(np.array_split(np.arange(len(u)), n_shards)):
        name = f"shard-{i:05d}.npz"
        np.savez(directory / name, u=u[rows], V=V[rows], episode=episode[rows])
        names.append(name)
    content = {"format": DATASET_FORMAT, "gait": gait, "n_actions": V.shape[1], "input_names": list(INPUT_NAMES),
               "shards": names, "episodes": int(np.unique(episode).size), "instances": len(u), "seed": 0,
               "code_version": "test"}
    content.update(manifest)
    (directory / "manifest.json").write_text(json.dumps(content))
    return directory


@pytest.fixture(scope="module")
def walk_data():
    return synthetic()


# ---- loading -----------------------------------------------------------------------------------
def test_load_dataset_round_trip(tmp_path, walk_data):
    u, V, episode = walk_data
    ds = load_dataset(write_dataset(tmp_path / "d", u, V, episode, n_shards=3))
    assert ds.gait == "walk" and ds.n_actions == 100 and ds.n_instances == len(u) and ds.n_episodes == 60
    np.testing.assert_array_equal(ds.u, u)
    np.testing.assert_array_equal(ds.V, V)
    np.testing.assert_array_equal(ds.episode, episode)
    assert ds.input_names == INPUT_NAMES and ds.manifest["code_version"] == "test"


def _expect_error(directory: Path, fragment: str, match_file: Path | None = None):
    with pytest.raises(DatasetError) as info:
        load_dataset(directory)
    message = str(info.value)
    assert "\n" not in message, message
    assert fragment in message, message
    assert str(match_file or directory) in message, message


def test_dataset_errors(tmp_path, walk_data):
    u, V, episode = walk_data
    _expect_error(tmp_path / "nowhere", "no such directory")
    (tmp_path / "empty").mkdir()
    _expect_error(tmp_path / "empty", "no manifest.json")

    def fresh(name, **manifest):
        return write_dataset(tmp_path / name, u, V, episode, **manifest)

    d = fresh("json")
    (d / "manifest.json").write_text("{not json")
    _expect_error(d, "not valid JSON")
    _expect_error(fresh("format", format="v0"), "format is 'v0'")
    _expect_error(fresh("gait", gait="gallop"), "unknown gait 'gallop'")
    _expect_error(fresh("n_actions", n_actions=162), "n_actions is 162")
    _expect_error(fresh("names", input_names=["a"] * 3), "input_names")
    _expect_error(fresh("noshards", shards=[]), "no shards")
    _expect_error(fresh("count", instances=5), "declares 5 instances")
    d = fresh("missing")
    (d / "shard-00001.npz").unlink()
    _expect_error(d, "missing", d / "shard-00001.npz")
    d = fresh("truncated")
    data = (d / "shard-00000.npz").read_bytes()
    (d / "shard-00000.npz").write_bytes(data[: len(data) // 3])
    _expect_error(d, "unreadable shard", d / "shard-00000.npz")

    def bad_shard(name, **arrays):
        d = fresh(name)
        rows = slice(0, len(u) // 2)
        content = {"u": u[rows], "V": V[rows], "episode": episode[rows], **arrays}
        np.savez(d / "shard-00000.npz", **{k: v for k, v in content.items() if v is not None})
        return d

    _expect_error(bad_shard("vshape", V=V[: len(u) // 2, :50]), "V has shape", tmp_path / "vshape" / "shard-00000.npz")
    _expect_error(bad_shard("ushape", u=u[: len(u) // 2, :12]), "u has shape")
    _expect_error(bad_shard("eshape", episode=episode[:3]), "episode has shape")
    _expect_error(bad_shard("noV", V=None), "missing array(s) V")
    u_nan = u[: len(u) // 2].copy()
    u_nan[7, 3] = np.nan
    _expect_error(bad_shard("unan", u=u_nan), "NaN/inf inputs in 1 row(s), first row 7")
    v_nan = V[: len(u) // 2].copy()
    v_nan[4, 0] = np.nan
    _expect_error(bad_shard("vnan", V=v_nan), "V has NaN costs (first row 4)")
    _expect_error(bad_shard("efloat", episode=episode[: len(u) // 2].astype(float)), "episode ids must be integers")


# ---- split -------------------------------------------------------------------------------------
def test_split_by_episode_and_instance():
    episode = np.repeat(np.arange(100), np.random.default_rng(0).integers(1, 31, 100))
    train_rows, test_rows = split_rows(episode, 0.7, "episode", seed=1)
    assert set(episode[train_rows]).isdisjoint(episode[test_rows])
    assert np.array_equal(np.sort(np.concatenate([train_rows, test_rows])), np.arange(len(episode)))
    assert abs(len(train_rows) / len(episode) - 0.7) < 0.05
    again = split_rows(episode, 0.7, "episode", seed=1)
    assert np.array_equal(again[0], train_rows)
    train_rows, test_rows = split_rows(episode, 0.7, "instance", seed=1)
    assert len(train_rows) == round(0.7 * len(episode)) and len(train_rows) + len(test_rows) == len(episode)
    assert not set(episode[train_rows]).isdisjoint(episode[test_rows])  # the paper's split mixes episodes
    with pytest.raises(DatasetError, match="at least 2 episodes"):
        split_rows(np.zeros(10, dtype=int), 0.7, "episode", seed=0)


# ---- training ----------------------------------------------------------------------------------
def test_flat_adam_matches_torch_adam():
    torch.manual_seed(0)
    x, y = torch.randn(40, 14), torch.rand(40, 100)
    reference, flat = ContactNet(100), ContactNet(100)
    flat.load_state_dict(reference.state_dict())
    adam = torch.optim.Adam(reference.parameters(), lr=1e-3, foreach=False)
    flat_adam = _FlatAdam(flat, lr=1e-3)
    for step in range(10):
        rows = slice(4 * step, 4 * step + 4)
        adam.zero_grad()
        torch.nn.functional.mse_loss(reference(x[rows]), y[rows]).backward()
        adam.step()
        flat_adam.zero_grad()
        torch.nn.functional.mse_loss(flat(x[rows]), y[rows]).backward()
        flat_adam.step()
    assert flat_adam.check_views()
    for a, b in zip(reference.parameters(), flat.parameters(), strict=True):
        torch.testing.assert_close(a, b, atol=1e-7, rtol=0)


def test_training_learns_and_restores_globals(walk_data):
    u, V, episode = walk_data
    dataset = Dataset.from_arrays(u, V, episode, gait="walk")
    threads_before = torch.get_num_threads()
    rng_before = torch.get_rng_state()
    config = TrainConfig(epochs=20, eval_every=10, seed=3)
    result = train(dataset, config, progress=False)
    assert torch.get_num_threads() == threads_before
    assert torch.equal(torch.get_rng_state(), rng_before)
    assert result.stopped == "done" and result.epochs_done == 20
    assert [h["epoch"] for h in result.history] == [10, 20]
    assert result.history[-1]["loss"] < 0.03  # a constant 0.5 output scores about 1/12
    chance = 5 / 100
    assert result.metrics["test_top5"] > 8 * chance, result.metrics
    assert result.metrics["train_top5"] > 8 * chance, result.metrics
    assert 0 <= result.metrics["test_top1"] <= result.metrics["test_top5"]
    c = result.counts
    assert c["train_instances"] + c["test_instances"] == len(u) and c["train_episodes"] + c["test_episodes"] == 60
    # the reported figures are those of the returned model and normalizer
    test_rows = split_rows(episode, 0.7, "episode", 3)[1]
    x = torch.tensor(result.normalizer.normalize(u[test_rows]), dtype=torch.float32)
    with torch.no_grad():
        scores = result.model(x).numpy()
    assert topk_accuracy(scores, V[test_rows]) == pytest.approx(result.metrics["test_top5"])
    # same seed, same model
    again = train(dataset, config, progress=False)
    for a, b in zip(result.model.parameters(), again.model.parameters(), strict=True):
        assert torch.equal(a, b)


def test_training_drops_all_infeasible_rows_and_time_limit(walk_data):
    u, V, episode = walk_data
    V = V.copy()
    V[:10] = np.inf
    dataset = Dataset.from_arrays(u, V, episode, gait="walk")
    result = train(dataset, TrainConfig(epochs=50, max_minutes=1e-9, split="instance"), progress=False)
    assert result.stopped == "time limit" and result.epochs_done == 1
    assert result.counts["dropped_infeasible"] == 10
    assert result.counts["train_instances"] + result.counts["test_instances"] == len(u) - 10


def test_train_config_validation():
    for bad in ({"epochs": 0}, {"lr": 0.0}, {"train_fraction": 1.0}, {"split": "random"}, {"max_minutes": 0}):
        with pytest.raises(ValueError):
            TrainConfig(**bad)


# ---- the command -------------------------------------------------------------------------------
def test_train_command_saves_a_model(tmp_path, walk_data, capsys):
    u, V, episode = walk_data
    data = write_dataset(tmp_path / "data", u, V, episode)
    out = tmp_path / "models" / "walk.pt"
    assert train_command("walk", data, out, epochs=3, progress=False) == 0
    printed = capsys.readouterr().out
    assert "93.48 / 90.81" in printed and "top-5" in printed and str(out) in printed
    loaded = load_model(out, expect_gait="walk")
    meta = loaded.metadata
    assert meta["gait"] == "walk" and meta["n_actions"] == 100 and meta["code_version"]
    assert meta["training"]["epochs"] == 3 and meta["training"]["batch_size"] == 100
    assert meta["training"]["split"] == "episode" and meta["training"]["lr"] == pytest.approx(1e-3)
    assert meta["dataset"]["instances"] == len(u) and meta["dataset"]["episodes"] == 60
    assert {"train_top1", "train_top5", "test_top1", "test_top5", "date"} <= set(meta)
    assert loaded.net.scores(u[0]).shape == (100,)
    assert meta["robot"] == loaded.robot == "solo12" and meta["paper_top5"] == [93.48, 90.81]

    with pytest.raises(DatasetError, match="is a 'walk' dataset, but --gait trot"):
        train_command("trot", data, tmp_path / "trot.pt", epochs=1, progress=False)
    with pytest.raises(ModelFileError, match="is a directory"):
        train_command("walk", data, tmp_path, epochs=1, progress=False)
    with pytest.raises(DatasetError, match="was made with 'solo12', but --robot go2"):
        train_command("walk", data, tmp_path / "go2_walk.pt", epochs=1, progress=False, robot="go2")


def test_the_model_records_the_datasets_robot(tmp_path, walk_data):
    u, V, episode = walk_data
    data = write_dataset(tmp_path / "data", u, V, episode, robot="go2")
    assert load_dataset(data).robot == "go2"
    out = tmp_path / "go2_walk.pt"
    assert train_command("walk", data, out, epochs=1, progress=False, robot="go2") == 0
    assert load_model(out, expect_robot="go2").metadata["robot"] == "go2"
    with pytest.raises(ModelFileError, match="is a 'go2' model, but a 'solo12' model was expected"):
        load_model(out, expect_robot="solo12")
    with pytest.raises(DatasetError, match="robot must be a robot name"):
        load_dataset(write_dataset(tmp_path / "bad", u, V, episode, robot=7))


def test_a_gait_without_a_paper_figure(tmp_path, walk_data, monkeypatch, capsys):
    from dataclasses import replace

    from contactnet.motion import gait as gait_table
    from contactnet.motion.gait import WALK

    monkeypatch.setitem(gait_table._GAITS, "crawl", replace(WALK, name="crawl", paper_top5=None))
    u, V, episode = walk_data
    data = write_dataset(tmp_path / "data", u, V, episode, gait="crawl")
    out = tmp_path / "crawl.pt"
    assert train_command("crawl", data, out, epochs=1, progress=False) == 0
    top5 = next(line for line in capsys.readouterr().out.splitlines() if "top-5" in line)
    assert top5.rstrip().endswith("-")
    assert load_model(out, expect_gait="crawl").metadata["paper_top5"] is None


def test_train_command_ctrl_c_saves_nothing(tmp_path, walk_data, monkeypatch, capsys):
    u, V, episode = walk_data
    data = write_dataset(tmp_path / "data", u, V, episode)
    real_train = train_module.train

    def interrupted_train(*args, **kwargs):
        def on_epoch(epoch, loss):
            if epoch == 2:
                raise KeyboardInterrupt

        return real_train(*args, on_epoch=on_epoch, **kwargs)

    monkeypatch.setattr(train_module, "train", interrupted_train)
    manifest = json.loads((data / "manifest.json").read_text())
    (data / "manifest.json").write_text(json.dumps({**manifest, "complete": False, "episodes_planned": 100}))
    out = tmp_path / "walk.pt"
    assert train_command("walk", data, out, epochs=10, progress=False) == 130
    assert not out.exists()
    err = capsys.readouterr().err
    assert "interrupted after 2 of 10 epochs: nothing saved" in err
    assert "is incomplete (60 of 100 episodes)" in err
    assert train_command("walk", data, out, epochs=10, progress=False, save_partial=True) == 130
    assert load_model(out).metadata["training"]["stopped"] == "interrupted"


SAMPLES = Path(__file__).resolve().parent.parent / "data" / "sample"


@pytest.mark.parametrize("gait", ["walk", "trot"])
def test_committed_sample_is_real_oracle_data_that_trains(gait):
    """data/sample/{gait}: the first shards of the full dataset (contactnet datagen), as committed."""
    if not (SAMPLES / gait).is_dir():
        pytest.skip(f"no committed {gait} sample")
    ds = load_dataset(SAMPLES / gait)
    assert ds.gait == gait and ds.V.shape == (ds.n_instances, N_ACTIONS[gait]) and ds.n_instances >= 200
    assert np.isfinite(ds.V).any(axis=1).all()
    # The oracle executed the cheapest action, so the data are not degenerate: many different best actions.
    assert len(np.unique(np.nanargmin(np.where(np.isfinite(ds.V), ds.V, np.nan), axis=1))) >= 10
    result = train(ds, TrainConfig(epochs=40, split="instance", seed=0), progress=False)
    assert result.metrics["train_top5"] > 0.4  # chance is 1 in 20 (walk) or 1 in 32 (trot)


def test_mirror_adds_each_training_instance_mirrored_and_leaves_the_test_split(walk_data):
    from contactnet.planning.mirror import mirrored

    u, V, episode = walk_data
    dataset = Dataset.from_arrays(u, V, episode, gait="walk")
    plain = train(dataset, TrainConfig(epochs=2, seed=3), progress=False)
    both = train(dataset, TrainConfig(epochs=2, seed=3, mirror=True), progress=False)
    assert both.counts["train_instances"] == 2 * plain.counts["train_instances"]
    assert both.counts["mirrored_instances"] == plain.counts["train_instances"] and plain.counts["mirrored_instances"] == 0
    assert both.counts["test_instances"] == plain.counts["test_instances"]
    # the normalizer saw the mirror images: every lateral input's range symmetric about zero
    train_rows = split_rows(episode, 0.7, "episode", 3)[0]
    expected = np.concatenate([u[train_rows], mirrored(u[train_rows], V[train_rows], registry.gait_by_name("walk"))[0]])
    np.testing.assert_allclose(both.normalizer.low, expected.min(axis=0), rtol=1e-6)
    np.testing.assert_allclose(both.normalizer.high, expected.max(axis=0), rtol=1e-6)
    lateral = [INPUT_NAMES.index(name) for name in ("com_vy", "cmd_vy")]
    np.testing.assert_allclose(both.normalizer.low[lateral], -both.normalizer.high[lateral], rtol=1e-6)
    assert not np.allclose(plain.normalizer.low[lateral], -plain.normalizer.high[lateral], rtol=1e-6)
