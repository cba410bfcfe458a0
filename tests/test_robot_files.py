"""Robots as files: a robot file reads into the same `RobotSpec` a module writes, bad files are one line naming the
field, `robot init` drafts one from example-robot-data, and ``--robot FILE.toml`` reaches the workers."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from contactnet.robots import RobotDataError, load_robot, robot_spec
from contactnet.robots.robot_file import load_robot_file, spec_values, to_toml
from contactnet.robots.robot_init import draft

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def _own_robot_files(monkeypatch):
    """A robot file read here is listed in CONTACTNET_ROBOT_FILES for child processes: not for the other tests'."""
    from contactnet.robots.robot_file import ROBOT_FILES_ENV

    monkeypatch.setenv(ROBOT_FILES_ENV, "")  # set (empty), so that monkeypatch removes what a test adds to it

A1 = """\
name = "a1_file"
description_dir = "a1_description"
urdf = "urdf/a1.urdf"
srdf = "srdf/a1.srdf"
standing_pose = "standing"
leg_prefixes = ["FL", "FR", "RL", "RR"]
joint_suffixes = ["hip_joint", "thigh_joint", "calf_joint"]
foot_suffix = "foot"
foot_radius_m = 0.02
fz_max_n = 120.0
kin_threshold_m = 0.15
fall_base_height_m = 0.12

[controller_gains]
kd_joint = 0.1
kp_swing = [400.0, 400.0, 400.0]
"""


def _file_with_table(tmp_path, name: str, table: str, body: str):  # noqa: ANN001, ANN202
    """A1's robot file renamed ``name`` with ``[table]`` holding ``body``: its path and its spec."""
    path = tmp_path / "a1.toml"
    path.write_text(A1.replace('name = "a1_file"', f'name = "{name}"') + f"\n[{table}]\n{body}\n")
    return path, load_robot_file(path)


def test_a_robot_file_is_a_spec_and_loads_a_robot(tmp_path):
    path = tmp_path / "a1.toml"
    path.write_text(A1)
    spec = load_robot_file(path)
    assert spec.name == "a1_file" and spec.leg_prefixes == ("FL", "FR", "RL", "RR")
    assert spec.controller_gains == (("kd_joint", 0.1), ("kp_swing", (400.0, 400.0, 400.0)))
    assert spec.collision_recipe("FL_foot")[0].get("radius") == "0.02" and spec.collision_recipe("FL_calf") is None
    robot = load_robot(str(path), cache_dir=tmp_path)
    assert robot.name == "a1_file" and 13.0 < robot.mass_kg < 14.5
    assert robot_spec("a1_file") == spec  # registered by name once read
    again = tmp_path / "again.toml"
    again.write_text(to_toml(spec_values(spec)))
    assert load_robot_file(again) == spec  # what to_toml writes reads back as the same robot
    for field in ("walk_crouch_m", "trot_crouch_m", "brace_outward_m"):  # the default: not written
        assert getattr(spec, field) == 0.0 and field not in spec_values(spec)
    crouched = tmp_path / "crouched.toml"
    crouched.write_text(A1.replace("fall_base_height_m = 0.12\n",
                                   "fall_base_height_m = 0.12\nwalk_crouch_m = 0.02\ntrot_crouch_m = 0.015\n"
                                   "brace_outward_m = 0.04\n")
                        .replace('name = "a1_file"', 'name = "a1_crouched"'))
    crouched_spec = load_robot_file(crouched)
    assert (crouched_spec.walk_crouch_m, crouched_spec.trot_crouch_m) == (0.02, 0.015)
    assert spec_values(crouched_spec)["trot_crouch_m"] == 0.015  # written back
    assert crouched_spec.brace_outward_m == 0.04 and spec_values(crouched_spec)["brace_outward_m"] == 0.04
    from contactnet.robots import robot_names
    from contactnet.robots.robot_file import registered_files

    assert registered_files() == (str(path.resolve()),)
    path.write_text(A1.replace("fz_max_n = 120.0", "fz_max_n = 130.0"))  # changed under the same name
    assert "a1_file" in robot_names()  # said on stderr, the first one kept


