"""The ContactNet network: rank targets, input normalization, the MLP, fast numpy inference, the model
file and the top-k metric (paper Sec. III-B and IV).

The network maps the 14 inputs u_r of a state (foot XY of FL, FR, HL, HR in the CoM frame, CoM
height, CoM velocity, user velocity) to one score per candidate action; a higher score means a
cheaper (better) candidate. Training regresses the scores onto the paper's rank targets Y.

Two implementations of the same forward pass:
- `ContactNet` (torch) for training; it takes *normalized* inputs;
- `NumpyContactNet` for the planner: raw inputs, normalization folded into the first layer, a few
  microseconds per evaluation, no torch call on the hot path.

The inputs u_r themselves are defined in `contactnet.network_input` (re-exported here).

Model file (``contactnet.registry.model_path(robot, gait)``: ``contactnet/models/{walk,trot}.pt`` for
Solo12): one `torch.save`d dict of plain tensors, strings, numbers and lists, loadable with
`torch.load(path, weights_only=True)`:
    {"format": "contactnet-model-v1", "gait": "walk", "n_actions": 100, "n_inputs": 14,
     "hidden": [128, 128, 128], "state_dict": {name: tensor}, "normalizer": {...},
     "metadata": {"robot": "solo12", ...}, "content_hash": "sha256:..."}
``metadata["robot"]`` names the robot the training data was made with; a file without it (the shipped
walk.pt and trot.pt predate the field) is a Solo12 model. ``content_hash`` (`content_hash`) is verified at
load; a file without one (the shipped ones again) has nothing to verify, `rehash` re-saves it with one.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import pickle
import re
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from contactnet.atomic import atomic_write_with
from contactnet.gait import gait_by_name
from contactnet.network_input import (
    INPUT_NAMES,
    N_INPUTS,
    network_input,
    network_input_of_context,
    network_input_of_state,
    network_input_one,
)
from contactnet.robots import DEFAULT_ROBOT

MODEL_FORMAT = "contactnet-model-v1"
HIDDEN = (128, 128, 128)


class ModelFileError(ValueError):
    """A model file that is missing, unreadable, malformed or not the one expected: one-line message."""


def _n_actions_of(gait: str) -> int:
    """N_a of a registered gait; ValueError for an unknown one."""
    return gait_by_name(gait).n_actions


# ---- rank targets ------------------------------------------------------------------------------
def cheapest_first(V: np.ndarray) -> np.ndarray:
    """Indices that order each row of V from the cheapest to the most expensive candidate.

    +inf (infeasible) and NaN sort last; ties keep index order (the lower index counts as cheaper,
    as `np.argmin` does)."""
    return np.argsort(np.asarray(V), axis=-1, kind="stable")


def rank_targets(V: np.ndarray) -> np.ndarray:
    """The paper's targets: Y_a = (position of candidate a in V sorted in decreasing order) / (N_a - 1).

    The cheapest candidate gets 1, the most expensive 0: V = [0.8, 0.3, 0.9] -> Y = [1/2, 1, 0].
    Works on one row (N_a,) or a batch (n, N_a); returns float32 of the same shape. +inf (and NaN)
    count as the most expensive; among equal costs the lower index ranks as cheaper (the decreasing
    order is the exact reverse of the stable cheapest-first order), so argmax Y == argmin V.
    """
    V = np.asarray(V)
    if V.ndim not in (1, 2) or V.shape[-1] < 2:
        raise ValueError(f"rank_targets: V must be (N_a,) or (n, N_a) with N_a >= 2, got shape {V.shape}")
    order = cheapest_first(V)
    n_a = V.shape[-1]
    position_cheapest_first = np.empty(V.shape, dtype=np.int64)
    np.put_along_axis(position_cheapest_first, order, np.arange(n_a).reshape((1,) * (V.ndim - 1) + (n_a,)),
                      axis=-1)
    # position in decreasing order = n_a - 1 - position in increasing order
    return ((n_a - 1 - position_cheapest_first) / (n_a - 1)).astype(np.float32)


# ---- metrics -----------------------------------------------------------------------------------
def topk_accuracy(scores: np.ndarray, V: np.ndarray, k_pred: int = 1, k_true: int = 5) -> float:
    """Fraction of rows where one of the network's `k_pred` best candidates (highest scores) is among
    the `k_true` cheapest candidates of V.

    k_pred=1, k_true=5 is the paper's top-5 metric; k_true=1 is top-1 (argmax scores == argmin V).
    "Among the k cheapest" means: feasible (finite cost) and costing no more than the k-th cheapest,
    which is the paper's definition when costs are distinct, counts exact ties alike, and never
    counts an infeasible (+inf) candidate as a good prediction.
    """
    scores = np.atleast_2d(np.asarray(scores, dtype=np.float64))
    V = np.atleast_2d(np.asarray(V, dtype=np.float64))
    if scores.shape != V.shape:
        raise ValueError(f"topk_accuracy: scores {scores.shape} and V {V.shape} differ in shape")
    n, n_a = V.shape
    if n == 0:
        return float("nan")
    if not (1 <= k_pred <= n_a and 1 <= k_true <= n_a):
        raise ValueError(f"topk_accuracy: k_pred and k_true must be in 1..{n_a}")
    if k_pred == 1:
        pred = np.argmax(scores, axis=1)[:, None]
    else:
        pred = np.argsort(-scores, axis=1, kind="stable")[:, :k_pred]
    kth_cost = np.partition(V, k_true - 1, axis=1)[:, k_true - 1 : k_true]
    pred_cost = np.take_along_axis(V, pred, axis=1)
    good = np.isfinite(pred_cost) & (pred_cost <= kth_cost)
    return float(good.any(axis=1).mean())


# ---- input normalization -----------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Normalizer:
    """Per-input affine map of the training set's [min, max] onto [-1, 1] (the paper's (-1, 1)).

    An input with a (near) zero range in the training set is only centred (scale 1). Inputs outside
    the training range map outside [-1, 1]; nothing is clipped.
    """

    low: np.ndarray  # (14,) training-set minimum of each input
    high: np.ndarray  # (14,) training-set maximum
    names: tuple[str, ...] = INPUT_NAMES
    min_range: float = 1e-9

    def __post_init__(self) -> None:
        low = np.asarray(self.low, dtype=np.float64).reshape(-1)
        high = np.asarray(self.high, dtype=np.float64).reshape(-1)
        if low.shape != high.shape or low.size == 0:
            raise ValueError(f"Normalizer: low {low.shape} and high {high.shape} must be equal non-empty")
        if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
            raise ValueError("Normalizer: low/high must be finite")
        if np.any(high < low):
            raise ValueError("Normalizer: high < low for some input")
        if len(self.names) != low.size:
            raise ValueError(f"Normalizer: {len(self.names)} names for {low.size} inputs")
        low.flags.writeable = False
        high.flags.writeable = False
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)
        object.__setattr__(self, "names", tuple(str(name) for name in self.names))

    @classmethod
    def fit(cls, u: np.ndarray, names: tuple[str, ...] | list[str] = INPUT_NAMES) -> Normalizer:
        u = np.asarray(u, dtype=np.float64)
        if u.ndim != 2 or u.shape[0] == 0:
            raise ValueError(f"Normalizer.fit: need (n, n_inputs) with n >= 1, got {u.shape}")
        return cls(low=u.min(axis=0), high=u.max(axis=0), names=tuple(names))

    @property
    def center(self) -> np.ndarray:
        return (self.low + self.high) / 2

    @property
    def half_range(self) -> np.ndarray:
        half = (self.high - self.low) / 2
        return np.where(half > self.min_range, half, 1.0)

    def normalize(self, u: np.ndarray) -> np.ndarray:
        return (np.asarray(u, dtype=np.float64) - self.center) / self.half_range

    def denormalize(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x, dtype=np.float64) * self.half_range + self.center

    def to_dict(self) -> dict[str, Any]:
        return {"low": [float(v) for v in self.low], "high": [float(v) for v in self.high],
                "names": list(self.names), "min_range": float(self.min_range)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Normalizer:
        if not isinstance(data, dict):
            raise ValueError("normalizer must be a dict")
        missing = [key for key in ("low", "high") if key not in data]
        if missing:
            raise ValueError(f"normalizer lacks {', '.join(missing)}")
        low = data["low"]
        names = data.get("names") or [f"u{i}" for i in range(len(low))]
        return cls(low=np.asarray(low, dtype=np.float64), high=np.asarray(data["high"], dtype=np.float64),
                   names=tuple(names), min_range=float(data.get("min_range", 1e-9)))


# ---- the network -------------------------------------------------------------------------------
class ContactNet(nn.Module):
    """The paper's MLP: 14 -> 128 -> 128 -> 128 -> N_a, ReLU after every layer but the last.

    The paper says "4 fully connected layers with 128 neurons each, all layers except the last one
    are followed by ReLU" with input 14 and output N_a. We read that as four Linear layers: three
    hidden layers of 128 units and the output layer of N_a units (the last layer cannot have 128
    neurons since it outputs one score per candidate). Input: normalized u (see `Normalizer`).
    Output: one score per candidate, trained towards the rank targets (1 = cheapest).
    """

    def __init__(self, n_actions: int, n_inputs: int = N_INPUTS, hidden: tuple[int, ...] = HIDDEN) -> None:
        super().__init__()
        sizes = [n_inputs, *hidden, n_actions]
        layers: list[nn.Module] = []
        for i, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:], strict=True)):
            layers.append(nn.Linear(fan_in, fan_out))
            if i < len(sizes) - 2:
                layers.append(nn.ReLU())
        self.layers = nn.Sequential(*layers)
        self.n_actions = int(n_actions)
        self.n_inputs = int(n_inputs)
        self.hidden = tuple(int(h) for h in hidden)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.layers(x)

    def linears(self) -> list[nn.Linear]:
        return [m for m in self.layers if isinstance(m, nn.Linear)]


class NumpyContactNet:
    """ContactNet forward pass in plain numpy for the planner: raw u in, scores out.

    The normalization is folded into the first layer (W1' = W1 / half_range, b1' = b1 - W1' @ center),
    weights are stored transposed and C-contiguous so one evaluation is four small matmuls.
    """

    def __init__(self, weights: list[np.ndarray], biases: list[np.ndarray], dtype: Any = np.float64) -> None:
        if len(weights) != len(biases) or not weights:
            raise ValueError("NumpyContactNet: need as many weight matrices as bias vectors")
        self.dtype = np.dtype(dtype)
        # weights[i] is (out, in) as in torch; keep the transposes (in, out).
        self._wt = [np.ascontiguousarray(np.asarray(w, dtype=np.float64).T, dtype=self.dtype) for w in weights]
        self._b = [np.ascontiguousarray(b, dtype=self.dtype) for b in biases]
        self.n_inputs = self._wt[0].shape[0]
        self.n_actions = self._wt[-1].shape[1]

    @classmethod
    def from_torch(cls, model: ContactNet, normalizer: Normalizer, dtype: Any = np.float64) -> NumpyContactNet:
        linears = model.linears()
        weights = [lin.weight.detach().cpu().double().numpy().copy() for lin in linears]
        biases = [lin.bias.detach().cpu().double().numpy().copy() for lin in linears]
        if normalizer.low.size != weights[0].shape[1]:
            raise ValueError(f"normalizer has {normalizer.low.size} inputs, network {weights[0].shape[1]}")
        w1 = weights[0] / normalizer.half_range[None, :]
        biases[0] = biases[0] - w1 @ normalizer.center
        weights[0] = w1
        return cls(weights, biases, dtype=dtype)

    def scores(self, u: np.ndarray) -> np.ndarray:
        """(N_a,) scores for one raw input vector u (14,); higher = cheaper candidate. A new array."""
        h = np.asarray(u, dtype=self.dtype)
        if h.shape != (self.n_inputs,):
            raise ValueError(f"scores: u must have shape ({self.n_inputs},), got {h.shape}")
        return self._forward(h)

    def scores_batch(self, U: np.ndarray) -> np.ndarray:
        """(B, N_a) scores for raw inputs U (B, 14)."""
        h = np.asarray(U, dtype=self.dtype)
        if h.ndim != 2 or h.shape[1] != self.n_inputs:
            raise ValueError(f"scores_batch: U must have shape (B, {self.n_inputs}), got {h.shape}")
        return self._forward(h)

    def _forward(self, h: np.ndarray) -> np.ndarray:
        last = len(self._wt) - 1
        for i, (wt, b) in enumerate(zip(self._wt, self._b, strict=True)):
            h = h @ wt
            h += b
            if i < last:
                np.maximum(h, 0.0, out=h)
        return h

    def ranking(self, u: np.ndarray) -> np.ndarray:
        """Candidate indices from best (highest score) to worst; ties keep index order."""
        return np.argsort(-self.scores(u), kind="stable")


# ---- model file --------------------------------------------------------------------------------
#: The largest network a model file may declare. Checked, with every stored tensor's size, before any tensor
#: is read or any network built: a small file cannot make the loader allocate gigabytes.
MAX_HIDDEN_UNITS = 1024
MAX_HIDDEN_LAYERS = 8
MAX_ACTIONS = 4096
MAX_METADATA_BYTES = 1 << 20  #: the pickled dict without its tensors (a shipped file's: 10 KB)
MAX_FILE_BYTES = 8 * ((N_INPUTS + 1) * MAX_HIDDEN_UNITS + (MAX_HIDDEN_LAYERS - 1) * (MAX_HIDDEN_UNITS + 1)
                      * MAX_HIDDEN_UNITS + (MAX_HIDDEN_UNITS + 1) * MAX_ACTIONS) + 2 * MAX_METADATA_BYTES
_HASH = re.compile(r"sha256:[0-9a-f]{64}")


@dataclass
class LoadedModel:
    """A model file, loaded and checked."""

    path: Path
    gait: str
    n_actions: int
    torch_model: ContactNet
    normalizer: Normalizer
    net: NumpyContactNet
    metadata: dict[str, Any] = field(default_factory=dict)
    robot: str = DEFAULT_ROBOT  #: the robot the model was trained for (``metadata["robot"]``)
    content_hash: str | None = None  #: recorded at save and verified; None in files saved before hashes
    file_sha256: str = ""  #: of the file's bytes

    @property
    def identity(self) -> str:
        """What a result made with this model depends on: its content hash, else the file's sha256."""
        return self.content_hash or f"file-sha256:{self.file_sha256}"

    def scores(self, u: np.ndarray) -> np.ndarray:
        return self.net.scores(u)

    def ranking(self, u: np.ndarray) -> np.ndarray:
        return self.net.ranking(u)


def _plain(value: Any, where: str) -> Any:
    """Metadata as plain str/int/float/bool/None/list/dict (numpy scalars converted), else TypeError."""
    if value is None or isinstance(value, bool | np.bool_):
        return None if value is None else bool(value)
    if isinstance(value, str):
        return str(value)  # plain str: subclasses (e.g. torch.__version__) are refused by weights_only loading
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value)
    if isinstance(value, np.ndarray):
        return _plain(value.tolist(), where)
    if isinstance(value, list | tuple):
        return [_plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, dict):
        return {str(k): _plain(v, f"{where}.{k}") for k, v in value.items()}
    raise TypeError(f"metadata {where}: {type(value).__name__} is not a plain value")


