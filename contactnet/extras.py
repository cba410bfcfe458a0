"""The optional parts of contactnet (the extras of its package) and the one line that says how to get a missing one.

torch is needed only to train a network (``contactnet train``, saving a model file): the planner, ``simulate``,
``serve``, ``experiment`` and ``datagen`` read model files and rank with numpy. It is the extra ``train``
(``pip install 'contactnet[train]'``; ``make setup`` installs it). Without it, what needs torch ends in
``MissingExtra``, one line on the command line.
"""

from __future__ import annotations

import importlib
from types import ModuleType

#: torch's pin (a CPU build is on the package index for it; another version pulls the CUDA packages).
TORCH_REQUIREMENT = "torch==2.13.0"


class MissingExtra(ImportError):
    """A package of an extra that is not installed: one line naming the extra to install."""


def import_torch(what: str = "training a network") -> ModuleType:
    """``torch``, or ``MissingExtra`` saying that ``what`` needs the extra ``train``."""
    try:
        return importlib.import_module("torch")
    except ImportError:
        raise MissingExtra(f"{what} needs torch, which contactnet installs only for training: "
                           f"pip install 'contactnet[train]' ({TORCH_REQUIREMENT})") from None


def has_torch() -> bool:
    """Whether torch can be imported (without importing it twice)."""
    try:
        importlib.import_module("torch")
    except ImportError:
        return False
    return True


__all__ = ["TORCH_REQUIREMENT", "MissingExtra", "has_torch", "import_torch"]
