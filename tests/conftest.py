"""Shared fixtures: one Solo12 model per test session (loading it takes a few ms, but keep it one)."""

from __future__ import annotations

import pytest

from contactnet.robot import Solo12


@pytest.fixture(scope="session")
def robot(tmp_path_factory) -> Solo12:
    return Solo12.load(cache_dir=tmp_path_factory.mktemp("cache"))
