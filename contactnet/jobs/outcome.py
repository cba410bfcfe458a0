"""What became of a trial, in a few words: the words the summaries, the report and the push experiment count
falls by."""

from __future__ import annotations


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
