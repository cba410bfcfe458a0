"""Confidence intervals of success rates and of the difference of two."""

from __future__ import annotations

import math
from statistics import NormalDist


def wilson_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval (no continuity correction) of a success rate: ``successes`` of ``trials``
    Bernoulli trials, two-sided at ``confidence``. (0, 1) for no trials."""
    if not 0 <= successes <= trials:
        raise ValueError(f"successes must be in 0..trials, got {successes} of {trials}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    if trials == 0:
        return 0.0, 1.0
    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    p = successes / trials
    z2n = z * z / trials
    center = (p + z2n / 2) / (1 + z2n)
    half = z / (1 + z2n) * math.sqrt(p * (1 - p) / trials + z2n / (4 * trials))
    low = 0.0 if successes == 0 else max(0.0, center - half)
    high = 1.0 if successes == trials else min(1.0, center + half)
    return low, high


def difference_interval(successes_a: int, trials_a: int, successes_b: int, trials_b: int,
                        confidence: float = 0.95) -> tuple[float, float]:
    """Newcombe's hybrid score interval (1998, method 10) of the difference of two success rates, a's minus b's,
    from each rate's Wilson interval: ``d - sqrt((p_a - l_a)^2 + (u_b - p_b)^2)`` to ``d + sqrt((u_a - p_a)^2 +
    (p_b - l_b)^2)``. It treats the two samples as independent; on paired trials (the same terrains) it is
    conservative. (-1, 1) when either side has no trials."""
    if trials_a == 0 or trials_b == 0:
        return -1.0, 1.0
    p_a, p_b = successes_a / trials_a, successes_b / trials_b
    low_a, high_a = wilson_interval(successes_a, trials_a, confidence)
    low_b, high_b = wilson_interval(successes_b, trials_b, confidence)
    d = p_a - p_b
    return (max(-1.0, d - math.hypot(p_a - low_a, high_b - p_b)),
            min(1.0, d + math.hypot(high_a - p_a, p_b - low_b)))
