"""Tests of the rotation and frame helpers (contactnet.frames)."""

from __future__ import annotations

import numpy as np

from contactnet.frames import euler_rate_map, rotation_2d, rotation_rpy, rotation_z, skew


def test_skew_is_the_cross_product() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    assert np.allclose((skew(a) @ b[..., None])[..., 0], np.cross(a, b))
    assert np.allclose(skew(a[0]) @ b[0], np.cross(a[0], b[0]))


def test_rotation_rpy_is_zyx() -> None:
    rng = np.random.default_rng(1)
    rpy = rng.uniform(-1.0, 1.0, (4, 3))
    rot = rotation_rpy(rpy)
    assert rot.shape == (4, 3, 3)
    assert np.allclose(rot @ np.swapaxes(rot, 1, 2), np.eye(3)) and np.allclose(np.linalg.det(rot), 1.0)
    for r, (roll, pitch, yaw) in zip(rot, rpy, strict=True):
        rx = rotation_rpy(np.array([roll, 0.0, 0.0]))
        ry = rotation_rpy(np.array([0.0, pitch, 0.0]))
        assert np.allclose(rx[1:, 1:], rotation_2d(roll))
        assert np.allclose(ry[[[2], [0]], [2, 0]], rotation_2d(pitch))  # z, x block
        assert np.allclose(r, rotation_z(yaw) @ ry @ rx)


def test_yaw_rotations() -> None:
    yaw = np.array([0.0, 0.3, -2.0])
    rz = rotation_z(yaw)
    assert np.allclose(rz, rotation_rpy(np.c_[np.zeros(3), np.zeros(3), yaw]))
    assert np.allclose(rz[:, :2, :2], rotation_2d(yaw))
    assert np.allclose(rotation_2d(np.pi / 2) @ [1.0, 0.0], [0.0, 1.0])  # counter-clockwise
    assert rotation_z(0.5).shape == (3, 3) and rotation_2d(0.5).shape == (2, 2)


def test_euler_rate_map_integrates_the_angular_velocity() -> None:
    """Integrating rpy' = T(rpy) omega follows the rotation R' = [omega]x R (omega in the world)."""
    rpy = np.array([0.2, -0.3, 0.5])
    omega = np.array([0.4, -0.7, 0.9])
    dt = 1e-6
    rot_next = rotation_rpy(rpy + dt * euler_rate_map(rpy) @ omega)
    expected = rotation_rpy(rpy) + dt * skew(omega) @ rotation_rpy(rpy)
    assert np.abs(rot_next - expected).max() < 1e-10
