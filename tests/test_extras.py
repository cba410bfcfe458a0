"""torch is the extra ``train`` (contactnet.extras): everything but training runs without it, and what needs it says
how to get it in one line. "Without torch" is a subprocess whose ``import torch`` fails (``sys.modules['torch'] =
None``), as it does where the extra is not installed."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np

from contactnet.bench.trajopt import example_problem
from contactnet.motion.trajopt import TrajectoryOptimizer
from contactnet.motion.trajopt import ipm as ipm_module
from contactnet.motion.trajopt.model import SrbdModel, TrajoptConfig
from contactnet.registry import load_robot

NO_TORCH = "import sys; sys.modules['torch'] = None\n"


def _without_torch(code: str, timeout_s: float = 240.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", NO_TORCH + code], capture_output=True, text=True, timeout=timeout_s)


def test_simulate_with_the_network_planner_needs_no_torch() -> None:
    code = ("from contactnet.cli import main\n"
            "rc = main(['simulate', '--terrain', 'flat', '--gait', 'walk', '--planner', 'contactnet', '--vx', '0.1',"
            " '--duration', '2', '--json'])\n"
            "assert sys.modules.get('torch') is None, 'torch was imported'\n"
            "sys.exit(rc)\n")
    run = _without_torch(code)
    assert run.returncode == 0, run.stderr[-2000:]
    summary = json.loads(run.stdout)
    assert summary["steps"] >= 4 and not summary["fell"], summary
    assert summary["reached_x"] > 0.1, summary


def test_the_server_and_the_experiments_import_without_torch() -> None:
    code = ("import app.api.server, app.live.session, contactnet.jobs.experiment, contactnet.jobs.datagen, contactnet.planning.oracle\n"
            "from contactnet.jobs.experiment import _one_torch_thread\n"
            "_one_torch_thread()\n"
            "print('ok')\n")
    run = _without_torch(code)
    assert run.returncode == 0 and run.stdout.strip() == "ok", run.stderr[-2000:]


def test_train_without_torch_says_which_extra_in_one_line(tmp_path) -> None:
    code = ("from contactnet.cli import main\n"
            f"sys.exit(main(['train', '--gait', 'walk', '--data', {str(tmp_path)!r}, '--out', "
            f"{str(tmp_path / 'm.pt')!r}]))\n")
    run = _without_torch(code)
    assert run.returncode == 2, (run.returncode, run.stderr[-2000:])
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "contactnet[train]" in lines[0] and "torch==2.13.0" in lines[0], run.stderr
    assert not (tmp_path / "m.pt").exists()


def _moving(rng: np.random.Generator) -> np.ndarray:
    """A state (12,) walking at 0.2 m/s, a little tilted."""
    x0 = np.zeros(12)
    x0[2], x0[3] = 0.24, 0.2
    x0[6:8] = rng.uniform(-0.03, 0.03, 2)
    return x0


def test_batched_solves_without_torch_equal_those_with_it(monkeypatch) -> None:
    """The ranking's batched interior-point method factors with numpy when torch is missing: the same optima."""
    desc = load_robot("solo12").description
    opt = TrajectoryOptimizer(SrbdModel.for_robot(desc), TrajoptConfig(n_nodes=8, solver="qp-ipm"))
    rng = np.random.default_rng(5)
    problems = [example_problem(desc, [(int(rng.integers(4)),)], rng.uniform(-0.3, 0.3, 2), x0=_moving(rng),
                                foothold_offsets=rng.uniform(-0.1, 0.1, (1, 4, 2))) for _ in range(6)]
    with_torch = opt.solve_batch(problems)
    assert ipm_module._torch() is not None
    monkeypatch.setattr(ipm_module, "_torch", lambda: None)
    without = opt.solve_batch(problems)
    for a, b in zip(with_torch, without, strict=True):
        assert a.success and b.success
        assert math.isclose(a.cost, b.cost, rel_tol=1e-7)
        assert np.allclose(a.forces_world, b.forces_world, atol=1e-6)


NO_PYBULLET = "import sys; sys.modules['pybullet'] = None\n"


def test_without_pybullet_mujoco_is_the_engine_with_a_one_line_notice() -> None:
    """Where pybullet is not installed (Python 3.12 and newer: no wheel, ``pyproject.toml`` leaves it out)."""
    code = (NO_PYBULLET + "from contactnet.cli import main\n"
            "sys.exit(main(['simulate', '--terrain', 'flat', '--gait', 'walk', '--planner', 'contactnet', '--vx', '0.1',"
            " '--duration', '2', '--json']))\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=240)
    assert run.returncode == 0, run.stderr[-2000:]
    summary = json.loads(run.stdout)
    assert summary["sim"] == "mujoco" and not summary["fell"] and summary["reached_x"] > 0.1, summary
    notices = [line for line in run.stderr.splitlines() if "pybullet is not installed" in line]
    assert len(notices) == 1 and "mujoco" in notices[0]
    asked = (NO_PYBULLET + "from contactnet.cli import main\n"
             "sys.exit(main(['simulate', '--terrain', 'flat', '--gait', 'walk', '--planner', 'heuristic', '--sim',"
             " 'pybullet', '--duration', '1']))\n")
    run = subprocess.run([sys.executable, "-c", asked], capture_output=True, text=True, timeout=240)
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr[-2000:]
    assert "pybullet is not installed here" in run.stderr and "--sim mujoco" in run.stderr
