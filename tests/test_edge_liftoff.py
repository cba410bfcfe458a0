"""A foot that stands near an edge lifts straight up (contactnet.motion.swing.edge_liftoff_fraction): a ball foot rolls
forward while it stands, and moving it toward its landing at once dragged it over the edge into the hole."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from contactnet.motion.swing import EDGE_LIFTOFF_FRACTION, edge_liftoff_fraction
from contactnet.terrain import Terrain


def _one_square() -> Terrain:
    return Terrain.from_dict({"name": "square", "start": [0.0, 0.0], "goal_x": 1.0, "regions": [
        {"shape": "rect", "center": [0.0, 0.0], "size": [0.2, 0.2]}]})


@pytest.mark.parametrize("x, lifts", [(0.0, False), (0.08, False), (0.086, True), (0.095, True), (0.105, True)])
def test_only_a_foot_within_its_radius_of_an_edge_lifts_straight_up(x: float, lifts: bool) -> None:
    """The square's edge is at x = 0.1; the ball's radius 1.6 cm: from x = 0.084 it stands within it."""
    fraction = edge_liftoff_fraction(_one_square(), np.array([x, 0.0, 0.016]), 0.016)
    assert fraction == (EDGE_LIFTOFF_FRACTION if lifts else 0.0)


@pytest.mark.slow
def test_the_rolled_foot_no_longer_falls_into_the_hole(robot, monkeypatch) -> None:
    """Friction 0.5, random field n = 80, seed 13, walk: the front left foot rolls to the edge of its square while it
    stands; moving it toward its landing at once dragged it into the hole (the paper's swing), lifting it first
    does not."""
    from contactnet.jobs.experiment import Trial, run_trial
    from contactnet.locomotion import LocomotionConfig
    from contactnet.sim.mismatch import ModelMismatch

    trial = Trial("random", "random", 80, 13, "walk", "contactnet", 0.05, 0.0, None,
                  mismatch=ModelMismatch(friction=0.5))
    assert run_trial(trial)["success"]
    import contactnet.locomotion as loop

    paper = replace(LocomotionConfig(), edge_liftoff_fraction=0.0)  # the trial's loop config, edge lift-off off
    monkeypatch.setattr(loop, "LocomotionConfig", lambda **kw: replace(paper, **kw))
    result = run_trial(trial)
    assert not result["success"] and "FL" in result["fall_reason"] and "gap" in result["fall_reason"]
