"""Issue 11, finding 7 (model files), replayed as a hostile tester did it, and issue 12's torch-free
loader (``contactnet.planning.model_file``) attacked the same way:

- 7a: a 204 KB model file declaring hidden sizes 20000 x 20000 reached 1.96 GB before being refused.
- 7b: flipped bytes in the weights (3,999 of 16,384 weights changed) loaded silently.
- 7c: the loader no longer uses torch.load: pickled code, opcodes that build other objects, a memo-index
  bomb, storages lying about their size or place, and archives listing many entries are all refused
  before anything runs or is allocated.

The model files are made in tmp dirs; the shipped models are read, never written.
"""

from __future__ import annotations

import collections
import io
import json
import os
import pickle
import re
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch

from contactnet.cli import EXIT_USER_ERROR, main
from contactnet.jobs.runner import file_sha256
from contactnet.planning.network import (
    MAX_HIDDEN_UNITS,
    ModelFileError,
    Normalizer,
    content_hash,
    load_model,
    rehash,
)
from contactnet.planning.network_torch import ContactNet, save_model
from contactnet.registry import model_path


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

    def __init__(self, storage: _Storage, shape: tuple[int, ...], stride: tuple[int, ...] | None = None) -> None:
        self.storage, self.shape, self.stride = storage, shape, stride

    def __reduce_ex__(self, protocol):  # noqa: ANN001, ANN204
        stride = self.stride or ((self.shape[1], 1) if len(self.shape) == 2 else (1,))
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
    from contactnet.planning.network import ModelFileError, load_model

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


def _archive(path: Path, pickled: bytes, records: dict[str, bytes] | None = None) -> Path:
    """A torch-style archive around a hand-made data.pkl (and storage entries)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as archive:
        archive.writestr("archive/data.pkl", pickled)
        archive.writestr("archive/byteorder", "little")
        for key, data in (records or {}).items():
            archive.writestr(f"archive/data/{key}", data)
        archive.writestr("archive/version", "3\n")
    return path


class _Call:
    """Pickles as a call of ``function(*args)``: what an attacker's model file would hold."""

    def __init__(self, function, *args) -> None:  # noqa: ANN001
        self.function, self.args = function, args

    def __reduce__(self):  # noqa: ANN204
        return self.function, self.args


def test_7c_pickled_code_is_refused_before_anything_runs(tmp_path):
    """The loader reads model files without torch (contactnet.planning.model_file): an allow-list of globals
    (_rebuild_tensor_v2, the storage types, OrderedDict) and of pickle opcodes, checked before unpickling."""
    marker = tmp_path / "ran"
    payload = torch.load(_save_random(tmp_path / "good.pt"), weights_only=True)
    cases = {
        "os.system": (_Call(os.system, f"touch {marker}"), r"\(posix\.system is not allowed\)"),
        "eval": (_Call(eval, f"open({str(marker)!r}, 'w')"), r"\((__builtin__|builtins)\.eval is not allowed\)"),
        "numpy array": (np.zeros(3), r"numpy.* is not allowed\)"),
        "torch Parameter": (torch.nn.Parameter(torch.zeros(3)), "is not allowed"),
        "a storage called": (_Call(torch.FloatStorage, 3), "corrupt"),
    }
    for name, (value, expected) in cases.items():
        path = tmp_path / f"{name.replace(' ', '_')}.pt"
        torch.save({**payload, "metadata": {**payload["metadata"], "x": value}}, path)
        with pytest.raises(ModelFileError, match=expected) as info:
            load_model(path)
        assert str(path) in str(info.value) and "\n" not in str(info.value), name
    protocol2 = b"\x80\x02"
    raw = {  # opcodes that make or change objects of other types, refused before unpickling starts
        "BUILD": (protocol2 + b"ccollections\nOrderedDict\n)R}b.", "pickle opcode BUILD is not allowed"),
        "NEWOBJ": (protocol2 + b"ccollections\nOrderedDict\n)\x81.", "pickle opcode NEWOBJ is not allowed"),
        "INST": (b"(iposix\nsystem\n.", "pickle opcode INST is not allowed"),
        "STACK_GLOBAL": (b"\x80\x04\x8c\x05posix\x8c\x06system\x93.", "is not allowed"),
        "memo bomb": (protocol2 + b"Nr\xff\xff\xff\x7f.", "memo index 2147483647 out of order"),
        "bad storage id": (protocol2 + b"(X\x07\x00\x00\x00storagectorch\nFloatStorage\nK\x00tQ.",
                           "malformed storage reference"),
        "truncated": (protocol2 + b"(X\x07\x00", "corrupt"),
    }
    for name, (pickled, expected) in raw.items():
        path = _archive(tmp_path / f"raw-{name.replace(' ', '_')}.pt", pickled)
        with pytest.raises(ModelFileError, match=expected):
            load_model(path)
    assert not marker.exists()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and RLIMIT_AS")
