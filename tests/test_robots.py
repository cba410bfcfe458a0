"""Robots as parameters: Solo12 is the robot the paper and FACTS.md describe; Go2 loads, stands and
walks through the same code; no Solo12 number lives outside its module."""

from __future__ import annotations

import ast
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from contactnet import registry
from contactnet.robots import RobotDataError, RobotFiles, load_robot, robot_spec
from contactnet.robots.solo12 import FOOT_RADIUS_M, TORQUE_LIMIT_NM

ROOT = Path(__file__).resolve().parents[1]


def test_files_come_from_the_installed_distribution():
    files = RobotFiles.locate(robot_spec("solo12"))
    assert files.urdf.name == "solo12.urdf" and files.urdf.is_file()
    assert "site-packages" in str(files.urdf)
    assert (files.package_root / "example-robot-data" / "robots" / "solo_description").is_dir()


def test_mass_frames_and_dimensions(robot):
    description = robot.description
    assert robot.mass_kg == pytest.approx(2.5, abs=1e-3)
    assert robot.model.nq == 19 and robot.model.nv == 18
    assert tuple(robot.model.names)[2:] == description.joint_names
    for frame in description.foot_frames:
        assert robot.model.existFrame(frame)
    hips = robot.hip_pos_base
    np.testing.assert_allclose(np.abs(hips[:, 0]), 0.1946, atol=1e-4)
    np.testing.assert_allclose(np.abs(hips[:, 1]), 0.1015, atol=1e-4)
    # Signs: FL front-left, FR front-right, HL hind-left, HR hind-right.
    np.testing.assert_array_equal(np.sign(hips[:, :2]), [[1, 1], [1, -1], [-1, 1], [-1, -1]])
    np.testing.assert_allclose(description.torque_limit_nm, TORQUE_LIMIT_NM)
    assert TORQUE_LIMIT_NM == pytest.approx(2.7)
    assert description.leg_reach_m == pytest.approx(0.32, abs=0.01)  # 0.16 m thigh + 0.16 m shank (+ offsets)


def test_standing_pose_puts_feet_on_the_ground(robot):
    np.testing.assert_allclose(robot.joint_standing, [0, 0.8, -1.6, 0, 0.8, -1.6, 0, -0.8, 1.6, 0, -0.8, 1.6])
    feet = robot.foot_positions_world(robot.q_standing)
    np.testing.assert_allclose(feet[:, 2], FOOT_RADIUS_M, atol=1e-9)
    assert robot.base_height_standing_m == pytest.approx(0.2229 + FOOT_RADIUS_M, abs=1e-3)
    # Feet under the hips, at the leg's natural lateral offset.
    np.testing.assert_allclose(robot.foot_nominal_base[:, 0], robot.hip_pos_base[:, 0], atol=1e-9)
    np.testing.assert_allclose(np.abs(robot.foot_nominal_base[:, 1]), 0.14695, atol=1e-4)
    assert robot.description.com_height_nominal_m == pytest.approx(0.215, abs=1e-3)


def test_composite_inertia_is_the_rigid_body_one(robot):
    inertia = robot.inertia_com_standing
    np.testing.assert_allclose(inertia, inertia.T, atol=1e-12)
    np.testing.assert_allclose(np.diag(inertia), [0.0300, 0.0515, 0.0680], atol=5e-4)
    assert np.all(np.linalg.eigvalsh(inertia) > 0)
    assert robot.com_base_standing[2] == pytest.approx(-0.024, abs=1e-3)


def test_description_is_frozen(robot):
    description = robot.description
    with pytest.raises(ValueError):
        description.hip_pos_base[0, 0] = 1.0
    with pytest.raises(AttributeError):
        description.mass_kg = 3.0


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


def test_a_cached_urdf_whose_meshes_are_gone_is_written_again(tmp_path):
    """A cache shared by several installations: the URDF written for one virtual environment names its meshes by
    absolute path; when that environment is deleted, the next one must not load it (PyBullet: "Cannot load URDF
    file"). Another installation gets its own file, and a file with dangling mesh paths is written again."""
    from dataclasses import replace

    from contactnet.robots.sim_urdf import write_pybullet_urdf

    go2 = load_robot("go2", cache_dir=tmp_path)
    path = write_pybullet_urdf(go2.spec, go2.files, tmp_path)
    text = path.read_text()
    root = str(go2.files.package_root.resolve())
    assert root in text
    path.write_text(text.replace(root, str(tmp_path / "deleted_venv")))  # as written by a deleted environment
    assert write_pybullet_urdf(go2.spec, go2.files, tmp_path) == path
    assert path.read_text() == text  # written again, with meshes that exist
    elsewhere = replace(go2.files, package_root=tmp_path / "another_venv")
    assert write_pybullet_urdf(go2.spec, elsewhere, tmp_path) != path


