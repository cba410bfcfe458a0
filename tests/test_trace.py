"""A run's trace (``contactnet.jobs.trace``, ``simulate --trace``): it reads the run and never changes it, on both
engines; its whole-body rotation is the one a plain sum over the links gives; its files and its mistakes."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from contactnet.cli import EXIT_USER_ERROR, main
from contactnet.jobs.trace import (
    LoopTrace,
    TraceConfig,
    TraceError,
    body_angular_velocity,
    columns,
    hold_margin,
)
from contactnet.locomotion import Locomotion
from contactnet.motion.gait import WALK
from contactnet.motion.support_polygon import support_distance
from contactnet.planning.heuristic import HeuristicPlanner
from contactnet.sim.world import ENGINES, Push, SimConfig
from contactnet.terrain import flat

FLAT_WALK = ["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic"]


def body_angular_velocity_by_links(model, data, q: np.ndarray, v: np.ndarray) -> np.ndarray:  # noqa: ANN001
    """The reference: every link's momentum summed about the robot's CoM, over the links' inertias summed there."""
    import pinocchio as pin

    pin.forwardKinematics(model, data, q, v)
    masses, coms, vels, rots, inertias, omegas = [], [], [], [], [], []
    for joint in range(1, model.njoints):
        link = model.inertias[joint]
        placement, twist = data.oMi[joint], data.v[joint]  # the twist in the joint's frame, at its origin
        rot = placement.rotation
        masses.append(link.mass)
        coms.append(placement.translation + rot @ link.lever)
        vels.append(rot @ (twist.linear + np.cross(twist.angular, link.lever)))
        omegas.append(rot @ twist.angular)
        rots.append(rot)
        inertias.append(link.inertia)
    com = np.average(coms, axis=0, weights=masses)
    momentum, inertia = np.zeros(3), np.zeros((3, 3))
    for m, c, vel, rot, i_link, omega in zip(masses, coms, vels, rots, inertias, omegas, strict=True):
        r = c - com
        i_world = rot @ i_link @ rot.T
        momentum += i_world @ omega + m * np.cross(r, vel)
        inertia += i_world + m * (r @ r * np.eye(3) - np.outer(r, r))
    return np.linalg.solve(inertia, momentum)


def test_the_whole_body_rotation_is_the_sum_over_the_links(robot):
    """``body_angular_velocity`` (pinocchio's centroidal momentum) against the plain sum; with the joints at rest it
    is the base's own rate (world axes)."""
    import pinocchio as pin

    model, rng = robot.model, np.random.default_rng(3)
    data = model.createData()
    for _ in range(5):
        quat = rng.normal(size=4)
        q = np.concatenate([rng.normal(size=3), quat / np.linalg.norm(quat), robot.joint_standing
                            + rng.normal(scale=0.3, size=12)])
        v = rng.normal(size=18)
        assert np.allclose(body_angular_velocity(model, data, q, v),
                           body_angular_velocity_by_links(model, model.createData(), q, v), atol=1e-9)
        v[6:] = 0.0
        rot = pin.Quaternion(q[3:7]).toRotationMatrix()
        assert np.allclose(body_angular_velocity(model, data, q, v), rot @ v[3:6], atol=1e-9)


def _walk(robot, engine: str, trace: LoopTrace | None, seconds: float = 1.2) -> dict:
    config = SimConfig(engine=engine, joint_vel_noise_var=0.01, seed=4)  # noise: a trace that drew it would show
    with Locomotion(robot, flat(), WALK, HeuristicPlanner(WALK), config, vel_cmd_xy=(0.1, 0.0)) as loco:
        loco.push(Push(0.5, 0.3, (0.0, 4.0, 0.0)))
        summary = loco.run(seconds) if trace is None else trace.run(loco, seconds)
    return {k: v for k, v in summary.items() if k not in ("wall_time_s", "planner_ms", "trajopt_ms")}  # clocks


