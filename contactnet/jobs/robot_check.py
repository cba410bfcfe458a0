"""`contactnet robot check NAME`: is a robot ready to walk here, and if not, what to tune.

Each check is measured, not read back from the robot's module: what the simulator loaded against what pinocchio
plans with (mass, CoM, composite inertia), where the feet stand under the hips and how bent the legs are, standing
10 s under the whole-body controller, and walking and trotting 20 s on flat ground with the heuristic planner (the
planner that needs no trained model). The verdict names the checks that failed and the robot module's fields that
tune them (``docs/robots.md``, "Tuning a robot").
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass

import numpy as np

#: Tolerances of the model check: mass (relative), CoM (m), composite inertia (relative to its largest entry).
MASS_TOLERANCE = 0.005
COM_TOLERANCE_M = 0.002
INERTIA_TOLERANCE = 0.01
#: A foot stands under its hip when it is within this fraction of the leg's length of it along x.
UNDER_HIP_FRACTION = 0.1
#: The standing leg's hip-to-foot distance as a fraction of its length: bent, but not crouched.
LEG_EXTENSION_RANGE = (0.55, 0.95)
#: Standing: the base may drift this far (m) in 10 s.
STAND_DRIFT_M = 0.03
#: Walking and trotting: at least this fraction of the commanded speed, sideways drift below this (m/s).
PROGRESS_FRACTION = 0.75
SIDEWAYS_M_S = 0.02


@dataclass(frozen=True)
class Check:
    """One check: its name, whether it passed, what was measured, and what to tune when it failed."""

    name: str
    passed: bool
    measured: str
    tune: str = ""


def model_checks(robot, engine: str) -> list[Check]:  # noqa: ANN001 - a Robot
    """The simulated robot against the model, and the stance's geometry."""
    from contactnet.robots.description import RobotDataError
    from contactnet.robots.sim_urdf import links_without_inertia
    from contactnet.sim.engines import make_simulator
    from contactnet.sim.world import SimConfig
    from contactnet.terrain import flat

    description = robot.description
    checks = []
    missing = links_without_inertia(ET.parse(robot.files.urdf).getroot())
    checks.append(Check("links with a mass", True, "every URDF link has an <inertial> block" if not missing else
                        f"{len(missing)} link(s) without <inertial> ({', '.join(missing[:4])}): given 1 mg, as pinocchio"
                        " gives them none"))
    try:
        with make_simulator(robot, flat(), SimConfig(engine=engine)) as sim:
            state = sim.state(with_contacts=False)
            simulated = sim.mass_properties()
    except RobotDataError as exc:
        return [*checks, Check(f"{engine} simulates the model", False, str(exc), "the URDF's <inertial> blocks")]
    com_base = state.base_rot_world.T @ (simulated.com_world - state.base_pos_world)
    com_error_m = float(np.abs(com_base - description.com_base_standing).max())
    inertia_error = float(np.abs(simulated.inertia_com_world - description.inertia_com_standing).max()
                          / np.abs(description.inertia_com_standing).max())
    mass_error = abs(simulated.mass_kg - description.mass_kg) / description.mass_kg
    checks.append(Check(
        f"{engine} simulates the model", mass_error <= MASS_TOLERANCE and com_error_m <= COM_TOLERANCE_M
        and inertia_error <= INERTIA_TOLERANCE,
        f"mass {simulated.mass_kg:.3f} kg (model {description.mass_kg:.3f}), CoM {1e3 * com_error_m:.1f} mm off, "
        f"inertia {100 * inertia_error:.2f} % off", "the URDF's <inertial> blocks, or the collision recipe"))
    reach = description.leg_reach_m
    offset_x_m = description.foot_nominal_base[:, 0] - description.hip_pos_base[:, 0]
    checks.append(Check(
        "feet under the hips", bool(np.abs(offset_x_m).max() <= UNDER_HIP_FRACTION * reach),
        f"largest foot-to-hip offset along x {100 * np.abs(offset_x_m).max():.1f} cm (leg {100 * reach:.1f} cm)",
        "standing_leg_joints_rad (the stance's joint angles)"))
    extension = np.linalg.norm(description.foot_nominal_base - description.hip_pos_base, axis=1) / reach
    low, high = LEG_EXTENSION_RANGE
    checks.append(Check(
        "legs bent, not straight", bool(low <= extension.min() and extension.max() <= high),
        f"hip to foot {100 * extension.min():.0f}-{100 * extension.max():.0f} % of the leg's length "
        f"(from {100 * low:.0f} to {100 * high:.0f} %)", "standing_leg_joints_rad (a straight knee is singular)"))
    return checks


