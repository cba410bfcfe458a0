"""Plugins: entry points of installed packages register robots, planners, gaits and terrains everywhere.

The unit tests load made-up entry points; the slow one installs ``examples/plugin`` with pip (into a folder of its
own, never into this environment) and drives its robot, planner and terrain through the command line, including an
experiment whose trials run in a pool of worker processes.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

from contactnet import plugins

ROOT = Path(__file__).resolve().parents[1]


def _points(*points: EntryPoint):  # noqa: ANN202 - an importlib.metadata.entry_points stand-in
    def entry_points(group: str) -> list[EntryPoint]:
        return [p for p in points if p.group == group]

    return entry_points


def test_a_plugin_is_a_module_or_a_function_and_a_broken_one_is_named_and_skipped(capsys, tmp_path, monkeypatch):
    (tmp_path / "good_plugin.py").write_text(
        "CALLS = []\n"
        "def register():\n"
        "    CALLS.append('registered')\n")
    (tmp_path / "broken_plugin.py").write_text("raise RuntimeError('the plugin is broken\\nsecond line')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    loads = plugins._load_groups(_points(
        EntryPoint("good", "good_plugin:register", "contactnet.planners"),
        EntryPoint("broken", "broken_plugin", "contactnet.robots"),
        EntryPoint("absent", "no_such_module_anywhere", "contactnet.terrains"),
        EntryPoint("other", "good_plugin:register", "not.contactnet"),  # not a group contactnet reads
    ))
    import good_plugin

    assert good_plugin.CALLS == ["registered"]  # called once: the other group is not read
    by_name = {load.name: load for load in loads}
    assert set(by_name) == {"good", "broken", "absent"}
    assert by_name["good"].error is None
    assert by_name["broken"].error == "RuntimeError: the plugin is broken"
    assert by_name["absent"].error.startswith("ModuleNotFoundError")
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and all(line.startswith("contactnet: plugin ") for line in err)
    assert "broken (contactnet.robots, broken_plugin) did not load: RuntimeError" in err[0]


def test_a_registered_terrain_is_resolved_by_name_and_cannot_take_a_shipped_name():
    from contactnet.terrain import flat, register_terrain, registered_terrains, resolve
    from contactnet.terrain.scenes import _REGISTERED

    def wide_flat():  # noqa: ANN202
        return flat()

    register_terrain("test_wide_flat", wide_flat)
    try:
        assert "test_wide_flat" in registered_terrains()
        assert resolve("test_wide_flat").name == flat().name
        with pytest.raises(ValueError, match="already exists"):
            register_terrain("stepping_stones", wide_flat)
        with pytest.raises(ValueError, match="already exists"):
            register_terrain("test_wide_flat", wide_flat)
    finally:
        del _REGISTERED["test_wide_flat"]


@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory) -> Path:
    """``examples/plugin`` installed with pip into a folder of its own (no dependencies, no build isolation: offline),
    built from a copy: the build writes its ``build/`` and ``*.egg-info`` beside the sources, not into the checkout."""
    source = tmp_path_factory.mktemp("plugin_source") / "plugin"
    shutil.copytree(ROOT / "examples" / "plugin", source, ignore=shutil.ignore_patterns("build", "*.egg-info"))
    target = tmp_path_factory.mktemp("plugin")
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", "--target",
                    str(target), str(source)], check=True, capture_output=True, timeout=300)
    return target


def _cli(plugin_path: Path, *args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(plugin_path), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "contactnet", *args], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=900)


@pytest.mark.slow
def test_the_example_plugin_reaches_the_command_line_and_the_workers(plugin_path, tmp_path):
    listed = _cli(plugin_path, "terrain", "list")
    assert "gap_course  (registered by a plugin)" in listed.stdout, listed.stderr
    a1 = _cli(plugin_path, "simulate", "--robot", "a1", "--terrain", "flat", "--gait", "trot", "--planner",
              "heuristic", "--vx", "0.1", "--duration", "4", "--json")
    assert a1.returncode == 0, a1.stderr
    result = json.loads(a1.stdout)  # valid JSON: A1's URDF warnings (its base has no inertia) are not on stdout
    assert not result["fell"] and result["reached_x"] > 0.2
    crossed = _cli(plugin_path, "simulate", "--terrain", "gap_course", "--gait", "walk", "--planner", "wide_margin",
                   "--duration", "60", "--json")
    assert crossed.returncode == 0, crossed.stderr
    assert json.loads(crossed.stdout)["success"]
    # The trials run in two worker processes: they see the plugin's planner too.
    out = tmp_path / "stones"
    experiment = _cli(plugin_path, "experiment", "stepping_stones", "--planners", "wide_margin", "--gaits",
                      "walk,trot", "--workers", "2", "--quiet", "--out", str(out))
    assert experiment.returncode == 0, experiment.stderr
    rows = json.loads((out / "summary.json").read_text())["rows"]
    assert {(r["gait"], r["planner"], r["successes"]) for r in rows} == {("walk", "wide_margin", 1),
                                                                         ("trot", "wide_margin", 1)}
    unknown = _cli(plugin_path, "simulate", "--robot", "b2", "--terrain", "flat", "--gait", "walk", "--planner",
                   "heuristic")
    assert unknown.returncode == 2 and "a1" in unknown.stderr  # the plugin's robot is among the choices