@pytest.mark.parametrize("engine", ENGINES)
def test_a_traced_run_is_the_same_run_and_the_forces_add_up(robot, engine):
    """Traced or not, the same run to the last digit (with sensor noise on, and a push); the samples every 10 ms from
    0.2 s; the ground carries the robot's weight as measured and as planned, the push is there while it lasts, a
    foot planned in swing is planned no force, a foot on the flat ground has its ball's centre a radius up, and the
    hold margin, there only while pushed, is positive with four feet down."""
    trace = LoopTrace(TraceConfig(every_ms=10, from_s=0.2))
    assert _walk(robot, engine, trace) == _walk(robot, engine, None)
    table = trace.table()
    col = {name: i for i, name in enumerate(columns())}
    assert np.allclose(table[:, col["t_s"]], np.arange(0.21, 1.2001, 0.01))
    weight = robot.mass_kg * 9.81
    measured = sum(table[:, col[f"{leg}_meas_fz_n"]] for leg in ("FL", "FR", "HL", "HR"))
    planned = sum(table[:, col[f"{leg}_plan_fz_n"]] for leg in ("FL", "FR", "HL", "HR"))
    assert np.median(measured) == pytest.approx(weight, rel=0.1)
    assert np.median(planned) == pytest.approx(weight, rel=0.1)
    pushed = (table[:, col["t_s"]] > 0.5) & (table[:, col["t_s"]] <= 0.8)
    assert np.all(table[pushed, col["push_fy_n"]] == 4.0) and np.all(table[~pushed, col["push_fy_n"]] == 0.0)
    swinging = 0
    for leg in ("FL", "FR", "HL", "HR"):
        swing = table[:, col[f"{leg}_stance"]] == 0.0
        assert np.all(table[swing, col[f"{leg}_plan_fz_n"]] == 0.0)
        assert np.all(np.isin(table[:, col[f"{leg}_contact"]], (0.0, 1.0)))
        down = table[:, col[f"{leg}_contact"]] == 1.0
        assert np.allclose(table[down, col[f"{leg}_z_m"]], robot.description.foot_radius_m, atol=3e-3)
        assert np.all(table[swing & ~down, col[f"{leg}_z_m"]] > robot.description.foot_radius_m)
        swinging += swing.sum()
    assert swinging >= 10  # the walk stepped
    margin = table[:, col["push_hold_margin_m"]]
    assert np.all(np.isnan(margin[~pushed])) and np.all(np.isfinite(margin[pushed]))
    four = sum(table[:, col[f"{leg}_contact"]] for leg in ("FL", "FR", "HL", "HR")) == 4.0
    assert np.all(margin[pushed] < 0.3) and (pushed & four).sum() >= 3 and (pushed & ~four).sum() >= 3
    assert np.all(margin[pushed & four] > 0.0)  # 4 N (4.9 cm asked) is held on four feet (about 0.15 m out)
    assert np.all(margin[pushed & ~four] < margin[pushed & four].max())  # a foot in the air: a smaller polygon


def test_the_hold_margin_is_the_support_reach_beyond_the_push_and_capture_point():
    """``hold_margin`` against the numbers worked by hand: four feet at (+-0.1, +-0.1) m around a CoM 0.3 m up, 10 kg,
    a 10 N push along +y asks the centre of pressure 10 * 0.3 / (10 * 9.81) = 3.06 cm toward it; moving at 0.1 m/s
    along it asks 0.1 / sqrt(9.81 / 0.3) = 1.75 cm more; along the diagonal the corner reaches 0.1 sqrt(2)."""
    feet = np.array([[0.1, 0.1], [0.1, -0.1], [-0.1, 0.1], [-0.1, -0.1]])
    com, still = np.array([0.0, 0.0, 0.3]), np.zeros(3)
    asked = 10.0 * 0.3 / (10.0 * 9.81)
    assert hold_margin(np.array([0.0, 10.0]), com, still, feet, 0.3, 10.0) == pytest.approx(0.1 - asked)
    moving = np.array([0.0, 0.1, 0.0])
    assert hold_margin(np.array([0.0, 10.0]), com, moving, feet, 0.3, 10.0) == pytest.approx(
        0.1 - asked - 0.1 / math.sqrt(9.81 / 0.3))
    assert hold_margin(np.array([0.0, -10.0]), com, moving, feet, 0.3, 10.0) == pytest.approx(
        0.1 - asked + 0.1 / math.sqrt(9.81 / 0.3))  # moving away from the push helps
    diagonal = np.array([10.0, 10.0]) / math.sqrt(2.0)
    assert hold_margin(diagonal, com, still, feet, 0.3, 10.0) == pytest.approx(0.1 * math.sqrt(2.0) - asked)
    assert hold_margin(np.array([0.0, 10.0]), com, still, feet[[1, 3]], 0.3, 10.0) == pytest.approx(-0.1 - asked)
    assert math.isnan(hold_margin(np.zeros(2), com, still, feet, 0.3, 10.0))
    assert hold_margin(np.array([0.0, 10.0]), com, still, feet[[0, 3]], 0.3, 10.0) == pytest.approx(-asked)  # a
    # diagonal pair: the line crosses it under the CoM, so no sideways push is held
    beside = np.array([[0.1, 0.1], [0.2, 0.1]])  # the line misses them: minus the asked point's distance to them
    assert hold_margin(np.array([0.0, 10.0]), com, still, beside, 0.3, 10.0) == pytest.approx(
        -math.hypot(0.1, 0.1 - asked))
    assert hold_margin(np.array([0.0, -10.0]), com, still, feet[[0, 2]], 0.3, 10.0) == pytest.approx(
        -0.1 - asked)  # the feet all behind the push: beyond the hull on the wrong side