def stand_check(robot, engine: str, seconds: float = 10.0) -> Check:  # noqa: ANN001 - a Robot
    """All four feet in stance, the whole-body controller holding the first CoM with the weight shared."""
    from contactnet.motion.controller import ControlTarget, WholeBodyController
    from contactnet.sim.engines import make_simulator
    from contactnet.sim.world import SimConfig
    from contactnet.terrain import flat

    controller = WholeBodyController(robot)
    with make_simulator(robot, flat(), SimConfig(engine=engine)) as sim:
        state = sim.state()
        start_m = state.base_pos_world.copy()
        com, _, feet, _ = controller.kinematics(state.q_pinocchio(), state.v_pinocchio())
        target = ControlTarget(com_pos=com, com_vel=np.zeros(3), rpy=np.zeros(3), ang_vel=np.zeros(3),
                               forces=np.tile([0.0, 0.0, robot.mass_kg * 9.81 / 4], (4, 1)),
                               stance=np.ones(4, dtype=bool), swing_pos=feet, swing_vel=np.zeros((4, 3)))
        reason = None
        for tick in range(round(seconds / sim.config.dt_s)):
            sim.step(controller.torques(state.q_pinocchio(), state.v_pinocchio(), target))
            state = sim.state(with_contacts=False)
            if tick % 100 == 0 and (reason := sim.fall_reason(state)) is not None:
                break
        drift_m = float(np.abs(state.base_pos_world - start_m).max())
    name = f"stands {seconds:g} s"
    tune = "controller_gains (kp_com, kd_com, kp_base_rot, kd_base_rot), fz_max_n, fall_base_height_m"
    if reason is not None:
        return Check(name, False, f"fell at {sim.t_s:.2f} s: {reason}", tune)
    return Check(name, drift_m <= STAND_DRIFT_M, f"base moved {100 * drift_m:.1f} cm", tune)


def walk_check(robot, gait_name: str, engine: str, seconds: float = 20.0, vx_m_s: float = 0.1) -> Check:  # noqa: ANN001
    """The heuristic planner's ``gait_name`` on flat ground at ``vx_m_s`` for ``seconds``."""
    from contactnet.locomotion import Locomotion
    from contactnet.registry import gait_for, make_planner
    from contactnet.sim.world import SimConfig
    from contactnet.terrain import flat

    terrain = flat()
    robot = robot.for_terrain(terrain, gait_name)  # its stance on flat ground (one_level_stance_abduction_rad)
    gait = gait_for(gait_name, robot)
    planner = make_planner("heuristic", gait, robot)
    with Locomotion(robot, terrain, gait, planner, SimConfig(engine=engine), vel_cmd_xy=(vx_m_s, 0.0)) as loco:
        summary = loco.run(seconds, stop_at_goal=False)
    vx, vy = summary["mean_velocity_xy"]
    name = f"{gait_name}s {seconds:g} s at {vx_m_s:g} m/s (heuristic planner)"
    tune = ("controller_gains (kp_swing, kd_swing, kd_joint), kin_threshold_m, fz_max_n; for a robot of another size "
            "the gait's step timing")
    if summary["fell"]:
        return Check(name, False, f"fell at {summary['sim_time_s']:.2f} s: {summary['fall_reason']}", tune)
    return Check(name, vx >= PROGRESS_FRACTION * vx_m_s and abs(vy) < SIDEWAYS_M_S,
                 f"{vx:.3f} m/s forward ({100 * vx / vx_m_s:.0f} % of the command), {vy:+.3f} m/s sideways", tune)


def check_robot(robot, engine: str = "pybullet", stand_s: float = 10.0, walk_s: float = 20.0,  # noqa: ANN001
                gaits: tuple[str, ...] = ("walk", "trot")) -> list[Check]:
    """Every check of ``robot`` in ``engine``; the motion checks run only when the model checks pass."""
    checks = model_checks(robot, engine)
    if all(c.passed for c in checks):
        checks.append(stand_check(robot, engine, stand_s))
        checks += [walk_check(robot, gait, engine, walk_s) for gait in gaits]
    return checks


def verdict(robot_name: str, checks: list[Check]) -> str:
    """One line: ready, or which checks failed and what to tune; when ready, the ContactNet models the robot has in
    the package (``registry.model_path``) or that it needs its own."""
    failed = [c for c in checks if not c.passed]
    if not failed:
        from contactnet.registry import model_path

        models = [model_path(robot_name, gait) for gait in ("walk", "trot")]
        if all(path.is_file() for path in models):
            return f"{robot_name}: ready (every check passed); its ContactNet models: " + ", ".join(p.name for p in models)
        return f"{robot_name}: ready (every check passed); ContactNet needs its own models: contactnet datagen and train"
    return f"{robot_name}: not ready: " + "; ".join(f"{c.name}: tune {c.tune}" for c in failed)


def format_checks(robot_name: str, checks: list[Check]) -> str:
    lines = [f"{'ok' if c.passed else 'FAIL':4s}  {c.name}: {c.measured}" for c in checks]
    return "\n".join([*lines, verdict(robot_name, checks)])


def checks_as_json(robot_name: str, engine: str, checks: list[Check]) -> dict:
    return {"robot": robot_name, "sim": engine, "ready": all(c.passed for c in checks),
            "checks": [asdict(c) for c in checks], "verdict": verdict(robot_name, checks)}


__all__ = ["Check", "check_robot", "checks_as_json", "format_checks", "model_checks", "stand_check", "verdict",
           "walk_check"]
