"""The model file read without torch (``contactnet.planning.model_file``, ``contactnet.planning.network.load_model``): no torch
import, the same weights bit for bit as ``torch.load``, the same scores, the same content hash as the torch
computation of it, every storage type and byte order torch reads, and the torch network built on demand."""

from __future__ import annotations

import hashlib
import io
import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch

from contactnet.motion.gait import gait_by_name
from contactnet.planning.model_file import MODEL_FORMAT, content_hash
from contactnet.planning.network import ModelFileError, Normalizer, NumpyContactNet, load_model
from contactnet.planning.network_torch import ContactNet, save_model, torch_scores
from contactnet.registry import model_path

SHIPPED = [model_path("solo12", gait) for gait in ("walk", "trot") if model_path("solo12", gait).exists()]


def _content_hash_with_torch(gait, robot, hidden, state, normalizer) -> str:
    """The content hash as contactnet computed it with torch until the loader went torch-free (the reference)."""
    digest = hashlib.sha256()
    head = {"format": MODEL_FORMAT, "gait": gait, "robot": robot, "hidden": [int(h) for h in hidden],
            "normalizer": normalizer.to_dict()}
    digest.update(json.dumps(head, sort_keys=True).encode())
    for name in sorted(state):
        values = state[name].detach().cpu().to(torch.float32).contiguous().numpy()
        digest.update(f"\n{name} {tuple(values.shape)}\n".encode())
        digest.update(values.astype("<f4", copy=False).tobytes())
    return f"sha256:{digest.hexdigest()}"


def _random_file(path: Path, seed: int, gait: str = "walk", hidden=(128, 128, 128)) -> Path:
    torch.manual_seed(seed)
    model = ContactNet(gait_by_name(gait).n_actions, hidden=hidden)
    with torch.no_grad():
        for p in model.parameters():
            p.mul_(3)
    u = np.random.default_rng(seed).normal(size=(40, 14)) * 0.3
    return save_model(path, model, Normalizer.fit(u), {"gait": gait})


def _bits(values) -> np.ndarray:
    return np.ascontiguousarray(values, dtype=np.float32).view(np.uint32)


def _models(tmp_path: Path) -> list[Path]:
    made = [_random_file(tmp_path / f"r{seed}.pt", seed, gait, hidden)
            for seed, gait, hidden in [(0, "walk", (128, 128, 128)), (1, "trot", (128, 128, 128)),
                                       (2, "walk", (64, 32, 16, 8)), (3, "trot", (7,))]]
    return SHIPPED + made


