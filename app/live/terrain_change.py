"""Whether a terrain change can apply while the robots walk on: `change_is_away`.

An edit far from every robot (its base, feet and planned footholds) and keeping the start, the goal and
the surface height does not need a restart: the live session swaps the terrain under the walking robots
(`Locomotion.replace_terrain`). Anything nearer restarts them (`app/live/session.py`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from contactnet.records import Snapshot
from contactnet.robots import Robot
from contactnet.terrain import Terrain

#: A change applies without a restart when everything it changed is this far from each robot's base ...
CLEARANCE_BASE_M = 0.5
#: ... and at least this far from its feet and its planned footholds.
CLEARANCE_FOOTHOLD_M = 0.1


def change_is_away(old: Terrain, new: Terrain, robot: Robot, snapshots: Sequence[Snapshot]) -> bool:
    """Did going from ``old`` to ``new`` leave the ground near every robot (one snapshot each) alone, and
    the start, goal and surface height as they were?"""
    if (
        not np.allclose(old.start_xy, new.start_xy)
        or old.goal_x != new.goal_x
        or old.to_dict().get("surface_z") != new.to_dict().get("surface_z")
    ):
        return False
    changed = shapely.symmetric_difference(old.steppable, new.steppable)
    if changed.is_empty:
        return True
    for snap in snapshots:
        if shapely.distance(changed, shapely.Point(snap.q[0], snap.q[1])) < CLEARANCE_BASE_M:
            return False
        points = [robot.foot_positions_world(snap.q)[:, :2]]
        points += [np.asarray(step.footholds_xy_world).reshape(-1, 2) for step in snap.planned_steps]
        if np.any(shapely.distance(changed, shapely.points(np.concatenate(points))) < CLEARANCE_FOOTHOLD_M):
            return False
    return True