@pytest.mark.parametrize(("change", "message"), [
    (lambda t: t.replace('foot_radius_m = 0.02\n', ''), "foot_radius_m: missing"),
    (lambda t: t.replace('fall_base_height_m = 0.12\n', 'fall_base_height_m = 0.12\nwheels = 4\n'),
     "wheels: unknown field"),
    (lambda t: t.replace('fz_max_n = 120.0', 'fz_max_n = -1'), "fz_max_n: expected a positive number"),
    (lambda t: t.replace('["FL", "FR", "RL", "RR"]', '["FL", "FR"]'), "leg_prefixes: expected 4 names"),
    (lambda t: t.replace('srdf = "srdf/a1.srdf"\n', ''), "srdf: missing: a stance needs"),
    (lambda t: t.replace('name = "a1_file"', 'name = "a1_file'), "not TOML"),
    (lambda t: t.replace('fall_base_height_m = 0.12\n', 'fall_base_height_m = 0.12\nfeet = "wheels"\n'),
     "feet: expected 'sphere' or 'mesh'"),
    (lambda t: t.replace('fall_base_height_m = 0.12\n', 'fall_base_height_m = 0.12\nwalk_crouch_m = -0.01\n'),
     "walk_crouch_m: expected a number from 0 to 1"),
    (lambda t: t.replace('fall_base_height_m = 0.12\n', 'fall_base_height_m = 0.12\ntrot_crouch_m = true\n'),
     "trot_crouch_m: expected a number from 0 to 1"),
    (lambda t: t.replace('fall_base_height_m = 0.12\n', 'fall_base_height_m = 0.12\nstance_abduction_rad = 0.5\n'),
     "stance_abduction_rad: expected a number from 0 to 0.3"),
    (lambda t: t.replace('fall_base_height_m = 0.12\n', 'fall_base_height_m = 0.12\nstance_abduction_rad = true\n'),
     "stance_abduction_rad: expected a number"),
    (lambda t: t.replace('fall_base_height_m = 0.12\n',
                         'fall_base_height_m = 0.12\none_level_stance_abduction_rad = 0.4\n'),
     "one_level_stance_abduction_rad: expected a number from 0 to 0.3"),
    (lambda t: t.replace('fall_base_height_m = 0.12\n', 'fall_base_height_m = 0.12\nbrace_outward_m = 0.5\n'),
     "brace_outward_m: expected a number from 0 to 0.15"),
])
def test_a_bad_robot_file_is_one_line_naming_the_field(tmp_path, change, message):
    path = tmp_path / "bad.toml"
    path.write_text(change(A1))
    with pytest.raises(RobotDataError, match=message) as error:
        load_robot_file(path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


def test_an_unknown_controller_gain_is_named_when_the_controller_is_built(tmp_path):
    from contactnet.motion.controller import ControllerGains

    path = tmp_path / "a1.toml"
    path.write_text(A1.replace("kd_joint = 0.1", "kd_joints = 0.1").replace('"a1_file"', '"a1_gains"'))
    robot = load_robot(str(path), cache_dir=tmp_path)
    with pytest.raises(RobotDataError, match="unknown controller gain 'kd_joints'"):
        ControllerGains.for_robot(robot.description)


def test_a_controller_gain_out_of_its_range_is_one_line_that_names_the_robot(tmp_path):
    from contactnet.motion.controller import ControllerGains

    path = tmp_path / "a1.toml"
    path.write_text(A1.replace("kd_joint = 0.1", "kd_joint = 0.1\nleg_gravity = 2.0").replace('"a1_file"', '"a1_lg"'))
    robot = load_robot(str(path), cache_dir=tmp_path)
    with pytest.raises(RobotDataError, match="robot a1_lg: ControllerGains.leg_gravity must be a share") as error:
        ControllerGains.for_robot(robot.description)
    assert "\n" not in str(error.value)
    good = tmp_path / "a1_ok.toml"
    good.write_text(A1.replace("kd_joint = 0.1", "kd_joint = 0.1\nleg_gravity = 1").replace('"a1_file"', '"a1_ok"'))
    assert ControllerGains.for_robot(load_robot(str(good), cache_dir=tmp_path).description).leg_gravity == 1.0


def test_robot_init_finds_legs_names_stance_and_says_what_it_guessed():
    go1 = draft("go1_description")
    assert go1.values["leg_prefixes"] == ["FL", "FR", "RL", "RR"]
    assert go1.values["joint_suffixes"] == ["hip_joint", "thigh_joint", "calf_joint"]
    assert go1.values["standing_pose"] == "standing" and "standing_leg_joints_rad" not in go1.values
    assert go1.values["kin_threshold_m"] == pytest.approx(0.12 / 0.32 * 0.426, abs=0.005)  # scaled by the leg
    laikago = draft("laikago_description")  # no SRDF: the stance is searched
    assert "srdf" not in laikago.values and len(laikago.values["standing_leg_joints_rad"]) == 3
    assert any("computed standing_leg_joints_rad" in line for line in laikago.problems)
    a1 = draft("a1_description")
    assert any("links without <inertial> (base)" in line for line in a1.problems)
    with pytest.raises(RobotDataError, match="not leg by leg"):  # ANYmal's URDF lists LF, LH, RF, RH
        draft("anymal_c_simple_description")
    with pytest.raises(RobotDataError, match="four legs of a 12-joint quadruped"):  # solo.urdf: 8 joints
        draft("solo_description")


@pytest.mark.slow
def test_a_drafted_robot_file_walks_through_the_command_line_and_the_workers(tmp_path):
    """The issue's target for robots we do not ship: `robot init` then `--robot FILE.toml`, no edit of the package;
    an experiment's trials in two worker processes read the file too."""
    def cli(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "contactnet", *args], capture_output=True, text=True, cwd=ROOT,
                              timeout=900)

    robot_file = tmp_path / "laikago.toml"
    made = cli("robot", "init", "laikago_description", "--out", str(robot_file))
    assert made.returncode == 0, made.stderr
    assert "guessed: computed standing_leg_joints_rad" in made.stdout
    assert cli("robot", "init", "laikago_description", "--out", str(robot_file)).returncode == 2  # exists
    walked = cli("simulate", "--robot", str(robot_file), "--terrain", "flat", "--gait", "trot", "--planner",
                 "heuristic", "--vx", "0.1", "--duration", "20", "--json")
    assert walked.returncode == 0, walked.stderr
    result = json.loads(walked.stdout)
    assert not result["fell"] and result["mean_velocity_xy"][0] > 0.075
    out = tmp_path / "runs"
    experiment = cli("experiment", "stepping_stones", "--robot", str(robot_file), "--planners", "heuristic",
                     "--gaits", "walk,trot", "--workers", "2", "--quiet", "--out", str(out))
    assert experiment.returncode == 0, experiment.stderr
    records = [json.loads(line) for line in (out / "trials.jsonl").read_text().splitlines()]
    assert len(records) == 2 and all(r["trial"]["robot"] == "laikago" for r in records)