def content_hash(gait: str, robot: str, hidden: Any, state: dict[str, torch.Tensor], normalizer: Normalizer) -> str:
    """``sha256:<hex>`` over what decides a model's scores and where it may be used: a JSON header (format,
    gait, robot, hidden sizes, the normalizer's ``to_dict()``, sorted keys), then for each state_dict entry in
    name order its name and shape and its values as little-endian float32. Metadata (training facts) is
    not covered."""
    digest = hashlib.sha256()
    head = {"format": MODEL_FORMAT, "gait": gait, "robot": robot, "hidden": [int(h) for h in hidden],
            "normalizer": normalizer.to_dict()}
    digest.update(json.dumps(head, sort_keys=True).encode())
    for name in sorted(state):
        values = state[name].detach().cpu().to(torch.float32).contiguous().numpy()
        digest.update(f"\n{name} {tuple(values.shape)}\n".encode())
        digest.update(values.astype("<f4", copy=False).tobytes())
    return f"sha256:{digest.hexdigest()}"


def save_model(path: str | os.PathLike, model: ContactNet, normalizer: Normalizer, metadata: dict[str, Any]) -> Path:
    """Write the model file atomically (``contactnet.atomic``: a reader sees the old file or the new one).

    `metadata` must name the `gait`, and may name the `robot` (default Solo12); it is stored as plain
    values (see the module docstring). The file records its `content_hash`, verified at load."""
    path = Path(path)
    gait = metadata.get("gait")
    if gait is None:
        raise ValueError("save_model: metadata must contain 'gait'")
    robot = metadata.get("robot", DEFAULT_ROBOT)
    if not isinstance(robot, str) or not robot:
        raise ValueError(f"save_model: metadata 'robot' must be a robot name, got {robot!r}")
    if _n_actions_of(gait) != model.n_actions:
        raise ValueError(f"save_model: gait {gait!r} has {_n_actions_of(gait)} actions, model {model.n_actions}")
    if normalizer.low.size != model.n_inputs:
        raise ValueError(f"save_model: normalizer has {normalizer.low.size} inputs, model {model.n_inputs}")
    meta = _plain(dict(metadata), "metadata")
    meta["n_actions"] = model.n_actions
    meta["robot"] = robot
    meta.setdefault("normalization", normalizer.to_dict())
    state = {k: v.detach().cpu().float().clone() for k, v in model.state_dict().items()}
    payload = {"format": MODEL_FORMAT, "gait": str(gait), "n_actions": model.n_actions, "n_inputs": model.n_inputs,
               "hidden": list(model.hidden), "state_dict": state, "normalizer": normalizer.to_dict(), "metadata": meta,
               "content_hash": content_hash(str(gait), robot, model.hidden, state, normalizer)}
    return atomic_write_with(path, lambda handle: torch.save(payload, handle))


