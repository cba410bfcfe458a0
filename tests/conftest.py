"""Shared fixtures: one Solo12 model per test session (loading it takes a few ms, but keep it one)."""

from __future__ import annotations

import pytest

from contactnet.robots import Robot, load_robot


@pytest.fixture(scope="session")
def robot(tmp_path_factory) -> Robot:
    return load_robot("solo12", cache_dir=tmp_path_factory.mktemp("cache"))
