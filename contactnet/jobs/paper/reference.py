"""The paper's own results (Sec. IV, Tables I and II, and what its text says where it gives no number), quoted
beside ours in the report. Source: ../shared/PAPER-NOTES.md and the paper's LaTeX."""

from __future__ import annotations

from contactnet.jobs.paper.results import Rate

#: Table I: mean planner time (ms, 3 network evaluations) in one attempt, per squares removed n
TABLE1_MS = {"walk": {50: 1.272, 60: 0.938, 70: 0.944, 80: 1.152, 90: 1.0584, 100: 0.9167},
             "trot": {50: 1.507, 60: 7.950, 70: 0.803, 80: 0.785, 90: 0.874, 100: 0.7899}}
#: Table II: n = 110, 300 attempts; the rates as printed (281 / 300 is 93.67 %)
TABLE2 = {"contactnet": Rate(281, 300), "fixed": Rate(256, 300)}
TABLE2_PERCENT = {"contactnet": 93.6, "fixed": 85.3}
#: what the text says, per result
SAYS = {
    "fig5": "high success for both gaits, the walk above the trot; noise no significant reduction (a figure "
            "without numbers in the text)",
    "fig5 walk": "high (a figure without numbers in the text)",
    "fig5 trot": "high, below the walk",
    "fig5 noise": "no significant reduction",
    "push": "recovers from pushes of up to +-5 N for 1 s in both directions (no numbers)",
    "stepping_stones": "ContactNet crosses; on average the 6th element of the ranking chosen, at most 30 "
                       "discarded; 1.6 ms mean planner time",
    "narrow_stones": "the fixed cyclic gait fails, the acyclic ContactNet crosses",
}