def test_7c_a_memo_index_bomb_allocates_nothing(tmp_path):
    # pickle's C unpickler sizes its memo by the largest index: LONG_BINPUT 2**31-1 alone asks for 16 GB
    path = _archive(tmp_path / "walk.pt", b"\x80\x02Nr\xff\xff\xff\x7f.")
    outcome = _load_measured(path)
    assert outcome["error"] == "ModelFileError" and "memo index" in outcome["message"], outcome
    assert outcome["peak_growth_kb"] < 64 * 1024, outcome


def _crafted(source: Path, path: Path, name: str, shape=None, stride=None, numel=None, key=None,  # noqa: ANN001
             data=None) -> Path:
    """``source``'s archive with the tensor ``name`` declared otherwise (shape, strides, storage size or key)
    or stored in other bytes; the other tensors as they were."""
    payload = torch.load(source, weights_only=True)
    records, state = {}, {}
    for i, (tensor_name, tensor) in enumerate(payload["state_dict"].items()):
        records[str(i)] = tensor.contiguous().numpy().tobytes()
        storage, dims = _Storage(str(i), tensor.numel()), tuple(tensor.shape)
        if tensor_name == name:
            records[str(i)] = records[str(i)] if data is None else data
            storage = _Storage(key or str(i), tensor.numel() if numel is None else numel)
            dims = dims if shape is None else shape
        state[tensor_name] = _Tensor(storage, dims, stride if tensor_name == name else None)
    buffer = io.BytesIO()
    _TorchPickler(buffer, protocol=2).dump({**payload, "state_dict": state})
    return _archive(path, buffer.getvalue(), records)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and RLIMIT_AS")
@pytest.mark.parametrize(("declared", "expected"), [
    ({"shape": (10**6, 10**6), "numel": 10**12}, "state_dict['layers.2.weight'] has shape (1000000, 1000000), "
                                                  "expected (128, 128)"),
    ({"numel": 10**12}, "state_dict['layers.2.weight'] is stored in 4000000000000 bytes, more than its shape "
                        "(128, 128) needs"),
])
def test_7c_a_tensor_declaring_10_to_the_12_elements_is_refused_without_allocating_it(tmp_path, declared, expected):
    path = _crafted(_save_random(tmp_path / "good.pt"), tmp_path / "walk.pt", "layers.2.weight", **declared)
    assert path.stat().st_size < 250_000
    outcome = _load_measured(path)
    assert outcome["error"] == "ModelFileError" and outcome["message"].endswith(expected), outcome
    assert outcome["peak_growth_kb"] < 64 * 1024, outcome


