"""The stored results of a paper run, read back for the report: each section's current trials and the
numbers the report's tables and plots are made of.

A section's current trials are those its folder's ``experiment.json`` names (the last run's plan) whose
logged record has the fingerprint it names; other records in ``trials.jsonl`` (other code, models or
settings) are left out. Nothing is run and no file is written.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from contactnet.jobs.experiment import ExperimentError
from contactnet.jobs.outcome import outcome
from contactnet.jobs.paper.layout import read_header
from contactnet.jobs.paper.stats import wilson_interval


@dataclass(frozen=True)
class SectionResult:
    """One section of the run: its title, its current trial records (in plan order), how many trials the
    run planned and how many the full plan has."""

    folder: str
    experiment: str
    title: str
    records: list[dict]
    planned: int
    full: int


def _records(log: Path) -> Iterable[dict]:
    """The log's records; lines that are not records (a line cut by a kill) are skipped."""
    if not log.exists():
        return
    for line in log.read_text().splitlines():
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(record, dict) and isinstance(record.get("key"), str):
            yield record


def load_section(out: Path, entry: dict) -> SectionResult:
    folder = out / entry["folder"]
    try:
        fingerprints = json.loads((folder / "experiment.json").read_text())["trials"]
    except (OSError, ValueError, KeyError, TypeError):
        fingerprints = {}
    current = {r["key"]: r for r in _records(folder / "trials.jsonl") if fingerprints.get(r["key"]) == r.get("fingerprint")}
    return SectionResult(entry["folder"], entry["experiment"], entry["title"],
                         [current[key] for key in fingerprints if key in current], len(fingerprints),
                         int(entry.get("trials_full", 0)))


def load_results(out: str | Path) -> tuple[dict, dict[str, SectionResult]]:
    """DIR's header (paper.json) and its sections' results by folder."""
    out = Path(out)
    if not out.is_dir():
        raise ExperimentError(f"{out}: not a directory")
    header = read_header(out)
    if header is None or not isinstance(header.get("sections"), list):
        raise ExperimentError(f"{out}: no paper.json: not a folder of `contactnet experiment paper`")
    return header, {entry["folder"]: load_section(out, entry) for entry in header["sections"]}


# ---- numbers ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Rate:
    """``successes`` of ``trials`` with the 95 % Wilson interval (``low``, ``high``)."""

    successes: int
    trials: int

    @property
    def rate(self) -> float:
        return self.successes / self.trials if self.trials else float("nan")

    @property
    def interval(self) -> tuple[float, float]:
        return wilson_interval(self.successes, self.trials)

    def text(self) -> str:
        """e.g. "98 / 100 (98.0 %, 93.0-99.4)"; "-" without trials."""
        if not self.trials:
            return "-"
        low, high = self.interval
        return f"{self.successes} / {self.trials} ({100 * self.rate:.1f} %, {100 * low:.1f}-{100 * high:.1f})"


def rate_of(records: list[dict]) -> Rate:
    return Rate(sum(bool(r["success"]) for r in records), len(records))


#: The order of the report's rows: these values first, in this order, then the others (numbers by value).
ROW_ORDER = {value: rank for rank, value in enumerate(
    ("walk", "trot", "contactnet", "fixed", "heuristic", "oracle", "+x", "-x", "+y", "-y"))}


def _row_key(value: object) -> tuple:
    if isinstance(value, str):
        return (0, ROW_ORDER.get(value, len(ROW_ORDER)), value)
    if isinstance(value, int | float):
        return (1, 0, float(value))
    return (2, 0, str(value))


def group(records: list[dict], key: Callable[[dict], tuple]) -> dict[tuple, list[dict]]:
    """The records by ``key(record["trial"])``, in the report's row order (walk before trot, ContactNet before
    the fixed gait, numbers by value)."""
    groups: dict[tuple, list[dict]] = {}
    for r in records:
        groups.setdefault(key(r["trial"]), []).append(r)
    return {k: groups[k] for k in sorted(groups, key=lambda k: tuple(map(_row_key, k)))}


def outcomes(records: list[dict]) -> Counter:
    return Counter(outcome(r) for r in records)


def samples(records: list[dict], name: str) -> np.ndarray:
    """Every call's time (ms) of ``name`` ("planner" or "trajopt") over the records."""
    parts = [np.asarray(r.get(f"{name}_ms_samples", []), dtype=float) for r in records]
    return np.concatenate(parts) if parts else np.zeros(0)


def mean_of_trial_means(records: list[dict], name: str) -> float:
    """The mean over trials of each trial's mean time of ``name`` ("planner_ms", "trajopt_ms"): the paper's
    Table I statistic (the mean time in one attempt, averaged over the attempts)."""
    values = [r[name]["mean"] for r in records if r.get("steps")]
    return float(np.mean(values)) if values else float("nan")


def models(records: Iterable[dict]) -> dict[str, Counter]:
    """The models' content hashes (`LoadedModel.identity`) by gait, with how many trials used each."""
    found: dict[str, Counter] = {}
    for r in records:
        identity = (r.get("inputs") or {}).get("model")
        if identity is not None:
            found.setdefault(r["trial"]["gait"], Counter())[identity] += 1
    return found