def _a1_spec():  # noqa: ANN202 - a RobotSpec, written as a contributor adding Unitree A1 would
    from contactnet.robots.description import RobotSpec

    return RobotSpec(name="a1", description_dir="a1_description", urdf="urdf/a1.urdf", srdf="srdf/a1.srdf",
                     standing_pose="standing", leg_prefixes=("FL", "FR", "RL", "RR"),
                     joint_suffixes=("hip_joint", "thigh_joint", "calf_joint"), foot_suffix="foot",
                     foot_radius_m=0.02, fz_max_n=120.0, kin_threshold_m=0.15, fall_base_height_m=0.12)


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_a_urdf_link_without_inertia_is_simulated_as_the_model_and_nothing_reaches_stdout(engine, tmp_path, capfd):
    """A1's root link has no <inertial> block: pinocchio gives it no mass, PyBullet would give it 1 kg (and print a
    warning on stdout, spoiling --json). The simulated URDF gives it a negligible mass, so every engine simulates the
    model's mass, and the engine's own output goes to stderr."""
    from contactnet.robots.description import Robot
    from contactnet.robots.sim_urdf import NEGLIGIBLE_MASS_KG, links_without_inertia
    from contactnet.sim.engines import make_simulator
    from contactnet.sim.world import SimConfig
    from contactnet.terrain import flat

    a1 = Robot.load(_a1_spec(), cache_dir=tmp_path)
    assert links_without_inertia(ET.parse(a1.files.urdf).getroot()) == ["base"]
    assert links_without_inertia(ET.parse(a1.pybullet_urdf()).getroot()) == []
    capfd.readouterr()
    with make_simulator(a1, flat(), SimConfig(engine=engine)) as sim:
        assert sim.robot.mass_kg == pytest.approx(a1.mass_kg)
    assert capfd.readouterr().out == ""
    assert NEGLIGIBLE_MASS_KG < 1e-4 * a1.mass_kg


def test_an_engine_that_simulates_another_mass_is_refused(robot):
    from contactnet.sim.engines import make_simulator
    from contactnet.terrain import flat

    with make_simulator(robot, flat()) as sim:
        sim._check_mass(robot.mass_kg * 1.004)  # within 0.5 %
        with pytest.raises(RobotDataError, match=r"simulates solo12 at 3\.500 kg .* weighs 2\.500 kg"):
            sim._check_mass(robot.mass_kg + 1.0)


def test_the_cached_urdf_is_keyed_on_the_code_that_writes_it(tmp_path):
    from dataclasses import replace

    from contactnet.robots.sim_urdf import write_pybullet_urdf

    solo = load_robot("solo12", cache_dir=tmp_path)
    path = write_pybullet_urdf(solo.spec, solo.files, tmp_path)

    def another_recipe(link_name: str):  # noqa: ANN202 - the same shapes, another writer
        return solo.spec.collision_recipe(link_name)

    other = write_pybullet_urdf(replace(solo.spec, collision_recipe=another_recipe), solo.files, tmp_path)
    assert other != path and other.read_text() == path.read_text()


def test_robot_check_says_what_is_wrong_with_a_stance_and_what_to_tune(tmp_path):
    from dataclasses import replace

    from contactnet.jobs.robot_check import model_checks, verdict
    from contactnet.robots.description import Robot

    good = {c.name: c for c in model_checks(Robot.load(_a1_spec(), cache_dir=tmp_path), "pybullet")}
    assert all(c.passed for c in good.values()), good
    assert "1 link(s) without <inertial> (base)" in good["links with a mass"].measured
    straight = Robot.load(replace(_a1_spec(), standing_leg_joints_rad=(0.0, 0.0, 0.0)), cache_dir=tmp_path)
    checks = {c.name: c for c in model_checks(straight, "pybullet")}
    assert not checks["legs bent, not straight"].passed and checks["feet under the hips"].passed
    leaning = Robot.load(replace(_a1_spec(), standing_leg_joints_rad=(0.0, 1.2, -1.6)), cache_dir=tmp_path)
    checks = model_checks(leaning, "pybullet")
    assert [c.name for c in checks if not c.passed] == ["feet under the hips"]
    assert "not ready: feet under the hips: tune standing_leg_joints_rad" in verdict("a1", checks)
    passed = [replace(c, passed=True) for c in checks]
    assert verdict("a1", passed).endswith("ContactNet needs its own models: contactnet datagen and train")
    assert verdict("go2", passed).endswith("its ContactNet models: go2_walk.pt, go2_trot.pt")  # shipped
    assert verdict("solo12", passed).endswith("its ContactNet models: walk.pt, trot.pt")