def rehash(path: str | os.PathLike, out: str | os.PathLike | None = None) -> Path:
    """Load and check a model file (e.g. one saved before files recorded a content hash) and save it again,
    with its hash, to ``out`` (default: over ``path``, atomically): the same weights, normalizer and metadata."""
    loaded = load_model(path)
    return save_model(path if out is None else out, loaded.torch_model, loaded.normalizer,
                      {**loaded.metadata, "gait": loaded.gait, "robot": loaded.robot})


def _first_line(exc: BaseException, limit: int = 120) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    text = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _excerpt(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _read_archive(path: Path, fail: Callable[[str], ModelFileError]) -> io.BytesIO:
    """The file's bytes, once they are known to be a zip archive of bounded declared sizes."""
    if not path.exists():
        raise fail("no such file")
    if not path.is_file():
        raise fail("not a regular file")
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            raise fail(f"is larger than the largest allowed network needs ({MAX_FILE_BYTES} bytes)")
        with open(path, "rb") as handle:
            data = handle.read(MAX_FILE_BYTES + 1)  # bounded even if the file grows meanwhile
    except OSError as exc:
        raise fail(f"cannot be read ({type(exc).__name__})") from None
    if not data:
        raise fail("is empty")
    if len(data) > MAX_FILE_BYTES:
        raise fail(f"is larger than the largest allowed network needs ({MAX_FILE_BYTES} bytes)")
    archive = io.BytesIO(data)
    if not zipfile.is_zipfile(archive):  # torch.save writes a zip archive; a truncated one has no directory
        raise fail("is not a complete torch file (truncated, or some other format)")
    try:
        with zipfile.ZipFile(archive) as listing:
            entries = listing.infolist()
    except (zipfile.BadZipFile, ValueError, OSError) as exc:
        raise fail(f"cannot be read as a torch file, corrupt? ({type(exc).__name__})") from None
    pickled = max((e.file_size for e in entries if e.filename.endswith("data.pkl")), default=0)
    if pickled > MAX_METADATA_BYTES:
        raise fail(f"declares {pickled} bytes of metadata, more than {MAX_METADATA_BYTES}")
    if sum(e.file_size for e in entries) > MAX_FILE_BYTES:
        raise fail(f"declares more content than the largest allowed network needs ({MAX_FILE_BYTES} bytes)")
    return archive


def _torch_load(archive: io.BytesIO, location: str, fail: Callable[[str], ModelFileError]) -> Any:
    """``torch.load`` with weights_only; on ``"meta"`` no tensor data is read or allocated, only shapes."""
    archive.seek(0)
    try:
        return torch.load(archive, map_location=location, weights_only=True)
    except pickle.UnpicklingError:
        raise fail("holds objects other than tensors and plain values (refused by weights_only loading)") from None
    except Exception as exc:  # torch raises many types for corrupt archives
        raise fail(f"cannot be read as a torch file, corrupt? ({type(exc).__name__})") from None


def _layer_shapes(n_inputs: int, hidden: list[int], n_actions: int) -> dict[str, tuple[int, ...]]:
    """The state_dict shapes of ``ContactNet(n_actions, n_inputs, hidden)``, computed without building it."""
    sizes = [n_inputs, *hidden, n_actions]
    shapes: dict[str, tuple[int, ...]] = {}
    for i, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:], strict=True)):
        shapes[f"layers.{2 * i}.weight"] = (fan_out, fan_in)
        shapes[f"layers.{2 * i}.bias"] = (fan_out,)
    return shapes


