"""What became of a trial, in a few words: the words the summaries, the report and the push experiment count
falls by."""

from __future__ import annotations

from collections import Counter


def outcome(record: dict) -> str:
    """What became of a trial, in a few words: the success, the kind of fall, or the time limit."""
    if record["success"]:
        return "stood the push" if record["trial"].get("push_force_xy") is not None else "reached the goal"
    reason = str(record.get("fall_reason") or "")
    if not record["fell"]:
        return "time limit before the goal"
    if reason.startswith("base height"):
        return "fell: base too low"
    if reason.startswith("base tilted"):
        return "fell: base tilted over"
    if "stepped into a gap" in reason or "stepped into gaps" in reason:
        return "fell: a foot stepped into a gap"
    if "on an edge" in reason:
        return "fell: a leg or the body hit an edge"
    if reason.startswith("non-foot contact"):
        return "fell: a leg or the body touched a top"
    return f"fell: {reason[:40]}"


def falls_by_reason(records: list[dict]) -> dict[str, int]:
    """The failed trials of ``records`` counted by their outcome's words (without "fell: "), most common first."""
    return dict(Counter(outcome(r).removeprefix("fell: ") for r in records if not r["success"]).most_common())


def falls_text(records: list[dict]) -> str:
    """``falls_by_reason`` as one table cell: "base tilted over: 9; a foot stepped into a gap: 2", "-" for none."""
    return "; ".join(f"{reason}: {n}" for reason, n in falls_by_reason(records).items()) or "-"