@pytest.mark.slow
def test_robot_check_on_the_command_line(tmp_path):
    import json
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-m", "contactnet", "robot", "check", "solo12", "--json"],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["ready"] and report["robot"] == "solo12" and len(report["checks"]) == 7
    assert report["verdict"].startswith("solo12: ready")


def test_go2_is_described_from_its_own_files(tmp_path):
    go2 = load_robot("go2", cache_dir=tmp_path)
    description = go2.description
    assert description.name == "go2"
    assert 15.0 < description.mass_kg < 17.0  # the 15 kg class
    assert description.joint_names[:3] == ("FL_hip_joint", "FL_thigh_joint", "FL_calf_joint")
    assert description.foot_frames == ("FL_foot", "FR_foot", "RL_foot", "RR_foot")  # hind legs: our HL, HR
    np.testing.assert_allclose(description.torque_limit_nm[:3], [23.7, 23.7, 45.43])  # from its URDF
    np.testing.assert_array_equal(np.sign(description.hip_pos_base[:, :2]), [[1, 1], [1, -1], [-1, 1], [-1, -1]])
    feet = go2.foot_positions_world(description.q_standing)
    np.testing.assert_allclose(feet[:, 2], description.foot_radius_m, atol=1e-9)
    np.testing.assert_allclose(description.foot_nominal_base[:, 0], description.hip_pos_base[:, 0], atol=1e-3)
    assert description.com_height_nominal_m > 0.25
    assert go2.pybullet_urdf().is_file()


def test_unknown_robot_is_a_clear_error():
    with pytest.raises(RobotDataError, match="unknown robot 'atlas'.*solo12"):
        load_robot("atlas")


def test_registry_names_every_robot():
    assert {"solo12", "go2"} <= set(registry.robot_names())


# Solo12's distinctive numbers: hip x and y, nominal foot y, CoM height, foot radius, torque limit,
# standing foot depth, HAA y. They belong in contactnet/robots/solo12.py (and the tests) only.
SOLO12_NUMBERS = {0.1946, 0.1015, 0.14695, 0.215, 0.016, 2.7, 0.2229, 0.0875}


def _numbers_in_code(path: Path) -> set[float]:
    """Numeric literals of a module's code (docstrings and comments are text, not code)."""
    tree = ast.parse(path.read_text())
    return {node.value for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, float)}


def test_no_solo12_number_outside_its_module():
    offenders = []
    for folder in ("contactnet", "app"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path.name == "solo12.py" and path.parent.name == "robots":
                continue
            found = _numbers_in_code(path) & SOLO12_NUMBERS
            if found:
                offenders.append(f"{path.relative_to(ROOT)}: {sorted(found)}")
    assert not offenders, "Solo12 numbers outside contactnet/robots/solo12.py:\n" + "\n".join(offenders)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["solo12", "go2"])
def test_robot_stands_10_s_under_the_whole_body_controller(name, tmp_path):
    """All four feet in stance, the controller holding the initial CoM with the weight shared: no fall."""
    from contactnet.motion.controller import ControlTarget, WholeBodyController
    from contactnet.sim.pybullet_world import Simulator
    from contactnet.terrain import flat

    robot = load_robot(name, cache_dir=tmp_path)
    controller = WholeBodyController(robot)
    with Simulator(robot, flat()) as sim:
        state = sim.state()
        com, _, feet, _ = controller.kinematics(state.q_pinocchio(), state.v_pinocchio())
        target = ControlTarget(com_pos=com, com_vel=np.zeros(3), rpy=np.zeros(3), ang_vel=np.zeros(3),
                               forces=np.tile([0.0, 0.0, robot.mass_kg * 9.81 / 4], (4, 1)),
                               stance=np.ones(4, dtype=bool), swing_pos=feet, swing_vel=np.zeros((4, 3)))
        for tick in range(10_000):
            sim.step(controller.torques(state.q_pinocchio(), state.v_pinocchio(), target))
            state = sim.state(with_contacts=False)
            if tick % 100 == 0:
                assert sim.fall_reason(state) is None, f"{name} fell at {sim.t_s:.2f} s"
        assert sim.fall_reason() is None
        assert abs(state.base_pos_world[2] - robot.base_height_standing_m) < 0.03
        np.testing.assert_allclose(state.base_pos_world[:2], [0.0, 0.0], atol=0.02)


