"""The ContactNet network: rank targets, the top-k metric, fast numpy inference and the model file
(paper Sec. III-B and IV).

The network maps the 14 inputs u_r of a state (foot XY of FL, FR, HL, HR in the CoM frame, CoM
height, CoM velocity, user velocity) to one score per candidate action; a higher score means a
cheaper (better) candidate. Training regresses the scores onto the paper's rank targets Y.

Two implementations of the same forward pass:
- `ContactNet` (torch, in ``contactnet.planning.network_torch``) for training; it takes *normalized* inputs;
- `NumpyContactNet` for the planner: raw inputs, normalization folded into the first layer, a few
  microseconds per evaluation, no torch call on the hot path.

This module does not import torch: `load_model` reads the model file with ``contactnet.planning.model_file`` and
builds the numpy network; ``LoadedModel.torch_model`` builds the torch one when asked for. The torch names
(`ContactNet`, `save_model`, `torch_scores`, `HIDDEN`) are re-exported from ``contactnet.planning.network_torch``
on first use. The inputs u_r are defined in `contactnet.planning.network_input`, the input normalization in
``contactnet.planning.normalizer`` (both re-exported here).

Model file (``contactnet.registry.model_path(robot, gait)``: ``contactnet/models/{walk,trot}.pt`` for
Solo12): one `torch.save`d dict of plain tensors, strings, numbers and lists, loadable with
`torch.load(path, weights_only=True)`:
    {"format": "contactnet-model-v1", "gait": "walk", "n_actions": 100, "n_inputs": 14,
     "hidden": [128, 128, 128], "state_dict": {name: tensor}, "normalizer": {...},
     "metadata": {"robot": "solo12", ...}, "content_hash": "sha256:..."}
``metadata["robot"]`` names the robot the training data was made with; a file without it (the shipped
walk.pt and trot.pt predate the field) is a Solo12 model. ``content_hash`` (`content_hash`) is verified at
load; a file without one (the shipped ones again) has nothing to verify but its zip checksums, `rehash`
re-saves it with one.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from contactnet.motion.gait import gait_by_name
from contactnet.planning.model_file import (
    MODEL_FORMAT,
    ArchiveError,
    StoredTensor,
    TorchArchive,
    content_hash,
    read_archive,
)
from contactnet.planning.network_input import (
    INPUT_NAMES,
    N_INPUTS,
    network_input,
    network_input_of_context,
    network_input_of_state,
    network_input_one,
)
from contactnet.planning.network_kernel import forward_one
from contactnet.planning.normalizer import Normalizer
from contactnet.robots import DEFAULT_ROBOT

if TYPE_CHECKING:
    from contactnet.planning.network_torch import ContactNet

#: Names that need torch, defined in ``contactnet.planning.network_torch`` and imported from there on first use
#: (``from contactnet.planning.network import ContactNet`` works; ``import contactnet.planning.network`` does not import torch).
_TORCH_NAMES = ("HIDDEN", "ContactNet", "save_model", "torch_scores")


def __getattr__(name: str) -> Any:
    if name in _TORCH_NAMES:
        import contactnet.planning.network_torch

        return getattr(contactnet.planning.network_torch, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class ModelFileError(ValueError):
    """A model file that is missing, unreadable, malformed or not the one expected: one-line message."""


def _n_actions_of(gait: str) -> tuple[int, ...]:
    """The output sizes a model of a registered gait may have: N_a + 1 (the stepping actions, then standing) or
    N_a (a model made before the stand choice: it never stands); ValueError for an unknown gait."""
    spec = gait_by_name(gait)
    return (spec.n_choices, spec.n_actions)


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


# ---- the network in numpy ----------------------------------------------------------------------
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
        self._zeros = [np.zeros(b.shape, dtype=self.dtype) for b in self._b]  # ReLU: max with an array is cheaper
        self._layers = (tuple(self._wt), tuple(self._b))  # for the compiled one-input pass (network_kernel)
        self.n_inputs = self._wt[0].shape[0]
        self.n_actions = self._wt[-1].shape[1]

    @classmethod
    def from_weights(cls, weights: list[np.ndarray], biases: list[np.ndarray], normalizer: Normalizer,
                     dtype: Any = np.float64) -> NumpyContactNet:
        """From the Linear layers' weights (out, in) and biases (as stored: float32) and the normalizer."""
        weights = [np.asarray(w, dtype=np.float64) for w in weights]
        biases = [np.asarray(b, dtype=np.float64) for b in biases]
        if normalizer.low.size != weights[0].shape[1]:
            raise ValueError(f"normalizer has {normalizer.low.size} inputs, network {weights[0].shape[1]}")
        w1 = weights[0] / normalizer.half_range[None, :]
        biases[0] = biases[0] - w1 @ normalizer.center
        weights[0] = w1
        return cls(weights, biases, dtype=dtype)

    @classmethod
    def from_torch(cls, model: ContactNet, normalizer: Normalizer, dtype: Any = np.float64) -> NumpyContactNet:
        linears = model.linears()
        return cls.from_weights([lin.weight.detach().cpu().double().numpy() for lin in linears],
                                [lin.bias.detach().cpu().double().numpy() for lin in linears], normalizer, dtype)

    def scores(self, u: np.ndarray) -> np.ndarray:
        """(N_a,) scores for one raw input vector u (14,); higher = cheaper candidate. A new array."""
        h = np.ascontiguousarray(u, dtype=self.dtype)
        if h.shape != (self.n_inputs,):
            raise ValueError(f"scores: u must have shape ({self.n_inputs},), got {h.shape}")
        return self.scores_unchecked(h)

    def scores_batch(self, U: np.ndarray) -> np.ndarray:
        """(B, N_a) scores for raw inputs U (B, 14)."""
        h = np.asarray(U, dtype=self.dtype)
        if h.ndim != 2 or h.shape[1] != self.n_inputs:
            raise ValueError(f"scores_batch: U must have shape (B, {self.n_inputs}), got {h.shape}")
        return self._forward(h)

    def scores_unchecked(self, u: np.ndarray) -> np.ndarray:
        """``scores`` of u (14,), a contiguous array of the network's dtype, unchecked: the planner's hot path,
        compiled (``contactnet.planning.network_kernel``; the same as ``_forward`` to rounding)."""
        out = np.empty(self.n_actions, dtype=self.dtype)
        forward_one(u, *self._layers, out)
        return out

    def negated(self) -> NumpyContactNet:
        """The network whose scores are exactly minus these (the last layer negated: negation commutes with
        every rounding), so that an ascending stable sort of its output is ``ranking``: one numpy call less."""
        weights = [wt.T for wt in self._wt]
        biases = list(self._b)
        weights[-1], biases[-1] = -weights[-1], -biases[-1]
        return NumpyContactNet(weights, biases, dtype=self.dtype)

    def _forward(self, h: np.ndarray) -> np.ndarray:
        """The forward pass in numpy, of one input (n_in,) or a batch (B, n_in)."""
        last = len(self._wt) - 1
        for i, (wt, b, zeros) in enumerate(zip(self._wt, self._b, self._zeros, strict=True)):
            h = h @ wt
            h += b
            if i < last:
                np.maximum(h, zeros, out=h)
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
    """A model file, loaded and checked (`load_model`): the numpy network for inference and what the file
    says. ``torch_model`` is built from the weights (importing torch) only when asked for."""

    path: Path
    gait: str
    n_actions: int
    normalizer: Normalizer
    net: NumpyContactNet
    #: the Linear layers' weights and biases as stored, float32 and read-only, named as ContactNet's state_dict
    state_dict: dict[str, np.ndarray] = field(default_factory=dict, repr=False, compare=False)
    hidden: tuple[int, ...] = ()  #: hidden layer sizes
    metadata: dict[str, Any] = field(default_factory=dict)
    robot: str = DEFAULT_ROBOT  #: the robot the model was trained for (``metadata["robot"]``)
    content_hash: str | None = None  #: recorded at save and verified; None in files saved before hashes
    file_sha256: str = ""  #: of the file's bytes

    @functools.cached_property
    def torch_model(self) -> ContactNet:
        """The torch `ContactNet` (eval mode) with these weights, built on first use: training, `rehash`, tests."""
        from contactnet.planning.network_torch import contactnet_of_state

        return contactnet_of_state(self.state_dict, self.n_actions, self.net.n_inputs, self.hidden)

    @property
    def identity(self) -> str:
        """What a result made with this model depends on: its content hash, else the file's sha256."""
        return self.content_hash or f"file-sha256:{self.file_sha256}"

    def scores(self, u: np.ndarray) -> np.ndarray:
        return self.net.scores(u)

    def ranking(self, u: np.ndarray) -> np.ndarray:
        return self.net.ranking(u)