def test_load_model_does_not_import_torch():
    code = ("import sys\n"
            "import contactnet.planning.network as n\n"
            "from contactnet import registry\n"
            "from contactnet.motion.gait import gait_by_name\n"
            "for gait in ('walk', 'trot'):\n"
            "    path = registry.model_path('solo12', gait)\n"
            "    if path.exists():\n"
            "        n.load_model(path).scores([0.1] * 14)\n"
            "        registry.make_planner('contactnet', gait_by_name(gait))\n"
            "assert 'torch' not in sys.modules, 'torch imported'\n"
            "assert n.ContactNet.__module__ == 'contactnet.planning.network_torch' and 'torch' in sys.modules\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr


def test_weights_are_bit_identical_to_torch_load_and_so_are_the_scores(tmp_path):
    u = np.random.default_rng(7).normal(size=(50, 14)) * 0.2
    for path in _models(tmp_path):
        raw = torch.load(path, weights_only=True)
        for dtype in (np.float64, np.float32):
            loaded = load_model(path, dtype=dtype)
            assert list(loaded.state_dict) == list(raw["state_dict"])
            for name, tensor in raw["state_dict"].items():
                assert loaded.state_dict[name].dtype == np.float32 and not loaded.state_dict[name].flags.writeable
                np.testing.assert_array_equal(_bits(loaded.state_dict[name]), _bits(tensor.float().numpy()), name)
            model = ContactNet(raw["n_actions"], hidden=tuple(raw["hidden"]))
            model.load_state_dict({k: v.float() for k, v in raw["state_dict"].items()})
            reference = NumpyContactNet.from_torch(model, Normalizer.from_dict(raw["normalizer"]), dtype=dtype)
            np.testing.assert_array_equal(loaded.net.scores_batch(u), reference.scores_batch(u))
            np.testing.assert_array_equal(loaded.scores(u[0]), reference.scores(u[0]))


def test_the_content_hash_from_numpy_is_the_torch_hash(tmp_path):
    for path in _models(tmp_path):
        raw = torch.load(path, weights_only=True)
        robot = raw["metadata"].get("robot", "solo12")
        normalizer = Normalizer.from_dict(raw["normalizer"])
        expected = _content_hash_with_torch(raw["gait"], robot, raw["hidden"], raw["state_dict"], normalizer)
        loaded = load_model(path)
        assert content_hash(raw["gait"], robot, raw["hidden"], loaded.state_dict, normalizer) == expected
        assert content_hash(raw["gait"], robot, raw["hidden"], raw["state_dict"], normalizer) == expected
        assert raw.get("content_hash", expected) == expected == (loaded.content_hash or expected)
    rng = np.random.default_rng(0)  # odd shapes and values: subnormals, signed zeros, huge and tiny
    state = {"b": rng.normal(size=(3, 5)).astype(np.float32), "a": np.array([0.0, -0.0, 1e-40, 3e38], np.float32),
             "c": np.float32(2.5) * np.ones((0, 4), np.float32)}
    tensors = {k: torch.from_numpy(v) for k, v in state.items()}
    norm = Normalizer.fit(rng.normal(size=(5, 14)))
    assert content_hash("walk", "go2", [9], state, norm) == _content_hash_with_torch("walk", "go2", [9], tensors, norm)


def test_the_torch_network_is_built_only_when_asked_for(tmp_path):
    path = _random_file(tmp_path / "walk.pt", 4)
    loaded = load_model(path)
    assert "torch_model" not in vars(loaded)
    model = loaded.torch_model
    assert loaded.torch_model is model and not model.training and model.hidden == (128, 128, 128)
    raw = torch.load(path, weights_only=True)
    for name, tensor in model.state_dict().items():
        assert torch.equal(tensor, raw["state_dict"][name])
    u = np.random.default_rng(1).normal(size=(9, 14)) * 0.2
    np.testing.assert_allclose(loaded.net.scores_batch(u), torch_scores(model, loaded.normalizer, u), atol=1e-5)


def _resaved(path: Path, out: Path, dtype: torch.dtype, hashed: bool = True) -> Path:
    """``path``'s payload saved by torch with its weights in ``dtype`` (the recorded hash kept or dropped)."""
    payload = torch.load(path, weights_only=True)
    payload["state_dict"] = {k: v.to(dtype) for k, v in payload["state_dict"].items()}
    if not hashed:
        payload.pop("content_hash")
    torch.save(payload, out)
    return out


@pytest.mark.parametrize("dtype", [torch.float64, torch.float16, torch.bfloat16])
def test_other_float_storages_load_as_torch_reads_them(tmp_path, dtype):
    path = _random_file(tmp_path / "walk.pt", 5)
    out = _resaved(path, tmp_path / "other.pt", dtype, hashed=dtype is torch.float64)  # float64 -> 32: exact
    raw = torch.load(out, weights_only=True)
    loaded = load_model(out)
    for name, tensor in raw["state_dict"].items():
        assert tensor.dtype == dtype
        np.testing.assert_array_equal(_bits(loaded.state_dict[name]), _bits(tensor.float().numpy()), name)


def test_double_weights_round_to_float32_as_torch_does_and_overflow_is_refused(tmp_path):
    path = _random_file(tmp_path / "walk.pt", 6)
    payload = torch.load(path, weights_only=True)
    payload.pop("content_hash")
    rng = np.random.default_rng(3)
    state = {k: torch.from_numpy(rng.normal(size=tuple(v.shape)) * 10.0 ** rng.integers(-40, 30, size=tuple(v.shape)))
             for k, v in payload["state_dict"].items()}
    torch.save({**payload, "state_dict": state}, tmp_path / "double.pt")
    loaded = load_model(tmp_path / "double.pt")
    for name, tensor in state.items():
        np.testing.assert_array_equal(_bits(loaded.state_dict[name]), _bits(tensor.float().numpy()), name)
    state["layers.2.bias"] = torch.full((128,), 1e300, dtype=torch.float64)  # finite, but not as float32
    torch.save({**payload, "state_dict": state}, tmp_path / "overflow.pt")
    with pytest.raises(ModelFileError, match=r"state_dict\['layers.2.bias'\] is not finite floating point"):
        load_model(tmp_path / "overflow.pt")


@pytest.mark.parametrize("dtype", [torch.int64, torch.int32, torch.uint8, torch.bool, torch.complex64])
def test_non_float_storages_are_refused(tmp_path, dtype):
    out = _resaved(_random_file(tmp_path / "walk.pt", 5), tmp_path / "int.pt", dtype, hashed=False)
    with pytest.raises(ModelFileError, match=r"state_dict\['layers.0.weight'\] is not finite floating point"):
        load_model(out)


def _rezipped(path: Path, out: Path, compression: int = zipfile.ZIP_STORED, big_endian: bool = False) -> Path:
    """The archive written again by zipfile: compressed, or with big-endian storages (as a big-endian
    machine's torch.save writes them)."""
    raw = torch.load(path, weights_only=True)
    sizes = {k: v.element_size() for k, v in raw["state_dict"].items()}
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(out, "w", compression) as dst:
        for info in src.infolist():
            data = src.read(info)
            if big_endian and info.filename.endswith("/byteorder"):
                data = b"big"
            elif big_endian and "/data/" in info.filename:
                itemsize = next(iter(set(sizes.values())))
                data = np.frombuffer(data, dtype=f"<u{itemsize}").astype(f">u{itemsize}").tobytes()
            dst.writestr(info.filename, data)
    return out


@pytest.mark.parametrize("how", ["deflated", "big-endian"])
def test_archives_torch_reads_load_the_same(tmp_path, how):
    path = _random_file(tmp_path / "walk.pt", 8)
    out = _rezipped(path, tmp_path / f"{how}.pt", zipfile.ZIP_DEFLATED if how == "deflated" else zipfile.ZIP_STORED,
                    big_endian=how == "big-endian")
    raw, original = torch.load(out, weights_only=True), load_model(path)
    loaded = load_model(out)
    assert loaded.content_hash == original.content_hash  # verified: the same values
    for name, tensor in raw["state_dict"].items():
        np.testing.assert_array_equal(_bits(loaded.state_dict[name]), _bits(tensor.numpy()), name)
        np.testing.assert_array_equal(loaded.state_dict[name], original.state_dict[name])


def test_a_tensor_viewing_part_of_its_storage_reads_that_part(tmp_path):
    path = _random_file(tmp_path / "walk.pt", 9)
    payload = torch.load(path, weights_only=True)
    payload.pop("content_hash")
    big = torch.arange(128 * 14 * 2, dtype=torch.float32).reshape(128, 28) / 100
    payload["state_dict"]["layers.0.weight"] = big[:, 3:17]  # strided view, offset 3: torch saves the storage
    buffer = io.BytesIO()
    torch.save(payload, buffer)
    (tmp_path / "view.pt").write_bytes(buffer.getvalue())
    loaded = load_model(tmp_path / "view.pt")
    np.testing.assert_array_equal(loaded.state_dict["layers.0.weight"], big[:, 3:17].numpy())
