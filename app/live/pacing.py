"""How the live session keeps real time (`Pacing`) and what it measures of it (`PacingStats`): the
session thread advances the simulation in chunks toward `speed x wall time` (`app/live/session.py`)."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Pacing:
    """How the session thread keeps real time."""

    chunk_ticks: int = 10  #: control ticks (1 ms) simulated between two looks at the queue
    max_lag_s: float = 1.0  #: further behind than this: drop the debt instead of catching up
    publish_period_s: float = 1.0 / 60.0  #: a new LiveView at most this often while running


@dataclass
class PacingStats:
    """Wall and simulated time spent running (paused time excluded), for the real-time factor."""

    running_wall_s: float = 0.0
    running_sim_s: float = 0.0
    lag_resets: int = 0
    behind_s: float = 0.0  #: how far the simulation was behind its schedule (speed x wall time) at the last look
    longest_stall_s: float = 0.0  #: longest wall time between two loop iterations while running
    history: deque = field(default_factory=lambda: deque(maxlen=240))  #: (wall, wall running, sim running)

    def account(self, gap_s: float) -> None:
        """``gap_s`` more wall seconds spent running."""
        self.running_wall_s += gap_s
        self.longest_stall_s = max(self.longest_stall_s, gap_s)

    def real_time_factor(self, wall: float, window_s: float = 2.0) -> float:
        """Simulated over wall time while running, over the last ``window_s`` (0 with too little data)."""
        self.history.append((wall, self.running_wall_s, self.running_sim_s))
        for then in self.history:
            if wall - then[0] <= window_s:
                d_wall = self.running_wall_s - then[1]
                return (self.running_sim_s - then[2]) / d_wall if d_wall > 0.2 else 0.0
        return 0.0