def rehash(path: str | os.PathLike, out: str | os.PathLike | None = None) -> Path:
    """Load and check a model file (e.g. one saved before files recorded a content hash) and save it again,
    with its hash, to ``out`` (default: over ``path``, atomically): the same weights, normalizer and metadata."""
    from contactnet.planning.network_torch import save_model

    loaded = load_model(path)
    return save_model(path if out is None else out, loaded.torch_model, loaded.normalizer,
                      {**loaded.metadata, "gait": loaded.gait, "robot": loaded.robot})


def _first_line(exc: BaseException, limit: int = 120) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    text = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _excerpt(value: Any, limit: int = 60) -> str:
    try:
        text = repr(value)
    except RecursionError:  # a pickle can nest lists a million deep
        return f"a deeply nested {type(value).__name__}"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _layer_shapes(n_inputs: int, hidden: list[int], n_actions: int) -> dict[str, tuple[int, ...]]:
    """The state_dict shapes of ``ContactNet(n_actions, n_inputs, hidden)``, computed without building it."""
    sizes = [n_inputs, *hidden, n_actions]
    shapes: dict[str, tuple[int, ...]] = {}
    for i, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:], strict=True)):
        shapes[f"layers.{2 * i}.weight"] = (fan_out, fan_in)
        shapes[f"layers.{2 * i}.bias"] = (fan_out,)
    return shapes


