"""The web tool on terrain with heights, without a browser: a click ray lands on the top the user sees
(app/scene/terrain_pick.py), and the CoM lines and the goal line are drawn above the tops (app/scene/live_scene.py)."""

from __future__ import annotations

import numpy as np
import pytest

from app.scene.live_scene import _on_ground, goal_line_z
from app.scene.terrain_pick import ray_hit_xy, ray_to_plane
from contactnet.terrain import Terrain, flat, raised_stones, stairs, stepping_stones

pytestmark = pytest.mark.app

SLANT = np.array([0.5, 0.3, -1.0]) / np.linalg.norm([0.5, 0.3, -1.0])  # seen from above and behind


def ray_at(point) -> tuple[np.ndarray, np.ndarray]:  # noqa: ANN001
    """A camera ray (origin 1 m up along -SLANT) through the world point."""
    return np.asarray(point, float) - SLANT / abs(SLANT[2]), SLANT


def test_a_click_on_a_raised_stone_lands_on_its_top():
    terrain = raised_stones()
    for index in (4, 8):  # a star at +4.3 cm, a rect at +6 cm
        region = terrain.to_dict()["regions"][index]
        centre = np.array(region["center"])
        origin, direction = ray_at([*centre, region["z"]])
        assert ray_hit_xy(terrain, origin, direction) == pytest.approx(tuple(centre), abs=1e-6)
        on_plane = ray_to_plane(origin, direction, terrain.surface_z)  # the old answer: behind the stone
        assert np.linalg.norm(np.subtract(on_plane, centre)) > 0.02


def test_a_click_on_a_lowered_stone_and_in_a_hole():
    terrain = raised_stones()
    circle = terrain.to_dict()["regions"][6]  # at -6 cm
    origin, direction = ray_at([*circle["center"], circle["z"]])
    assert ray_hit_xy(terrain, origin, direction) == pytest.approx(tuple(circle["center"]), abs=1e-6)
    hole = (0.3, -0.23)
    assert np.isnan(terrain.height_at(hole))
    origin, direction = ray_at([*hole, 0.0])
    assert ray_hit_xy(terrain, origin, direction) == pytest.approx(hole, abs=1e-6)  # on the plane surface_z


def test_a_ray_into_a_riser_stops_at_the_wall():
    terrain = stairs()  # the first riser (0 -> 5 cm) at x = 0.25
    hit = ray_hit_xy(terrain, (0.0, 0.1, 0.03), (1.0, 0.0, -0.01))
    assert hit == pytest.approx((0.25, 0.1), abs=1e-6)
    assert float(terrain.height_at(hit)) == pytest.approx(0.05)  # the stone whose wall it is


def test_one_height_lands_on_the_plane_as_before():
    for terrain in (flat(), stepping_stones()):
        origin, direction = ray_at([0.37, 0.12, 0.0])
        assert ray_hit_xy(terrain, origin, direction) == ray_to_plane(origin, direction, 0.0)
    assert ray_hit_xy(flat(), (0.0, 0.0, 1.0), (0.0, 0.0, 1.0)) is None  # looking up


def test_com_lines_follow_the_tops():
    path = np.array([[0.0, 0.0, 0.3], [0.35, 0.0, 0.32], [0.85, 0.0, 0.45], [3.0, 0.0, 0.3]])
    flat_lines = _on_ground(path, stepping_stones(), 0.004)
    np.testing.assert_array_equal(flat_lines[:, 2], np.float32(0.004))  # flat terrains: as before
    np.testing.assert_array_equal(flat_lines[:, :2], path[:, :2].astype(np.float32))
    on_stairs = _on_ground(path, stairs(), 0.004)
    np.testing.assert_allclose(on_stairs[:, 2], [0.004, 0.054, 0.154, 0.004], atol=1e-6)  # off the terrain: surface
    assert _on_ground(np.zeros((0, 3)), stairs(), 0.004).shape == (0, 3)


def test_the_goal_line_is_drawn_at_the_highest_top_it_crosses():
    assert goal_line_z(stepping_stones()) == 0.0
    assert goal_line_z(stairs()) == 0.0  # the goal lies on the last platform
    data = stairs().to_dict()
    data["goal_x"] = 0.85  # on the landing at +15 cm
    assert goal_line_z(Terrain.from_dict(data)) == pytest.approx(0.15)
    data = raised_stones().to_dict()
    data["goal_x"] = 1.08  # across the rect at +6 cm and the star at -4.3 cm
    assert goal_line_z(Terrain.from_dict(data)) == pytest.approx(0.06)
