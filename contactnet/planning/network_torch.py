"""The torch side of ContactNet: the `ContactNet` module that training fits, `save_model` that writes the
model file, the network rebuilt from a loaded file's weights, and reference scores (paper Sec. III-B, IV).

Only training, saving and tests import this module (and so torch); loading a model file for the planner
does not (``contactnet.planning.network.load_model`` reads it with ``contactnet.planning.model_file``, inference is numpy).
``contactnet.planning.network`` re-exports these names when they are asked for.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from contactnet.atomic import atomic_write_with
from contactnet.extras import import_torch
from contactnet.motion.gait import gait_by_name
from contactnet.planning.model_file import MODEL_FORMAT, content_hash
from contactnet.planning.network_input import N_INPUTS
from contactnet.planning.normalizer import Normalizer
from contactnet.robots import DEFAULT_ROBOT

torch = import_torch()  # MissingExtra without the extra ``train``: one line saying how to get it
nn = torch.nn

HIDDEN = (128, 128, 128)


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


def contactnet_of_state(state: Mapping[str, np.ndarray], n_actions: int, n_inputs: int,
                        hidden: tuple[int, ...]) -> ContactNet:
    """A `ContactNet` in eval mode holding ``state`` (float32 arrays named as its state_dict; copied)."""
    model = ContactNet(n_actions, n_inputs=n_inputs, hidden=tuple(hidden))
    model.load_state_dict({name: torch.from_numpy(np.array(values, dtype=np.float32))  # a writable copy
                           for name, values in state.items()})
    model.eval()
    return model


def _plain(value: Any, where: str) -> Any:
    """Metadata as plain str/int/float/bool/None/list/dict (numpy scalars converted), else TypeError."""
    if value is None or isinstance(value, bool | np.bool_):
        return None if value is None else bool(value)
    if isinstance(value, str):
        return str(value)  # plain str: subclasses (e.g. torch.__version__) are refused by the loader
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


def save_model(path: str | os.PathLike, model: ContactNet, normalizer: Normalizer, metadata: dict[str, Any]) -> Path:
    """Write the model file atomically (``contactnet.atomic``: a reader sees the old file or the new one).

    `metadata` must name the `gait`, and may name the `robot` (default Solo12); it is stored as plain
    values (see ``contactnet.planning.network``). The file records its `content_hash`, verified at load."""
    path = Path(path)
    gait = metadata.get("gait")
    if gait is None:
        raise ValueError("save_model: metadata must contain 'gait'")
    robot = metadata.get("robot", DEFAULT_ROBOT)
    if not isinstance(robot, str) or not robot:
        raise ValueError(f"save_model: metadata 'robot' must be a robot name, got {robot!r}")
    spec = gait_by_name(gait)
    if model.n_actions not in (spec.n_choices, spec.n_actions):
        raise ValueError(f"save_model: gait {gait!r} has {spec.n_choices} choices ({spec.n_actions} actions and "
                         f"standing), model {model.n_actions} outputs")
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


def torch_scores(model: ContactNet, normalizer: Normalizer, u: np.ndarray) -> np.ndarray:
    """Reference (slow path) scores from the torch model for raw inputs u (14,) or (B, 14)."""
    x = torch.as_tensor(normalizer.normalize(u), dtype=torch.float32)
    with torch.no_grad():
        return model(x).numpy()


__all__ = ["HIDDEN", "ContactNet", "contactnet_of_state", "save_model", "torch_scores"]