def _check_state(state: Any, shapes: dict[str, tuple[int, ...]],
                 fail: Callable[[str], ModelFileError]) -> dict[str, StoredTensor]:
    """Names, shapes, dtypes and declared storage sizes of the stored tensors (nothing read yet)."""
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
        if not isinstance(tensor, StoredTensor):
            raise fail(f"state_dict[{name!r}] is not a tensor")
        if tensor.shape != shape:
            raise fail(f"state_dict[{name!r}] has shape {_excerpt(tensor.shape)}, expected {shape}")
        if not tensor.floating:
            raise fail(f"state_dict[{name!r}] is not finite floating point")
        if tensor.stored_bytes > 8 * max(1, math.prod(shape)):
            raise fail(f"state_dict[{name!r}] is stored in {tensor.stored_bytes} bytes, more than its shape {shape} "
                       "needs")
    return {name: state[name] for name in shapes}


def _tensors_outside(payload: dict) -> bool:
    """Whether any tensor lies outside ``state_dict`` (its storage would be read unchecked)."""
    stack, seen = [value for key, value in payload.items() if key != "state_dict"], set()
    while stack:
        value = stack.pop()
        if isinstance(value, StoredTensor):
            return True
        if id(value) in seen:  # a pickle can make a list that holds itself
            continue
        seen.add(id(value))
        if isinstance(value, dict):
            stack.extend(value.values())
        elif isinstance(value, list | tuple):
            stack.extend(value)
    return False


def _read_weights(archive: TorchArchive, tensors: dict[str, StoredTensor],
                  fail: Callable[[str], ModelFileError]) -> dict[str, np.ndarray]:
    """The checked tensors' values as read-only float32 arrays (torch's ``.float()``); finite."""
    state: dict[str, np.ndarray] = {}
    for name, tensor in tensors.items():
        try:
            with np.errstate(over="ignore"):  # a float64 beyond float32's range becomes inf: refused below
                values = archive.read(tensor).astype(np.float32, copy=False)
        except ArchiveError as exc:
            raise fail(str(exc)) from None
        if not np.isfinite(values).all():
            raise fail(f"state_dict[{name!r}] is not finite floating point")
        values.flags.writeable = False
        state[name] = values
    return state


