"""Shared fixtures: one Solo12 model per test session (loading it takes a few ms, but keep it one), and one folder of
random-weight walk/trot models for the tests that must not depend on the shipped ones."""

from __future__ import annotations

import pytest

from contactnet.robots import Robot, load_robot


@pytest.fixture(scope="session")
def robot(tmp_path_factory) -> Robot:
    return load_robot("solo12", cache_dir=tmp_path_factory.mktemp("cache"))


@pytest.fixture(scope="session")
def random_models(tmp_path_factory):
    """A folder with walk.pt and trot.pt of random weights (``helpers.save_random_models``); read only."""
    from helpers import save_random_models

    folder = tmp_path_factory.mktemp("models")
    save_random_models(folder)
    return folder