def test_7c_storages_are_checked_against_the_archive_entries(tmp_path):
    good = _save_random(tmp_path / "good.pt")
    weight = torch.load(good, weights_only=True)["state_dict"]["layers.2.weight"].numpy().tobytes()
    cases = {
        "entry shorter than its storage": ({"data": weight[: len(weight) // 2]},
                                           "holds 32768 bytes, its tensor's storage declares 65536"),
        "entry longer than its storage": ({"data": weight + weight[:400]}, "holds 65936 bytes"),
        "no entry": ({"key": "99"}, "has no entry 'archive/data/99' for a tensor's storage"),
        "view beyond its storage": ({"stride": (1000, 1)}, "does not fit its storage"),
        "one storage declared twice": ({"key": "0"}, "declares storage '0' twice"),
    }
    for name, (declared, expected) in cases.items():
        path = _crafted(good, tmp_path / f"{name.replace(' ', '_')}.pt", "layers.2.weight", **declared)
        with pytest.raises(ModelFileError, match=re.escape(expected)) as info:
            load_model(path)
        assert str(path) in str(info.value) and "\n" not in str(info.value), name
    assert load_model(_crafted(good, tmp_path / "same.pt", "layers.2.weight")).content_hash  # the helper is faithful


def test_7c_an_archive_listing_many_entries_is_refused_before_its_directory_is_read(tmp_path):
    # zipfile builds an object per listed entry: ~900k entries fit under the size limit (~400 MB of them)
    path = tmp_path / "walk.pt"
    with zipfile.ZipFile(path, "w") as archive:
        for i in range(70_000):  # more than 65535: the zip64 end record holds the count
            archive.writestr(f"archive/{i}", b"")
    with pytest.raises(ModelFileError, match="holds 70000 zip entries, more than 256$"):
        load_model(path)


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


def _without_hash(shipped: Path, folder: Path) -> Path:
    """A copy of a shipped model as files were saved before models carried a content hash (as the shipped trot
    model still is; users may have such files)."""
    payload = torch.load(shipped, weights_only=True)
    payload.pop("content_hash", None)
    path = folder / f"{shipped.stem}-nohash.pt"
    torch.save(payload, path)
    return path


def test_7b_a_shipped_model_with_a_hash_verifies_it():
    """A shipped model saved with a content hash (the walk's, trained with the stand choice) is identified by it."""
    for gait in ("walk", "trot"):
        raw = torch.load(model_path("solo12", gait), weights_only=True)
        if "content_hash" in raw:
            loaded = load_model(model_path("solo12", gait), expect_gait=gait, expect_robot="solo12")
            assert loaded.identity == loaded.content_hash == raw["content_hash"]


@pytest.mark.parametrize("gait", ["walk", "trot"])
def test_7b_a_model_saved_without_a_hash_still_loads_and_can_be_rehashed_elsewhere(gait, tmp_path):
    old = _without_hash(model_path("solo12", gait), tmp_path)
    before = file_sha256(old)
    loaded = load_model(old, expect_gait=gait)
    assert "content_hash" not in torch.load(old, weights_only=True)  # saved before hashes: nothing to verify
    assert loaded.content_hash is None and loaded.identity == f"file-sha256:{before}"
    copy = tmp_path / f"{gait}.pt"
    shutil.copyfile(old, copy)
    damaged = _flip_weights(copy, "layers.2.weight", 3999)  # no hash to catch it: the zip checksums do
    assert torch.load(damaged, weights_only=True)["state_dict"]["layers.2.weight"].shape == (128, 128)
    expected = rf"flipped-{gait}\.pt: is damaged: the zip checksum of [\w-]+/data/2 does not match \(the file was"
    with pytest.raises(ModelFileError, match=expected + r" changed after it was saved\)$"):
        load_model(damaged)
    rehash(copy)
    again = load_model(copy, expect_gait=gait, expect_robot="solo12")
    assert again.content_hash is not None and again.identity == again.content_hash
    for a, b in zip(loaded.torch_model.state_dict().values(), again.torch_model.state_dict().values(), strict=True):
        assert torch.equal(a, b)
    u = np.random.default_rng(1).normal(size=(20, 14))
    np.testing.assert_array_equal(loaded.net.scores_batch(u), again.net.scores_batch(u))
    with pytest.raises(ModelFileError, match="content hash mismatch"):
        load_model(_flip_weights(copy, "layers.2.weight", 3999))
    assert file_sha256(old) == before  # the file itself is not rewritten