def load_model(path: str | os.PathLike, expect_gait: str | None = None, expect_n_actions: int | None = None,
               expect_robot: str | None = None, dtype: Any = np.float64) -> LoadedModel:
    """Load and check a model file, without torch; any problem raises ModelFileError naming the file.

    ``expect_gait``, ``expect_n_actions``, ``expect_robot``: refuse a model of another gait, size or robot
    (a file that names no robot is a Solo12 model). Order: the archive's declared sizes; the pickled dict,
    read through an allow-list with its tensors as declarations (``contactnet.planning.model_file``: no data):
    metadata, architecture limits, every tensor's shape and stored size; only then the tensors' data (each
    entry's real size against its declared one), their finiteness, the recorded content hash and the zip
    checksums. ``dtype``: of the numpy network's arithmetic."""
    path = Path(path)

    def fail(problem: str) -> ModelFileError:
        return ModelFileError(f"model file {path}: {problem}")

    try:
        archive = read_archive(path, MAX_FILE_BYTES, MAX_METADATA_BYTES)
        payload = archive.payload()
    except ArchiveError as exc:
        raise fail(str(exc)) from None
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
    if type(n_actions) is not int or n_actions not in gait_n_actions or n_actions > MAX_ACTIONS:
        raise fail(f"n_actions is {_excerpt(n_actions)}, but gait {gait!r} has {gait_n_actions[0]} choices "
                   f"({gait_n_actions[1]} actions and standing)")
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
    except (ValueError, TypeError, RecursionError) as exc:
        raise fail(f"bad normalizer ({_first_line(exc)})") from None
    if normalizer.low.size != n_inputs:
        raise fail(f"normalizer has {normalizer.low.size} inputs, expected {n_inputs}")
    recorded = payload.get("content_hash")
    if recorded is not None and not (isinstance(recorded, str) and _HASH.fullmatch(recorded)):
        raise fail(f"content_hash {_excerpt(recorded)} is not 'sha256:' and 64 hex digits")
    shapes = _layer_shapes(n_inputs, list(hidden), n_actions)
    tensors = _check_state(payload["state_dict"], shapes, fail)
    if _tensors_outside(payload):
        raise fail("holds tensors outside state_dict")

    state = _read_weights(archive, tensors, fail)  # the first tensor data read
    if recorded is not None and content_hash(gait, robot, hidden, state, normalizer) != recorded:
        raise fail("content hash mismatch: the file was changed after it was saved")
    try:
        archive.check_checksums(tensors.values())
    except ArchiveError as exc:
        raise fail(str(exc)) from None
    names = list(shapes)  # layers.0.weight, layers.0.bias, layers.2.weight, ...
    net = NumpyContactNet.from_weights([state[n] for n in names[0::2]], [state[n] for n in names[1::2]],
                                       normalizer, dtype=dtype)
    return LoadedModel(path=path, gait=gait, n_actions=n_actions, normalizer=normalizer, net=net, state_dict=state,
                       hidden=tuple(hidden), metadata=dict(metadata), robot=robot, content_hash=recorded,
                       file_sha256=hashlib.sha256(archive.data).hexdigest())


#: Without the torch names (`_TORCH_NAMES`): ``from contactnet.planning.network import *`` does not import torch.
__all__ = [
    "INPUT_NAMES", "MAX_FILE_BYTES", "MAX_HIDDEN_LAYERS", "MAX_HIDDEN_UNITS", "MODEL_FORMAT", "N_INPUTS",
    "LoadedModel", "ModelFileError", "Normalizer", "NumpyContactNet", "cheapest_first", "content_hash",
    "load_model", "network_input", "network_input_of_context", "network_input_of_state", "network_input_one",
    "rank_targets", "rehash", "topk_accuracy",
]
