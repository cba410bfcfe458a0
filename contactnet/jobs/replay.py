"""Replay one stored experiment trial: ``contactnet replay DIR KEY``.

The trial is rebuilt from its record in ``DIR/trials.jsonl`` (or, for a paper run, in ``DIR/<section>/trials.jsonl``),
run again in this process with the code and models installed now, and its outcome set beside the stored one. The
outcomes differ only where the code or the models changed since the trial ran (the record's ``fingerprint``
names the code it ran on): the way to tell a change of behaviour from luck, and to look at one fall closely.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

from contactnet.jobs.experiment import ExperimentError, Trial, read_log, run_trial
from contactnet.sim.mismatch import ModelMismatch

if TYPE_CHECKING:
    from contactnet.jobs.trace import LoopTrace


def trial_from_record(record: dict) -> Trial:
    """The ``Trial`` a record of ``trials.jsonl`` was run from (JSON lists back to tuples, the mismatch back to
    a ``ModelMismatch``)."""
    fields = dict(record["trial"])
    names = {f.name for f in dataclasses.fields(Trial)}
    unknown = sorted(set(fields) - names)
    if unknown:
        raise ExperimentError(f"trial {record.get('key')!r}: fields this version does not know: {', '.join(unknown)}")
    for name, value in fields.items():
        if isinstance(value, list):
            fields[name] = tuple(value)
    fields.setdefault("observer", False)  # a record from before the observer existed ran without it
    mismatch = fields.get("mismatch")
    if isinstance(mismatch, dict):
        fields["mismatch"] = ModelMismatch(**{k: tuple(v) if isinstance(v, list) else v for k, v in mismatch.items()})
    return Trial(**fields)


def find_record(out: str | Path, key: str) -> dict:
    """The last record of trial ``key`` in the experiment folder ``out`` (its ``trials.jsonl``, or those of its
    section folders); an ``ExperimentError`` naming the folder when there is none."""
    out = Path(out)
    logs = [out / "trials.jsonl"] if (out / "trials.jsonl").exists() else sorted(out.glob("*/trials.jsonl"))
    if not logs:
        raise ExperimentError(f"{out}: no trials.jsonl here (nor in its section folders)")
    found = [record for log in logs for record in read_log(log) if record["key"] == key]
    if not found:
        raise ExperimentError(f"{out}: no trial {key!r} (the keys are the 'key' fields of trials.jsonl)")
    return found[-1]


def replay(out: str | Path, key: str, trace: LoopTrace | None = None) -> tuple[dict, dict]:
    """(the stored record, the record of running it again now) of trial ``key`` in ``out``; ``trace``: sampled on
    the way (``contactnet.jobs.trace``)."""
    stored = find_record(out, key)
    return stored, run_trial(trial_from_record(stored), trace=trace)


__all__ = ["find_record", "replay", "trial_from_record"]
