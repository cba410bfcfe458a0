"""Input normalization of the network: each input's training-set range mapped onto [-1, 1] (paper Sec. IV).

Torch-free: the planner's numpy network, the model file's loader and the torch network all use it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from contactnet.planning.network_input import INPUT_NAMES


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


__all__ = ["Normalizer"]