def _check_state(state: Any, shapes: dict[str, tuple[int, ...]], fail: Callable[[str], ModelFileError],
                 values: bool) -> None:
    """Names, shapes, dtypes and stored sizes (on meta tensors too); finite values when ``values``."""
    if not isinstance(state, dict):
        raise fail("state_dict is not a dict")
    missing_w = sorted(set(shapes) - set(state))
    extra_w = sorted(map(str, set(state) - set(shapes)))
    if missing_w or extra_w:
        parts = ([f"missing {', '.join(missing_w)}"] if missing_w else []) + (
            [f"unexpected {', '.join(extra_w[:4])}"] if extra_w else [])
        raise fail(f"state_dict does not match the network ({'; '.join(parts)})")
    for name, shape in shapes.items():
        tensor = state[name]
        if not isinstance(tensor, torch.Tensor):
            raise fail(f"state_dict[{name!r}] is not a tensor")
        if tuple(tensor.shape) != shape:
            raise fail(f"state_dict[{name!r}] has shape {_excerpt(tuple(tensor.shape))}, expected {shape}")
        if not tensor.is_floating_point() or (values and not bool(torch.isfinite(tensor).all())):
            raise fail(f"state_dict[{name!r}] is not finite floating point")
        stored = tensor.untyped_storage().nbytes()
        if stored > 8 * max(1, math.prod(shape)):
            raise fail(f"state_dict[{name!r}] is stored in {stored} bytes, more than its shape {shape} needs")