def test_a_wider_stance_turns_each_abduction_outward(tmp_path):
    """``stance_abduction_rad``: every foot moves away from the sagittal plane by about the angle times the foot's
    depth below its abduction axis, the left and right alike, its x unchanged; the base settles a little lower; the
    legs' upright feet stay the stance's. Written to a robot file only when not 0."""
    import dataclasses

    import numpy as np

    from contactnet.planning.footholds import LegGeometry
    from contactnet.robots.description import Robot

    path = tmp_path / "a1.toml"
    path.write_text(A1.replace("fall_base_height_m = 0.12\n", "fall_base_height_m = 0.12\nstance_abduction_rad = 0.1\n")
                    .replace('name = "a1_file"', 'name = "a1_wide"'))
    wide_spec = load_robot_file(path)
    assert wide_spec.stance_abduction_rad == 0.1 and spec_values(wide_spec)["stance_abduction_rad"] == 0.1
    for spec in (dataclasses.replace(wide_spec, stance_abduction_rad=0.0), robot_spec("solo12")):
        plain = Robot.load(spec, cache_dir=tmp_path).description
        wide = Robot.load(dataclasses.replace(spec, stance_abduction_rad=0.1), cache_dir=tmp_path).description
        out = np.abs(wide.foot_nominal_base[:, 1]) - np.abs(plain.foot_nominal_base[:, 1])
        depth = -plain.foot_nominal_base[:, 2]  # the feet's depth below the base, about their depth below the axis
        assert np.all(out > 0.5 * 0.1 * depth) and np.all(out < 1.5 * 0.1 * depth), (spec.name, out)
        assert np.ptp(out) < 1e-9  # the four alike
        assert np.allclose(wide.foot_nominal_base[:, 0], plain.foot_nominal_base[:, 0], atol=1e-9)
        assert wide.com_height_nominal_m < plain.com_height_nominal_m
        # the legs lean from where their feet stood before (the height checks' leg planes, LegGeometry)
        np.testing.assert_array_equal(wide.foot_upright_base, plain.foot_nominal_base)
        np.testing.assert_array_equal(plain.foot_upright_base, plain.foot_nominal_base)
        plane = LegGeometry.of(wide).plane_left_m  # about the plain stance's (the hips turn with the abduction)
        np.testing.assert_allclose(plane, LegGeometry.of(plain).plane_left_m, atol=2e-3)
    with pytest.raises(RobotDataError, match="stance_abduction_rad must be from 0 to 0.3"):
        Robot.load(dataclasses.replace(robot_spec("solo12"), stance_abduction_rad=-0.1), cache_dir=tmp_path)


