"""Where contactnet keeps files of its own outside the package: the per-user cache and data folders."""

from __future__ import annotations

import os
from pathlib import Path


def default_cache_dir() -> Path:
    """Per-user cache for generated files ($CONTACTNET_CACHE, else $XDG_CACHE_HOME/contactnet)."""
    env = os.environ.get("CONTACTNET_CACHE")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "contactnet"


def default_data_dir() -> Path:
    """Per-user data (user terrains, recordings): $CONTACTNET_DATA, else $XDG_DATA_HOME/contactnet."""
    env = os.environ.get("CONTACTNET_DATA")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_DATA_HOME", Path.home() / ".local" / "share")) / "contactnet"
