"""The ground the robot stands on: one height, from the tops under its feet.

The CoM height reference of the optimizer, the CoM height the network sees and the planner's predicted
CoM height all measure from the *support height*: the mean of the tops under the four feet
(``Terrain.ground_z``: the top where there is one, the nominal ground level ``surface_z`` over a hole).
Measuring from the ground under the CoM instead would jump by a whole riser when the CoM passes over
one, while the feet, and so the body, climb one foot at a time.

On a terrain whose tops are all at ``surface_z`` (every flat scene) this is exactly ``surface_z``, the
same number as the ground under the CoM.

The body follows the slope of its feet as well (``body_pitch``): nose up by half the angle from the hind
feet's mean top to the front feet's, so that on stairs the hind legs do not stretch straight while the
front ones fold (a level body), nor do the knees of the legs on the lower tops drop toward the higher ones
(a body parallel to the slope). Level on flat ground.

The optimizer's friction pyramids stand on the tops' normals under the footholds (``ground_normals``).
"""

from __future__ import annotations

import numpy as np

from contactnet.terrain import Terrain


def support_height(terrain: Terrain, feet_xy_world: np.ndarray) -> float:
    """World z of the feet's support: the mean of ``terrain.ground_z`` under the feet (4, 2) (or (M, 2))."""
    tops = terrain.ground_z(np.asarray(feet_xy_world, dtype=float).reshape(-1, 2)).tolist()
    return sum(tops) / len(tops)


#: The body pitches by this share of its feet's slope: a half-way compromise between a level body (the legs
#: on the lower tops stretch, those on the higher ones fold) and one parallel to the slope (each hip at its
#: nominal height over its foot, but the knees of the legs on the lower tops come down toward the higher ones).
PITCH_SHARE = 0.5


def body_pitch(tops_z: np.ndarray, front_to_hind_m: float, share: float = PITCH_SHARE) -> np.ndarray:
    """Pitch (rad, positive nose down, the ``rpy`` convention): ``share`` of the slope from the hind feet's mean
    top to the front feet's over ``front_to_hind_m``; ``tops_z`` (..., 4) per leg FL, FR, HL, HR -> (...)."""
    tops = np.asarray(tops_z, dtype=float)
    front = 0.5 * (tops[..., 0] + tops[..., 1])
    hind = 0.5 * (tops[..., 2] + tops[..., 3])
    return share * np.arctan2(hind - front, front_to_hind_m)


def ground_normals(terrain: Terrain, feet_world: np.ndarray) -> np.ndarray | None:
    """Unit normals (..., 3) of the tops under feet (..., 3) or (..., 2) (``Terrain.normal_at``; +z over holes), the
    optimizer's friction pyramids' axes (``TrajoptProblem.contact_normals_world``); None on a terrain without sloped
    tops (every normal +z: nothing to look up)."""
    if not terrain.sloped:
        return None
    feet = np.asarray(feet_world, dtype=float)
    return terrain.normal_at(feet[..., 0:2].reshape(-1, 2)).reshape(*feet.shape[:-1], 3)


def front_to_hind_m(foot_nominal_base: np.ndarray) -> float:
    """Distance along x from the hind feet to the front feet in the nominal stance (legs FL, FR, HL, HR)."""
    feet = np.asarray(foot_nominal_base, dtype=float)
    return float(0.5 * (feet[0, 0] + feet[1, 0]) - 0.5 * (feet[2, 0] + feet[3, 0]))


__all__ = ["PITCH_SHARE", "body_pitch", "front_to_hind_m", "ground_normals", "support_height"]