def test_on_terrain_of_one_level_a_robot_stands_in_its_wider_stance(tmp_path):
    """``one_level_stance_abduction_rad`` (Solo12's 0.1): ``Robot.for_terrain`` gives, on terrain of one level, a twin
    whose stance is the spec's widened by it (the same as ``stance_abduction_rad`` would make it: feet 0.169 m from the
    centre line instead of 0.147 m), built once; on terrain with heights (several levels or sloped) the SRDF's stance
    (Solo12's twin there only presses its feet harder: ``heights_controller_gains``).
    A robot without it is itself everywhere; the value reads from and writes to a robot file, range-checked."""
    import dataclasses

    import numpy as np

    from contactnet.robots.description import Robot
    from contactnet.terrain import flat, resolve

    solo = load_robot("solo12", cache_dir=tmp_path)
    assert solo.spec.one_level_stance_abduction_rad == 0.1 and solo.spec.stance_abduction_rad == 0.0
    one_level, heights = resolve("push_field"), resolve("random_heights", removed=80, seed=0)
    assert not one_level.has_heights and heights.has_heights and resolve("ramps").has_heights
    wide = solo.for_terrain(one_level)
    assert wide is not solo and wide is solo.for_terrain(flat()) and wide.for_terrain(flat()) is wide
    on_heights = solo.for_terrain(heights)
    assert on_heights.spec.stance_abduction_rad == 0.0 and wide.name == solo.name == on_heights.name == "solo12"
    np.testing.assert_array_equal(on_heights.description.q_standing, solo.description.q_standing)
    np.testing.assert_allclose(np.abs(solo.description.foot_nominal_base[:, 1]), 0.147, atol=5e-4)
    np.testing.assert_allclose(np.abs(wide.description.foot_nominal_base[:, 1]), 0.169, atol=5e-4)
    reference = Robot.load(dataclasses.replace(solo.spec, stance_abduction_rad=0.1), cache_dir=tmp_path).description
    np.testing.assert_array_equal(wide.description.q_standing, reference.q_standing)
    np.testing.assert_array_equal(wide.description.foot_upright_base, solo.description.foot_nominal_base)
    go2 = load_robot("go2", cache_dir=tmp_path)
    walk, trot = go2.for_terrain(one_level, "walk"), go2.for_terrain(one_level, "trot")
    assert go2.for_terrain(one_level) is walk and walk.spec.stance_abduction_rad == 0.0  # the trot's stance only
    assert trot.spec.stance_abduction_rad == 0.1 and go2.for_terrain(heights, "trot") is go2
    path = tmp_path / "a1.toml"
    path.write_text(A1.replace("fall_base_height_m = 0.12\n",
                               "fall_base_height_m = 0.12\none_level_stance_abduction_rad = 0.05\n")
                    .replace('name = "a1_file"', 'name = "a1_one_level"'))
    spec = load_robot_file(path)
    assert spec.one_level_stance_abduction_rad == 0.05 and spec_values(spec)["one_level_stance_abduction_rad"] == 0.05
    plain = dataclasses.replace(robot_spec("go2"), one_level_stance_abduction_rad=0.0)
    assert "one_level_stance_abduction_rad" not in spec_values(plain)  # 0: not written
    assert spec_values(robot_spec("go2"))["one_level_stance_gaits"] == ["trot"]
    with pytest.raises(RobotDataError, match="one_level_stance_abduction_rad must be from 0 to 0.3"):
        Robot.load(dataclasses.replace(solo.spec, one_level_stance_abduction_rad=float("nan")), cache_dir=tmp_path)


