"""How far inside a top a foothold must be: all around it, and further on in one direction.

`Terrain.is_safe` and `Terrain.safe_locator` take a margin in metres (the steppable set shrunk by it) or an
`EdgeMargin`: that shrunk set, keeping only the points whose point ``ahead_xy_m`` further on (world frame) is in it
too. The planner uses the second for a ball foot that will roll along the walking direction while it stands
(``contactnet.planning.roll``). Its region is the shrunk set intersected with itself moved back by ``ahead_xy_m``:
exact, built once per margin and cached on the terrain like the plain margins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The longest ``ahead_xy_m`` accepted, metres (a roll of several centimetres means something else is wrong).
MAX_AHEAD_M = 0.1


@dataclass(frozen=True)
class EdgeMargin:
    """A foothold at least ``around_m`` from every edge of its top, and the point ``ahead_xy_m`` (world x, y,
    metres) further on also at least ``around_m`` inside."""

    around_m: float
    ahead_xy_m: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        if (isinstance(self.around_m, bool) or not isinstance(self.around_m, int | float)
                or not math.isfinite(self.around_m) or self.around_m < 0.0):
            raise ValueError(f"edge margin: around_m must be a finite number >= 0 (metres), got {self.around_m!r}")
        ahead = self.ahead_xy_m
        if (not isinstance(ahead, tuple) or len(ahead) != 2
                or not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in ahead)
                or math.hypot(*ahead) > MAX_AHEAD_M):
            raise ValueError(f"edge margin: ahead_xy_m must be two finite numbers (metres) at most {MAX_AHEAD_M:g} m "
                             f"long, got {ahead!r}")

    @property
    def key(self) -> tuple[str, float, float, float]:
        """The terrain's cache key of this margin's safe region."""
        return ("ahead", float(self.around_m), float(self.ahead_xy_m[0]), float(self.ahead_xy_m[1]))


__all__ = ["MAX_AHEAD_M", "EdgeMargin"]