def test_the_hold_margin_is_where_the_push_line_leaves_the_support_polygon():
    """Go2's walk as it stood at 4.06 s on flat ground (feet from the CoM: front-left 0.293 m ahead and only 0.070 m
    left, hind-left 0.245 m behind and 0.209 m left): a push along +y leaves the polygon on the edge between the left
    feet, at 0.070 + (0.209 - 0.070) * 0.293 / 0.538 = 0.1457 m, not at the hind foot's 0.209 m; 60 N on 15 kg at
    0.3 m asks 0.1223 m, 2.3 cm of margin."""
    feet = np.array([[0.293, 0.070], [0.303, -0.140], [-0.245, 0.209], [-0.237, -0.197]])
    com, still = np.array([0.0, 0.0, 0.3]), np.zeros(3)
    edge = 0.070 + (0.209 - 0.070) * 0.293 / (0.293 + 0.245)
    asked = 60.0 * 0.3 / (15.0 * 9.81)
    assert hold_margin(np.array([0.0, 60.0]), com, still, feet, 0.3, 15.0) == pytest.approx(edge - asked)
    right = -0.140 + (-0.197 + 0.140) * 0.303 / (0.303 + 0.237)  # along -y: the right feet's edge, 0.172 m
    assert hold_margin(np.array([0.0, -60.0]), com, still, feet, 0.3, 15.0) == pytest.approx(-right - asked)
    assert math.isnan(hold_margin(np.array([0.0, 10.0]), com, still, feet[:0], 0.3, 10.0))


def test_the_hold_margin_matches_a_walk_along_the_push_line():
    """Against a slow reference: step along the push's line in 0.1 mm steps and take the last point inside the
    feet's hull (``support_distance`` 0) and the first; the margin is the nearer of the two to the asked point, and
    where the line misses the hull minus that point's distance to it (random stances of 3 and 4 feet, random pushes;
    the CoM inside the hull or not)."""
    rng = np.random.default_rng(7)
    com, still = np.array([0.0, 0.0, 0.3]), np.zeros(3)
    s = np.arange(-0.6, 0.6, 1e-4)
    for case in range(40):
        n = 3 + case % 2
        feet = rng.uniform(-0.25, 0.25, (n, 2))
        force = rng.uniform(-60.0, 60.0, 2)
        along = force / np.hypot(*force)
        asked = np.hypot(*force) * 0.3 / (15.0 * 9.81)
        padded = np.vstack([feet, np.zeros((4 - n, 2))])
        stance = np.arange(4) < n
        inside = support_distance(s[:, None] * along, np.broadcast_to(padded, (len(s), 4, 2)), stance) == 0.0
        margin = hold_margin(force, com, still, feet, 0.3, 15.0)
        if inside.any():
            assert margin == pytest.approx(min(s[inside].max() - asked, asked - s[inside].min()), abs=2e-4)
        else:  # the line misses the hull: minus the asked point's distance to it
            assert margin == pytest.approx(-float(support_distance(asked * along, padded, stance)))


def test_simulate_writes_the_trace_and_its_plot(tmp_path, capsys):
    """``--trace`` and ``--trace-plot``: a CSV of the columns and a PNG; ``--json`` stays one JSON object on stdout."""
    out_csv, out_png = tmp_path / "run.csv", tmp_path / "run.png"
    assert main([*FLAT_WALK, "--duration", "0.5", "--json", "--trace", str(out_csv), "--trace-plot", str(out_png),
                 "--trace-every-ms", "20"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["sim_time_s"] == pytest.approx(0.5) and not summary["fell"]
    assert f"trace: {out_csv}, {out_png} (25 samples)" in captured.err
    with out_csv.open() as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == columns() and len(rows) == 26
    assert math.isclose(float(rows[-1][0]), 0.5)
    assert out_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("extra, needle", [
    (["--trace", "{tmp}/run.txt"], "must end in .csv"),
    (["--trace", "{tmp}/missing/run.csv"], "does not exist"),
    (["--trace-plot", "{tmp}/run.gif"], "must end in .png or .svg or .pdf"),
    (["--trace", "{tmp}"], "must end in .csv"),
    (["--trace", "{tmp}/run.csv", "--record", "{tmp}/run.viser"], "one at a time"),
])
def test_a_trace_file_that_cannot_be_written_is_one_line_before_running(extra, needle, tmp_path, capsys):
    args = [part.format(tmp=tmp_path) for part in extra]
    assert main([*FLAT_WALK, *args]) == EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not list(tmp_path.glob("*.csv")) and not list(tmp_path.glob("*.viser"))


def test_a_trace_that_starts_after_the_run_writes_no_file(tmp_path, capsys):
    out_csv = tmp_path / "late.csv"
    assert main([*FLAT_WALK, "--duration", "0.2", "--trace", str(out_csv), "--trace-from", "5"]) == 0
    assert "trace: no samples" in capsys.readouterr().err and not out_csv.exists()


@pytest.mark.parametrize("value", ["0", "1001", "ten"])
def test_a_bad_sampling_interval_exits_2(value, capsys):
    with pytest.raises(SystemExit) as exc:
        main([*FLAT_WALK, "--trace-every-ms", value])
    assert exc.value.code == EXIT_USER_ERROR and "--trace-every-ms" in capsys.readouterr().err


def test_the_config_refuses_what_it_cannot_sample():
    with pytest.raises(TraceError, match="every_ms"):
        TraceConfig(every_ms=0)
    with pytest.raises(TraceError, match="from_s"):
        TraceConfig(from_s=float("nan"))
    assert replace(TraceConfig(), from_s=2.0).from_s == 2.0