def test_controller_gains_for_terrain_of_one_level_only_are_taken_there_by_every_gait(tmp_path):
    """``one_level_controller_gains`` (Go2's legs' weight held, ``leg_gravity`` 1, and its feedback spread again,
    ``unload_rounds`` 2): on terrain of one level every gait's robot has them over ``controller_gains`` (the trot's with
    its wider stance too), on terrain with heights the robot itself keeps its own; Solo12 has none. They read from and
    write to a robot file's table; a bad value is named."""
    import dataclasses

    from contactnet.motion.controller import ControllerGains
    from contactnet.terrain import resolve

    one_level, heights = resolve("push_field"), resolve("random_heights", removed=80, seed=0)
    go2 = load_robot("go2", cache_dir=tmp_path)

    def gains(robot):
        return ControllerGains.for_robot(robot.description)

    assert gains(go2).leg_gravity == 0.0 and gains(go2.for_terrain(heights, "walk")).leg_gravity == 0.0
    assert gains(go2).unload_rounds == gains(go2.for_terrain(heights, "trot")).unload_rounds == 0
    for gait in ("walk", "trot"):
        twin = go2.for_terrain(one_level, gait)
        assert gains(twin).leg_gravity == 1.0 and gains(twin).kd_joint == gains(go2).kd_joint == 0.2
        assert gains(twin).unload_rounds == 2
        assert twin.name == "go2" and twin.for_terrain(one_level, gait) is twin
    solo = load_robot("solo12", cache_dir=tmp_path)
    assert solo.spec.one_level_controller_gains == () and gains(solo.for_terrain(one_level)).leg_gravity == 0.0
    assert spec_values(robot_spec("go2"))["one_level_controller_gains"] == {"leg_gravity": 1.0, "unload_rounds": 2}
    assert "one_level_controller_gains" not in spec_values(robot_spec("solo12"))
    path, spec = _file_with_table(tmp_path, "a1_level_gains", "one_level_controller_gains",
                                  "leg_gravity = 1\nkd_joint = 0.3")
    assert spec.one_level_controller_gains == (("leg_gravity", 1.0), ("kd_joint", 0.3))
    assert spec_values(spec)["one_level_controller_gains"] == {"leg_gravity": 1.0, "kd_joint": 0.3}
    robot = load_robot(str(path), cache_dir=tmp_path)
    assert gains(robot.for_terrain(one_level, "walk")).kd_joint == 0.3 and gains(robot).kd_joint == 0.1
    path.write_text(A1 + "\n[one_level_controller_gains]\nleg_gravity = true\n")
    with pytest.raises(RobotDataError, match="one_level_controller_gains.leg_gravity: expected a number"):
        load_robot_file(path)
    assert dataclasses.replace(robot_spec("go2"), one_level_controller_gains=()) != robot_spec("go2")


def test_a_wider_stance_for_some_gaits_only_is_taken_by_those_gaits(tmp_path):
    """``one_level_stance_gaits``: on terrain of one level only the named gaits stand wider (``for_terrain(terrain,
    gait)``); another gait, or no gait named, keeps the robot's own stance, as does every gait on terrain with heights.
    The list reads from and writes to a robot file; a bad one is an error naming the field."""
    import dataclasses

    from contactnet.robots.description import Robot
    from contactnet.terrain import resolve

    solo = load_robot("solo12", cache_dir=tmp_path)
    one_level, heights = resolve("push_field"), resolve("random_heights", removed=80, seed=0)
    assert solo.for_terrain(one_level, "walk") is solo.for_terrain(one_level, "trot") is solo.for_terrain(one_level)
    trot_only = Robot.load(dataclasses.replace(solo.spec, one_level_stance_gaits=("trot",), heights_controller_gains=()),
                           cache_dir=tmp_path)
    wide = trot_only.for_terrain(one_level, "trot")
    assert wide is not trot_only and wide.spec.stance_abduction_rad == 0.1
    assert trot_only.for_terrain(one_level, "walk") is trot_only and trot_only.for_terrain(one_level) is trot_only
    assert trot_only.for_terrain(heights, "trot") is trot_only
    path = tmp_path / "a1.toml"
    path.write_text(A1.replace("fall_base_height_m = 0.12\n", "fall_base_height_m = 0.12\n"
                               "one_level_stance_abduction_rad = 0.05\none_level_stance_gaits = [\"trot\"]\n"))
    spec = load_robot_file(path)
    assert spec.one_level_stance_gaits == ("trot",) and spec_values(spec)["one_level_stance_gaits"] == ["trot"]
    assert "one_level_stance_gaits" not in spec_values(robot_spec("solo12"))  # every gait: not written
    path.write_text(A1.replace("fall_base_height_m = 0.12\n", "fall_base_height_m = 0.12\none_level_stance_gaits = 3\n"))
    with pytest.raises(RobotDataError, match="one_level_stance_gaits: expected a list of gait names"):
        load_robot_file(path)
    with pytest.raises(RobotDataError, match="one_level_stance_gaits must be None"):
        Robot.load(dataclasses.replace(solo.spec, one_level_stance_gaits=["trot"]), cache_dir=tmp_path)


def test_controller_gains_for_terrain_with_heights_read_and_write_and_are_taken_there(tmp_path):
    """A robot file's ``[heights_controller_gains]`` (Solo12's ``fz_min_n`` in its module): read, written back, taken
    by the robot on terrain with heights only (over ``[controller_gains]``); a bad value is named."""
    from contactnet.motion.controller import ControllerGains
    from contactnet.terrain import resolve

    assert spec_values(robot_spec("solo12"))["heights_controller_gains"] == {"fz_min_n": 0.98}
    assert "heights_controller_gains" not in spec_values(robot_spec("go2"))
    path, spec = _file_with_table(tmp_path, "a1_heights_gains", "heights_controller_gains", "fz_min_n = 2")
    assert spec.heights_controller_gains == (("fz_min_n", 2.0),)
    assert spec_values(spec)["heights_controller_gains"] == {"fz_min_n": 2.0}
    assert "[heights_controller_gains]" in to_toml(spec_values(spec))
    robot = load_robot(str(path), cache_dir=tmp_path)
    heights = robot.for_terrain(resolve("stairs"), "walk")
    assert ControllerGains.for_robot(heights.description).fz_min_n == 2.0
    assert ControllerGains.for_robot(heights.description).kd_joint == 0.1  # [controller_gains] under it
    assert ControllerGains.for_robot(robot.for_terrain(resolve("push_field"), "walk").description).fz_min_n == 0.5
    path.write_text(A1 + "\n[heights_controller_gains]\nfz_min_n = \"hard\"\n")
    with pytest.raises(RobotDataError, match="heights_controller_gains.fz_min_n: expected a number"):
        load_robot_file(path)
