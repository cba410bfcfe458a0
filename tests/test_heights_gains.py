"""Controller gains on terrain with heights only (``RobotSpec.heights_controller_gains``, `Robot.for_terrain`):
Solo12's stance feet keep at least 4 % of its weight there (``fz_min_n`` 0.98 N instead of 0.5 N), so that a foot
near a stone's edge is not left unloaded while another leg swings (docs/results.md, "Stance feet pressed on terrain
with heights")."""

from dataclasses import replace

import pytest

from contactnet.motion.controller import ControllerGains
from contactnet.robots import load_robot
from contactnet.terrain import resolve


def _gains(robot) -> ControllerGains:  # noqa: ANN001
    return ControllerGains.for_robot(robot.description)


def test_solo12_presses_its_stance_feet_harder_on_terrain_with_heights_only(tmp_path):
    """On terrain with heights every gait's Solo12 has the heights gains over its own (and the SRDF's stance), on
    terrain of one level the wider stance and the default minimum load; a twin is its own robot on every terrain;
    Go2 has no heights gains (not measured there)."""
    solo = load_robot("solo12", cache_dir=tmp_path)
    heights, one_level = resolve("raised_stones"), resolve("push_field")
    assert _gains(solo).fz_min_n == ControllerGains().fz_min_n == 0.5
    for gait in ("walk", "trot"):
        twin = solo.for_terrain(heights, gait)
        assert twin is not solo and twin.name == "solo12" and twin.for_terrain(heights, gait) is twin
        assert _gains(twin).fz_min_n == pytest.approx(0.04 * solo.mass_kg * 9.81, abs=0.01)
        assert twin.spec.stance_abduction_rad == 0.0  # the SRDF's stance, as the robot itself on heights
        flat = solo.for_terrain(one_level, gait)
        assert _gains(flat).fz_min_n == 0.5 and flat.spec.stance_abduction_rad == 0.1
    assert solo.for_terrain(heights, "walk") is solo.for_terrain(heights, "trot")  # built once
    go2 = load_robot("go2", cache_dir=tmp_path)
    assert go2.spec.heights_controller_gains == () and go2.for_terrain(heights, "walk") is go2


@pytest.mark.slow
@pytest.mark.parametrize("fz_min_n", [None, 0.5], ids=["heights-gains", "the-default-0.5N"])
def test_solo12s_walk_in_mujoco_crosses_the_raised_stones_with_its_stance_feet_pressed(fz_min_n):
    """Issue 28's target (MuJoCo, the shipped raised stones, no noise, the walk crosses): with the heights gains it
    crosses; with the one-level minimum load (0.5 N) the front-left foot, planned at 0 N during a hind swing near a
    star's tip, slides off into the gap (the fall at 20.8 s, docs/results.md)."""
    from contactnet.locomotion import Locomotion
    from contactnet.registry import gait_for, make_planner
    from contactnet.sim.world import SimConfig

    terrain = resolve("raised_stones")
    robot = load_robot("solo12").for_terrain(terrain, "walk")
    gait = gait_for("walk", robot)
    gains = _gains(robot) if fz_min_n is None else replace(_gains(robot), fz_min_n=fz_min_n)
    with Locomotion(robot, terrain, gait, make_planner("contactnet", gait, robot), SimConfig(engine="mujoco"),
                    gains=gains, vel_cmd_xy=(0.05, 0.0)) as loco:
        summary = loco.run(40.0)
    if fz_min_n is None:
        assert summary["success"], summary["fall_reason"]
    else:
        assert summary["fell"], summary
