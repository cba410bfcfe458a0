"""The roll allowance (issue 27): a ball foot rolls forward while it stands, so a landing keeps room ahead.

Traced on the walk's falls with a robot that is not the model (random field, 80 squares removed, mass x 1.2 and
friction 0.5: 12 falls in 200 trials, all a front foot in a gap): the foot landed inside its square, closer to the
edge ahead than a foot radius, and stood there for seconds while the body passed over it. A ball under a shin that
turns rolls: its contact point moved 1.3 cm forward over one stance (up to 5 cm with friction 0.5), until the
ball stood beyond the edge, held by it; at lift-off it dropped into the hole. The roll over a stance is about the
foot radius times the shin's turn, (stance travel) / (leg length): for Solo12's walk 16 mm x (20 cm / 32 cm),
1.0 cm; tangential forces stayed at 5 % of the normal ones (rolling, not slip).

So the planner asks for more than the landing point's margin where it can: once the network's ranking has given
the first safe action, the same legs' first cells in the ranking whose point ``allowance_radii`` foot radii
further on along the commanded velocity (world frame) is safe too replace its cells (``Terrain.is_safe`` of both
points with the plain margin; the planner's compiled walk makes the second lookup in the same raster, in the
same call as the first walk, ``ranking.OneLevelWalk.first_safe_with_room``; on terrain with heights the walk with
the height checks is asked again with the actions lacking the room ranked last,
``ContactNetPlanner._with_room_on_heights``; only with ``RollConfig(heights=True)``, off by default). The network's
choice of legs stands: asking every action for the room first (a first version) made the walk move other legs
rather than step onto narrow bars, and `narrow_map` fell from 84 to 57 / 100. Where those legs have no cell with
room (3 cm bars) the plain choice stands. A command below ``min_speed_m_s`` (standing, turning on the spot) has no
direction and no allowance. ``ContactNetPlanner(roll=None)`` turns it off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class RollConfig:
    """How much room ahead a landing keeps for its foot's roll."""

    allowance_radii: float = 0.75  # the point this many foot radii ahead must be safe (12 mm for Solo12)
    min_speed_m_s: float = 0.005  # below this command speed: no direction, no allowance
    #: on terrain with tops at several heights too (off: measured, it helped MuJoCo's walk on the raised stones
    #: and hurt PyBullet's, docs/results.md "The room for the roll on terrain with heights")
    heights: bool = False

    def __post_init__(self) -> None:
        for name in ("allowance_radii", "min_speed_m_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"RollConfig.{name} must be a finite number >= 0, got {value!r}")


#: The planners' default: the allowance on (``ContactNetPlanner(roll=None)`` turns it off).
DEFAULT_ROLL = RollConfig()


def roll_ahead_xy(foot_radius_m: float, cmd_world_xy: tuple[float, float] | list[float],
                  config: RollConfig | None) -> tuple[float, float] | None:
    """The room ahead (world x, y, metres) along the commanded velocity ``cmd_world_xy`` (m/s, world), None when
    there is none to ask for (``config`` None, no allowance, or a command too slow to have a direction). Runs in
    every plan: Python floats."""
    if config is None or config.allowance_radii == 0.0:
        return None
    vx, vy = float(cmd_world_xy[0]), float(cmd_world_xy[1])
    speed = math.hypot(vx, vy)
    if speed < config.min_speed_m_s:
        return None
    ahead = config.allowance_radii * foot_radius_m / speed
    return ahead * vx, ahead * vy


__all__ = ["DEFAULT_ROLL", "RollConfig", "roll_ahead_xy"]
