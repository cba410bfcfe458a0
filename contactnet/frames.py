"""Rotations and frame maps (numpy, vectorized over leading axes).

Conventions used throughout the project:

* an orientation is given by roll-pitch-yaw angles ``rpy = (roll, pitch, yaw)`` in rad, ZYX Euler
  angles: ``R = Rz(yaw) Ry(pitch) Rx(roll)`` maps body-frame vectors to the world frame;
* angular velocities are expressed in the world frame;
* "yaw" alone is the heading, the rotation about the world z axis (counter-clockwise seen from above).

Every function takes arrays with any number of leading axes (a single angle or vector is the case of
none) and returns float arrays with the same leading axes.
"""

from __future__ import annotations

import numpy as np


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices (..., 3, 3) of vectors (..., 3): ``skew(a) @ b == np.cross(a, b)``."""
    v = np.asarray(v, dtype=float)
    s = np.zeros((*v.shape[:-1], 3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def rotation_rpy(rpy: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of ZYX roll-pitch-yaw angles (..., 3): R = Rz(y) Ry(p) Rx(r)."""
    rpy = np.asarray(rpy, dtype=float)
    cr, sr = np.cos(rpy[..., 0]), np.sin(rpy[..., 0])
    cp, sp = np.cos(rpy[..., 1]), np.sin(rpy[..., 1])
    cy, sy = np.cos(rpy[..., 2]), np.sin(rpy[..., 2])
    r = np.empty((*rpy.shape[:-1], 3, 3))
    r[..., 0, 0], r[..., 0, 1], r[..., 0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    r[..., 1, 0], r[..., 1, 1], r[..., 1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    r[..., 2, 0], r[..., 2, 1], r[..., 2, 2] = -sp, cp * sr, cp * cr
    return r


def rotation_z(yaw_rad: np.ndarray | float) -> np.ndarray:
    """Rotation matrices (..., 3, 3) about the z axis by ``yaw_rad`` (...,): a heading frame to the world."""
    yaw = np.asarray(yaw_rad, dtype=float)
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.zeros((*yaw.shape, 3, 3))
    rot[..., 0, 0], rot[..., 0, 1], rot[..., 1, 0], rot[..., 1, 1], rot[..., 2, 2] = c, -s, s, c, 1.0
    return rot


def rotation_2d(yaw_rad: np.ndarray | float) -> np.ndarray:
    """Planar rotation matrices (..., 2, 2) by ``yaw_rad`` (...,): the xy block of ``rotation_z``."""
    yaw = np.asarray(yaw_rad, dtype=float)
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.empty((*yaw.shape, 2, 2))
    rot[..., 0, 0], rot[..., 0, 1], rot[..., 1, 0], rot[..., 1, 1] = c, -s, s, c
    return rot


def euler_rate_map(rpy: np.ndarray) -> np.ndarray:
    """Matrices T (..., 3, 3) with d(rpy)/dt = T(rpy) omega_world (ZYX angles, singular at pitch +-90 deg)."""
    rpy = np.asarray(rpy, dtype=float)
    cp, sp = np.cos(rpy[..., 1]), np.sin(rpy[..., 1])
    cy, sy = np.cos(rpy[..., 2]), np.sin(rpy[..., 2])
    t = np.zeros((*rpy.shape[:-1], 3, 3))
    t[..., 0, 0], t[..., 0, 1] = cy / cp, sy / cp
    t[..., 1, 0], t[..., 1, 1] = -sy, cy
    t[..., 2, 0], t[..., 2, 1], t[..., 2, 2] = cy * sp / cp, sy * sp / cp, 1.0
    return t


def rotate_xy(xy: np.ndarray, yaw_rad: float) -> np.ndarray:
    """Planar vectors (..., 2) turned by ``yaw_rad`` (one angle): a heading-frame xy to the world's."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    xy = np.asarray(xy, dtype=float)
    return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)


def quat_to_matrix(quat_xyzw: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = (float(c) for c in quat_xyzw)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def quat_to_rpy(quat_xyzw: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (ZYX Euler angles) of a unit quaternion, rad.

    The products on Python floats (the same IEEE arithmetic as on numpy scalars, a tenth of the cost), the
    angles from numpy's arctan2 and arcsin."""
    x, y, z, w = (float(c) for c in quat_xyzw)
    roll_yaw = np.arctan2([2 * (w * x + y * z), 2 * (w * z + x * y)], [1 - 2 * (x * x + y * y), 1 - 2 * (y * y + z * z)])
    pitch = np.arcsin(min(max(2 * (w * y - z * x), -1.0), 1.0))
    return np.array([roll_yaw[0], pitch, roll_yaw[1]])


def yaw_to_quat(yaw_rad: float) -> np.ndarray:
    return np.array([0.0, 0.0, np.sin(yaw_rad / 2), np.cos(yaw_rad / 2)])


def quat_mul_wxyz(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of wxyz quaternions, broadcast over leading axes."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )
