"""Terrain import keeps sloped planar patches as sloped tops (issue 30, items 1 and 2).

The round trip: the ``ramps`` terrain rasterised (the plain point-by-point rasteriser of test_terrain_import) or
meshed (``Terrain.mesh``, as ``terrain render``'s 3-D view and the simulators use it) and imported back gives the
same steppable area within a cell and the same slopes within a degree; a patch steeper than the steppable limit
(``geometry.MAX_SAFE_SLOPE_RAD``) is dropped as too steep; flat maps give flat regions without slope keys.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from test_terrain_import import rasterise

from contactnet.terrain import import_terrain, resolve
from contactnet.terrain.geometry import MAX_SAFE_SLOPE_RAD


def same_slopes(original, imported, resolution_m: float) -> None:  # noqa: ANN001
    """Area within a cell; away from the edges (2 cells in), slopes within 1 degree and heights within 1 mm."""
    difference = original.steppable.symmetric_difference(imported.steppable).area
    assert difference <= original.steppable.length * resolution_m, (difference, original.steppable.length)
    x0, y0, x1, y1 = original.bounds
    points = np.random.default_rng(0).uniform([x0, y0], [x1, y1], size=(5000, 2))
    inner = points[shapely.contains_xy(original.steppable.buffer(-2 * resolution_m), *points.T)]
    slope = [np.degrees(np.arctan(np.hypot(*t.gradient_at(inner).T))) for t in (original, imported)]
    assert np.abs(slope[1] - slope[0]).max() <= 1.0
    sloped = slope[0] > 1.0
    assert sloped.sum() > 500  # the test sees the ramps
    direction = [np.degrees(np.arctan2(*t.gradient_at(inner[sloped])[:, ::-1].T)) for t in (original, imported)]
    turned = (direction[1] - direction[0] + 180.0) % 360.0 - 180.0
    assert np.abs(turned).max() <= 1.0
    np.testing.assert_allclose(imported.height_at(inner), original.height_at(inner), atol=1e-3)


def sloped_regions(terrain) -> list[dict]:  # noqa: ANN001
    return [r for r in terrain.to_dict()["regions"] if "slope_deg" in r]


def test_the_ramps_rasterised_import_back_as_sloped_tops(tmp_path):
    original = resolve("ramps")
    heights, origin = rasterise(original, 0.01)
    np.save(tmp_path / "ramps.npy", heights)
    imported, report = import_terrain(tmp_path / "ramps.npy", resolution_m=0.01, origin_xy=origin)
    same_slopes(original, imported, 0.01)
    assert report.sloped == 5 and report.dropped == ()  # 10 and 15 degrees up and down, 10 across
    assert "(5 sloped)" in report.lines()[0]
    for region in sloped_regions(imported):  # z is the plane's height at the polygon's centroid
        centroid = shapely.Polygon(region["vertices"]).centroid
        assert imported.height_at(np.array([[centroid.x, centroid.y]]))[0] == pytest.approx(region["z"], abs=1e-6)
    assert sorted(round(r["slope_deg"], 3) for r in sloped_regions(imported)) == [10, 10, 10, 15, 15]
    assert imported.is_safe(np.array([[0.4, 0.0], [1.8, 0.0], [3.05, 0.1]])).all()  # on the ramps


def test_the_ramps_meshed_import_back_as_sloped_tops(tmp_path):
    import trimesh

    original = resolve("ramps")
    mesh = original.mesh(thickness=0.05)
    path = tmp_path / "ramps.stl"
    trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces)).export(path)
    imported, report = import_terrain(path, resolution_m=0.005)
    same_slopes(original, imported, 0.005)
    assert report.sloped == 5
    np.testing.assert_allclose(imported.start_xy, original.start_xy, atol=0.005)


def gentle_and_steep(slope_deg: float) -> np.ndarray:
    """1 cm cells: flat ground, a 40 cm ramp of ``slope_deg`` up along x, a flat landing at its top."""
    heights = np.zeros((50, 160))
    rise = 0.01 * math.tan(math.radians(slope_deg))
    heights[:, 60:100] = rise * (np.arange(40) + 0.5)
    heights[:, 100:] = rise * 40
    return heights


@pytest.mark.parametrize("slope_deg", [5.0, 20.0])
def test_a_ramp_no_steeper_than_the_limit_is_kept_with_its_plane(tmp_path, slope_deg):
    np.save(tmp_path / "ramp.npy", gentle_and_steep(slope_deg))
    terrain, report = import_terrain(tmp_path / "ramp.npy", resolution_m=0.01)
    (region,) = sloped_regions(terrain)
    assert region["slope_deg"] == pytest.approx(slope_deg, abs=1e-6) and region["slope_dir_deg"] == 0.0
    assert report.tops == 3 and report.sloped == 1 and report.dropped == ()
    assert shapely.Polygon(region["vertices"]).area == pytest.approx(0.4 * 0.5)
    assert terrain.is_safe(np.array([[0.8, 0.25]]))[0]


def test_a_ramp_steeper_than_the_limit_is_dropped_as_too_steep(tmp_path):
    assert math.degrees(MAX_SAFE_SLOPE_RAD) == pytest.approx(21.8, abs=0.01)
    np.save(tmp_path / "ramp.npy", gentle_and_steep(24.0))
    terrain, report = import_terrain(tmp_path / "ramp.npy", resolution_m=0.01, start_xy=(0.2, 0.25), goal_x=1.4)
    assert sloped_regions(terrain) == [] and report.sloped == 0
    assert any("too steep, sloped 24.0 degrees (> 21.8" in line for line in report.dropped), report.dropped
    assert not terrain.is_safe(np.array([[0.8, 0.25]]))[0]


def test_a_millimetre_png_ramp_is_kept_within_a_degree(tmp_path):
    from PIL import Image

    millimetres = np.round(gentle_and_steep(10.0) * 1000).astype(np.uint16)
    Image.fromarray(millimetres).save(tmp_path / "ramp.png")
    terrain, report = import_terrain(tmp_path / "ramp.png", resolution_m=0.01, z_scale=0.001)
    (region,) = sloped_regions(terrain)
    assert region["slope_deg"] == pytest.approx(10.0, abs=1.0) and report.sloped == 1


def test_flat_tops_stay_flat_regions_without_slope_keys(tmp_path):
    original = resolve("stairs")
    heights, origin = rasterise(original, 0.01)
    np.save(tmp_path / "stairs.npy", heights)
    imported, report = import_terrain(tmp_path / "stairs.npy", resolution_m=0.01, origin_xy=origin)
    assert sloped_regions(imported) == [] and report.sloped == 0 and "sloped" not in report.lines()[0]


def test_terrain_import_on_the_command_line_says_how_many_tops_are_sloped(tmp_path):
    import json
    import subprocess
    import sys
    from pathlib import Path

    np.save(tmp_path / "ramp.npy", gentle_and_steep(10.0))
    out = tmp_path / "ramp.json"
    result = subprocess.run([sys.executable, "-m", "contactnet", "terrain", "import", str(tmp_path / "ramp.npy"),
                             "--out", str(out), "--max-roughness", "0.001"],
                            capture_output=True, text=True, cwd=Path(__file__).resolve().parents[1], timeout=300)
    assert result.returncode == 0, result.stderr
    assert "3 top(s) (1 sloped)" in result.stdout
    (region,) = [r for r in json.loads(out.read_text())["regions"] if "slope_deg" in r]
    assert region["slope_deg"] == pytest.approx(10.0)
