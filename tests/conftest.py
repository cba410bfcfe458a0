"""Shared fixtures: one Solo12 model per test session (loading it takes a few ms, but keep it one), and one folder of
random-weight walk/trot models for the tests that must not depend on the shipped ones. Also: every test that drives a
browser is marked ``browser``, and the run ends with a warning naming modules over the 600-line cap."""

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


def pytest_collection_modifyitems(items) -> None:  # noqa: ANN001 - pytest's hook
    """Mark ``browser`` every test that drives Debian's chromium (its module's marks, or a ``browser`` fixture),
    so ``pytest -m "not browser"`` runs everything else.

    With pytest-xdist (``make test`` runs ``-n auto --dist loadfile``) a test file stays on one worker: its module
    fixtures (a live server, a page) start once and its tests run in order, as some rely on (a panel opened by the
    test before). (``--dist loadgroup`` with ``xdist_group`` marks does not group on pytest 9: xdist 3.8 renames
    ``item._nodeid``, which pytest 9 no longer reads, and the tests of a file ran on both workers.)"""
    for item in items:
        if "browser" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.browser)


def pytest_terminal_summary(terminalreporter) -> None:  # noqa: ANN001 - pytest's hook
    """The line cap is a warning, not a goal: split a long module by concern when it says one grew."""
    from test_architecture import MAX_LINES, long_modules

    long = long_modules()
    if long:
        terminalreporter.write_line(f"warning: modules over {MAX_LINES} lines (split by concern): " + ", ".join(long),
                                    yellow=True)
