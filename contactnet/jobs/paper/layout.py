"""The folder of a paper run: its header, ``DIR/paper.json``, read and checked."""

from __future__ import annotations

import json
from pathlib import Path

from contactnet.jobs.experiment import ExperimentError

HEADER_FORMAT = "contactnet-paper-v1"
HEADER_NAME = "paper.json"


def read_header(out: Path) -> dict | None:
    """DIR's paper.json, or None when there is none. Raises ExperimentError when DIR is not a folder of this
    command (a file, a single experiment's folder, another header)."""
    if out.exists() and not out.is_dir():
        raise ExperimentError(f"{out} exists and is not a directory")
    if (out / "experiment.json").exists():
        raise ExperimentError(f"{out} holds a single experiment (experiment.json), not the paper's; use another --out")
    path = out / HEADER_NAME
    if not path.exists():
        return None
    try:
        header = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        raise ExperimentError(f"{path}: unreadable header") from None
    if not isinstance(header, dict) or header.get("format") != HEADER_FORMAT or not isinstance(header.get("runs"), list):
        raise ExperimentError(f"{path}: not a {HEADER_FORMAT} header")
    return header