def _tensors_outside(payload: dict) -> bool:
    """Whether any tensor lies outside ``state_dict`` (its storage would be read unchecked)."""
    stack, seen = [value for key, value in payload.items() if key != "state_dict"], set()
    while stack:
        value = stack.pop()
        if isinstance(value, torch.Tensor):
            return True
        if id(value) in seen:  # a pickle can make a list that holds itself
            continue
        seen.add(id(value))
        if isinstance(value, dict):
            stack.extend(value.values())
        elif isinstance(value, list | tuple):
            stack.extend(value)
    return False


def load_model(path: str | os.PathLike, expect_gait: str | None = None, expect_n_actions: int | None = None,
               expect_robot: str | None = None, dtype: Any = np.float64) -> LoadedModel:
    """Load and check a model file; any problem raises ModelFileError naming the file.

    ``expect_gait``, ``expect_n_actions``, ``expect_robot``: refuse a model of another gait, size or robot
    (a file that names no robot is a Solo12 model). Order: the archive's declared sizes; the pickled dict
    read with its tensors on the ``meta`` device (no data): metadata, architecture limits, every tensor's
    shape and stored size; only then the tensors' data, their finiteness and the recorded content hash."""
    path = Path(path)

    def fail(problem: str) -> ModelFileError:
        return ModelFileError(f"model file {path}: {problem}")

    archive = _read_archive(path, fail)
    payload = _torch_load(archive, "meta", fail)
    if not isinstance(payload, dict):
        raise fail(f"not a contactnet model (a {type(payload).__name__}, not a dict)")
    if "format" not in payload:
        keys = ", ".join(_excerpt(k, 20) for k in list(payload)[:4])
        raise fail(f"not a contactnet model file (no 'format' key; keys: {keys}...)")
    if payload.get("format") != MODEL_FORMAT:
        raise fail(f"format is {_excerpt(payload.get('format'))}, expected {MODEL_FORMAT!r}")
    missing = [k for k in ("gait", "n_actions", "n_inputs", "hidden", "state_dict", "normalizer", "metadata")
               if k not in payload]
    if missing:
        raise fail(f"missing key(s) {', '.join(missing)}")
    gait = payload["gait"]
    try:
        gait_n_actions = _n_actions_of(gait)
    except (ValueError, TypeError):
        raise fail(f"unknown gait {_excerpt(gait)}") from None
    if expect_gait is not None and gait != expect_gait:
        raise fail(f"is a {gait!r} model, but a {expect_gait!r} model was expected")
    n_actions, n_inputs, hidden = payload["n_actions"], payload["n_inputs"], payload["hidden"]
    if type(n_actions) is not int or n_actions != gait_n_actions or n_actions > MAX_ACTIONS:
        raise fail(f"n_actions is {_excerpt(n_actions)}, but gait {gait!r} has {gait_n_actions}")
    if expect_n_actions is not None and n_actions != expect_n_actions:
        raise fail(f"n_actions is {n_actions}, expected {expect_n_actions}")
    if type(n_inputs) is not int or n_inputs != N_INPUTS:
        raise fail(f"n_inputs is {_excerpt(n_inputs)}, expected {N_INPUTS}")
    if not (isinstance(hidden, list | tuple) and hidden and all(type(h) is int and h > 0 for h in hidden)):
        raise fail(f"hidden sizes {_excerpt(hidden)} are not a list of positive integers")
    if len(hidden) > MAX_HIDDEN_LAYERS or max(hidden) > MAX_HIDDEN_UNITS:
        raise fail(f"hidden sizes {_excerpt(list(hidden))} exceed the limit "
                   f"({MAX_HIDDEN_LAYERS} layers of at most {MAX_HIDDEN_UNITS} units)")
    metadata = payload["metadata"]
    if not isinstance(metadata, dict):
        raise fail("metadata is not a dict")
    robot = metadata.get("robot", DEFAULT_ROBOT)
    if not isinstance(robot, str) or not robot:
        raise fail(f"metadata names the robot {_excerpt(robot)}, not a robot name")
    if expect_robot is not None and robot != expect_robot:
        raise fail(f"is a {robot!r} model, but a {expect_robot!r} model was expected")
    try:
        normalizer = Normalizer.from_dict(payload["normalizer"])
    except (ValueError, TypeError) as exc:
        raise fail(f"bad normalizer ({_first_line(exc)})") from None
    if normalizer.low.size != n_inputs:
        raise fail(f"normalizer has {normalizer.low.size} inputs, expected {n_inputs}")
    recorded = payload.get("content_hash")
    if recorded is not None and not (isinstance(recorded, str) and _HASH.fullmatch(recorded)):
        raise fail(f"content_hash {_excerpt(recorded)} is not 'sha256:' and 64 hex digits")
    shapes = _layer_shapes(n_inputs, list(hidden), n_actions)
    _check_state(payload["state_dict"], shapes, fail, values=False)
    if _tensors_outside(payload):
        raise fail("holds tensors outside state_dict")

    state = _torch_load(archive, "cpu", fail)["state_dict"]  # the same bytes: now with the tensors' data
    _check_state(state, shapes, fail, values=True)
    if recorded is not None and content_hash(gait, robot, hidden, state, normalizer) != recorded:
        raise fail("content hash mismatch: the file was changed after it was saved")
    model = ContactNet(n_actions, n_inputs=n_inputs, hidden=tuple(hidden))
    model.load_state_dict({k: state[k].float() for k in shapes})
    model.eval()
    net = NumpyContactNet.from_torch(model, normalizer, dtype=dtype)
    return LoadedModel(path=path, gait=gait, n_actions=n_actions, torch_model=model, normalizer=normalizer,
                       net=net, metadata=dict(metadata), robot=robot, content_hash=recorded,
                       file_sha256=hashlib.sha256(archive.getbuffer()).hexdigest())


def torch_scores(model: ContactNet, normalizer: Normalizer, u: np.ndarray) -> np.ndarray:
    """Reference (slow path) scores from the torch model for raw inputs u (14,) or (B, 14)."""
    x = torch.as_tensor(normalizer.normalize(u), dtype=torch.float32)
    with torch.no_grad():
        return model(x).numpy()


__all__ = [
    "INPUT_NAMES", "MAX_FILE_BYTES", "MAX_HIDDEN_LAYERS", "MAX_HIDDEN_UNITS", "MODEL_FORMAT", "N_INPUTS",
    "ContactNet", "LoadedModel", "ModelFileError", "Normalizer", "NumpyContactNet", "cheapest_first",
    "content_hash", "load_model", "network_input", "network_input_of_context", "network_input_of_state",
    "network_input_one", "rank_targets", "rehash", "save_model", "topk_accuracy", "torch_scores",
]
