"""The serve settings (app/live/settings.py): one place for the web tool's start-up values and limits."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from app.live.settings import (
    PUSH_DURATION_LIMIT_S,
    PUSH_FORCE_LIMIT_N,
    SIM_SPEED_RANGE,
    VELOCITY_LIMIT_M_S,
    ServeSettings,
    settings_from_args,
)
from contactnet import registry

pytestmark = pytest.mark.app  # the web tool: `pytest -m "not app"` skips these


def test_defaults_and_limits():
    settings = ServeSettings()
    assert (settings.robot, settings.gait, settings.planner, settings.vx_m_s) == ("solo12", "walk", "contactnet", 0.05)
    assert (VELOCITY_LIMIT_M_S, PUSH_FORCE_LIMIT_N, PUSH_DURATION_LIMIT_S, SIM_SPEED_RANGE) == (0.3, 20.0, 5.0, (0.1, 2.0))
    assert ServeSettings(vx_m_s=-0.3, vy_m_s=0.3).vx_m_s == -0.3  # the limits themselves are allowed


@pytest.mark.parametrize(
    "field, value",
    [
        ("vx_m_s", 0.31),
        ("vx_m_s", -0.5),
        ("vx_m_s", float("nan")),
        ("vx_m_s", float("inf")),
        ("vx_m_s", "fast"),
        ("vy_m_s", 0.4),
        ("port", 70000),
        ("viser_port", 0),
        ("sim_speed", 3.0),
        ("record_hz", 100.0),
        ("gait", "gallop"),
        ("planner", "teleport"),
        ("robot", "spot"),
    ],
)
def test_out_of_range_values_are_one_line_errors_naming_the_field(field, value):
    with pytest.raises(ValueError) as info:
        ServeSettings(**{field: value})
    message = str(info.value)
    assert message.startswith(f"{field} must be") and "\n" not in message


def test_names_come_from_the_registry():
    for gait in registry.gait_names():
        assert ServeSettings(gait=gait).gait == gait
    for planner in registry.planner_names():
        assert ServeSettings(planner=planner).planner == planner
    for robot in registry.robot_names():
        assert ServeSettings(robot=robot).robot == robot


def test_settings_from_command_line_values():
    args = argparse.Namespace(host="0.0.0.0", port=8123, viser_port=8124, terrain="flat", robot="go2",
                              gait="trot", planner="heuristic", vx=0.1, recordings="rec", func=print)
    settings = settings_from_args(args)
    assert settings == ServeSettings(host="0.0.0.0", port=8123, viser_port=8124, terrain="flat", robot="go2",
                                     gait="trot", planner="heuristic", vx_m_s=0.1, recordings_dir=Path("rec"))
    assert settings_from_args({"vx": None}) == ServeSettings()  # absent values keep the defaults
    with pytest.raises(ValueError, match="^vx_m_s must be"):
        settings_from_args({"vx": 0.5})
