"""Solo12 facts: the model we load is the robot the paper and FACTS.md describe."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from contactnet.robot import FOOT_FRAMES, FOOT_RADIUS_M, JOINT_NAMES, TORQUE_LIMIT_NM, RobotFiles


def test_files_come_from_the_installed_distribution():
    files = RobotFiles.locate()
    assert files.urdf.name == "solo12.urdf" and files.urdf.is_file()
    assert "site-packages" in str(files.urdf)
    assert (files.package_root / "example-robot-data" / "robots" / "solo_description").is_dir()


def test_mass_frames_and_dimensions(robot):
    assert robot.mass_kg == pytest.approx(2.5, abs=1e-3)
    assert robot.model.nq == 19 and robot.model.nv == 18
    assert tuple(robot.model.names)[2:] == JOINT_NAMES
    for frame in FOOT_FRAMES:
        assert robot.model.existFrame(frame)
    hips = robot.hip_pos_base
    np.testing.assert_allclose(np.abs(hips[:, 0]), 0.1946, atol=1e-4)
    np.testing.assert_allclose(np.abs(hips[:, 1]), 0.1015, atol=1e-4)
    # Signs: FL front-left, FR front-right, HL hind-left, HR hind-right.
    np.testing.assert_array_equal(np.sign(hips[:, :2]), [[1, 1], [1, -1], [-1, 1], [-1, -1]])
    assert TORQUE_LIMIT_NM == pytest.approx(2.7)


def test_standing_pose_puts_feet_on_the_ground(robot):
    np.testing.assert_allclose(robot.joint_standing, [0, 0.8, -1.6, 0, 0.8, -1.6, 0, -0.8, 1.6, 0, -0.8, 1.6])
    feet = robot.foot_positions_world(robot.q_standing)
    np.testing.assert_allclose(feet[:, 2], FOOT_RADIUS_M, atol=1e-9)
    assert robot.base_height_standing_m == pytest.approx(0.2229 + FOOT_RADIUS_M, abs=1e-3)
    # Feet under the hips, at the leg's natural lateral offset.
    np.testing.assert_allclose(robot.foot_nominal_base[:, 0], robot.hip_pos_base[:, 0], atol=1e-9)
    np.testing.assert_allclose(np.abs(robot.foot_nominal_base[:, 1]), 0.14695, atol=1e-4)


def test_composite_inertia_is_the_rigid_body_one(robot):
    inertia = robot.inertia_com_standing
    np.testing.assert_allclose(inertia, inertia.T, atol=1e-12)
    np.testing.assert_allclose(np.diag(inertia), [0.0300, 0.0515, 0.0680], atol=5e-4)
    assert np.all(np.linalg.eigvalsh(inertia) > 0)
    assert robot.com_base_standing[2] == pytest.approx(-0.024, abs=1e-3)


def test_pybullet_urdf_has_sphere_feet_and_absolute_meshes(robot):
    path = robot.pybullet_urdf()
    assert path == robot.pybullet_urdf()  # generated once, then reused
    root = ET.parse(path).getroot()
    for mesh in root.iter("mesh"):
        assert not mesh.get("filename").startswith("package://")
    for link in root.iter("link"):
        if link.get("name").endswith("_FOOT"):
            sphere = link.find("collision/geometry/sphere")
            assert sphere is not None and float(sphere.get("radius")) == pytest.approx(FOOT_RADIUS_M)
    mesh_feet = robot.pybullet_urdf(sphere_feet=False)
    assert mesh_feet != path and mesh_feet.is_file()
