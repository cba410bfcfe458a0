"""Every script in examples/ runs (short durations) and prints what it promises: examples never rot."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

#: script -> (arguments for a short run, text its output must contain)
CASES = {
    "01_simulate_stepping_stones.py": (["--duration", "3"], '"steps"'),
    "02_terrain_in_code.py": (["--duration", "3"], "three_stones"),
    "03_custom_planner.py": (["--duration", "3"], "planners: contactnet, fixed, heuristic, oracle, contactnet_paper, cautious"),
    "04_go2_walks.py": (["--duration", "3"], "go2 trot: fell=False"),
    "05_custom_gait.py": (["--duration", "3"], "gaits: walk, trot, pace"),
    "06_trace_a_push.py": (["--duration", "3"], "trace: 300 samples over 3.00 s; fell=False"),
}


def test_every_example_is_checked():
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == sorted(CASES)


@pytest.mark.slow
@pytest.mark.parametrize("script", sorted(CASES))
def test_example_runs(script, tmp_path):
    args, expected = CASES[script]
    run = subprocess.run([sys.executable, str(EXAMPLES / script), *args], capture_output=True, text=True,
                         timeout=300, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert expected in run.stdout, run.stdout[-2000:]