@pytest.mark.slow
@pytest.mark.parametrize("gait_name", ["walk", "trot"])
def test_go2_walks_and_trots_with_the_heuristic_planner(gait_name, tmp_path):
    """The issue's Go2 target: flat ground, vx = 0.1 m/s for 20 s, no fall, progress >= 75 % of the command."""
    from contactnet.locomotion import Locomotion
    from contactnet.terrain import flat

    robot = load_robot("go2", cache_dir=tmp_path)
    gait = registry.gait_by_name(gait_name)
    planner = registry.make_planner("heuristic", gait, robot)
    with Locomotion(robot, flat(), gait, planner, vel_cmd_xy=(0.1, 0.0)) as loco:
        summary = loco.run(20.0, stop_at_goal=False)
    assert not summary["fell"], summary["fall_reason"]
    assert summary["sim_time_s"] == pytest.approx(20.0)
    assert summary["mean_velocity_xy"][0] >= 0.075
    assert abs(summary["mean_velocity_xy"][1]) < 0.02


@pytest.mark.slow
def test_go2_trots_across_the_stone_grid_with_its_contactnet(tmp_path):
    """esfal's Go2 stones (11 cm squares), Go2's own trot model: crossed. With Solo12's force weight in the walking
    loop Go2's CoM stayed 5 cm behind its reference, over its feet, and the trot stopped at 0.45 m."""
    from contactnet.locomotion import Locomotion

    robot = load_robot("go2", cache_dir=tmp_path)
    gait = registry.gait_for("trot", robot)
    planner = registry.make_planner("contactnet", gait, robot)
    terrain = registry.terrain_for("stone_grid", robot)
    with Locomotion(robot, terrain, gait, planner, vel_cmd_xy=(0.05, 0.0)) as loco:
        summary = loco.run(60.0)
    assert summary["success"], (summary["fall_reason"], summary["reached_x"])


def test_go2s_calf_is_two_cylinders_along_its_bend_that_stop_above_the_foot_ball(tmp_path):
    """The URDF's two convex hulls of Go2's calf filled its bend and wrapped the foot, 3-5 mm beyond the ball: a foot
    brushing a riser counted as the calf touching it. The recipe's cylinders lie inside the visual mesh's outline
    (to its radius) and every point of them is farther from the foot's centre than the ball's radius."""
    import trimesh

    from contactnet.robots import go2

    robot = load_robot("go2", cache_dir=tmp_path)
    root = ET.parse(robot.pybullet_urdf()).getroot()
    calves = [link for link in root.iter("link") if link.get("name").endswith("_calf")]
    assert len(calves) == 4
    for link in calves:
        assert [c.find("geometry")[0].tag for c in link.findall("collision")] == ["cylinder", "cylinder"]
    visual = trimesh.load(robot.files.urdf.parent.parent / "visuals" / "calf.dae", force="mesh")
    foot_xz = np.array([0.0, -0.213])
    for bottom, top, radius in go2.CALF_CYLINDERS_M:
        bottom, top = np.asarray(bottom), np.asarray(top)
        length = np.linalg.norm(top - bottom)
        unit = (top - bottom) / length
        along = float((foot_xz - bottom) @ unit)  # the foot's centre from the solid cylinder, exactly
        across = abs(float(unit[0] * (foot_xz - bottom)[1] - unit[1] * (foot_xz - bottom)[0]))
        beyond_end = max(0.0, -along, along - length)
        assert np.hypot(max(0.0, across - radius), beyond_end) > go2.FOOT_RADIUS_M
        axis = bottom + np.linspace(0.0, 1.0, 20)[:, None] * (top - bottom)
        for x, z in axis:  # the axis inside the mesh's cross-section at its height
            section = visual.vertices[np.abs(visual.vertices[:, 2] - z) < 0.01]
            assert section[:, 0].min() - 0.002 <= x <= section[:, 0].max() + 0.002
