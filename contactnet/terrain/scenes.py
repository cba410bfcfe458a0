"""The paper's scenes as terrain generators, the shipped terrain files and name resolution.

Generators: :func:`flat`, :func:`random_field` (experiment 3), :func:`stepping_stones` (experiment 1),
:func:`narrow_stones` (experiment 2) and :func:`push_field` (experiment 5). Each scene's geometry
(platforms, stones, fields) is written here in metres; none depends on a robot. :data:`SHIPPED`
names the files in ``terrains/``; ``python -m contactnet.terrain`` (:func:`main`) rewrites them.
"""

from __future__ import annotations

import argparse
import numbers
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from contactnet.terrain.geometry import Terrain
from contactnet.terrain.schema import TerrainError, is_number, show


def _rect(center_xy: Sequence[float], size_xy: Sequence[float], yaw: float = 0.0) -> dict[str, Any]:
    return {"shape": "rect", "center": [float(v) for v in center_xy], "size": [float(v) for v in size_xy],
            "yaw": float(yaw)}


def _circle(center_xy: Sequence[float], radius: float) -> dict[str, Any]:
    return {"shape": "circle", "center": [float(v) for v in center_xy], "radius": float(radius)}


def _star(center_xy: Sequence[float], outer: float, inner: float, points: int, yaw: float = 0.0) -> dict[str, Any]:
    return {"shape": "star", "center": [float(v) for v in center_xy], "outer_radius": float(outer),
            "inner_radius": float(inner), "points": int(points), "yaw": float(yaw)}


def flat(size: tuple[float, float] = (20.0, 20.0)) -> Terrain:
    """One big rectangle centred on the start (0, 0); goal_x = 8 m (or 0.5 m before the far edge)."""
    size_x, size_y = (float(v) for v in size)
    if not (size_x >= 1.2 and size_y >= 0.6):
        raise TerrainError(f"flat: size must be at least (1.2, 0.6) m to hold the robot, got {show(list(size))}")
    return Terrain(name="flat", start_xy=(0.0, 0.0), goal_x=min(8.0, 0.5 * size_x - 0.5),
                   regions=[_rect((0.0, 0.0), (size_x, size_y))],
                   description=f"flat ground, {size_x:g} x {size_y:g} m")


RANDOM_FIELD_CELL_M = 0.05
RANDOM_FIELD_COLS = 30
RANDOM_FIELD_ROWS = 10
RANDOM_FIELD_PLATFORM_M = 0.5


def random_field(removed: int, seed: int) -> Terrain:
    """The paper's random field (experiment 3): 30 x 10 squares of 5 cm with ``removed`` squares missing.

    Layout along x: a solid 0.5 x 0.5 m start platform centred on the start (0, 0), the 1.5 x 0.5 m
    field from x = 0.25 to 1.75 m, then a solid 0.5 x 0.5 m end platform. ``goal_x`` = 1.75 m: the
    base has crossed the whole field. The removed cells are ``default_rng(seed).choice(300, removed)``.
    """
    n_cells = RANDOM_FIELD_COLS * RANDOM_FIELD_ROWS
    if not is_number(removed) or not isinstance(removed, numbers.Integral) or not 0 <= removed <= n_cells:
        raise TerrainError(f"random_field: removed must be an integer in 0..{n_cells}, got {show(removed)}")
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool) or seed < 0:
        raise TerrainError(f"random_field: seed must be a non-negative integer, got {show(seed)}")
    cell, platform = RANDOM_FIELD_CELL_M, RANDOM_FIELD_PLATFORM_M
    width_y = RANDOM_FIELD_ROWS * cell
    field_x0 = 0.5 * platform
    field_x1 = field_x0 + RANDOM_FIELD_COLS * cell
    flat_index = np.random.default_rng(int(seed)).choice(n_cells, size=int(removed), replace=False)
    removed_cells = [[int(i % RANDOM_FIELD_COLS), int(i // RANDOM_FIELD_COLS)] for i in flat_index]
    regions = [
        _rect((0.0, 0.0), (platform, width_y)),
        {"shape": "grid", "origin": [field_x0, -0.5 * width_y], "cell": cell, "cols": RANDOM_FIELD_COLS,
         "rows": RANDOM_FIELD_ROWS, "removed": removed_cells},
        _rect((field_x1 + 0.5 * platform, 0.0), (platform, width_y)),
    ]
    return Terrain(name=f"random_{int(removed)}_{int(seed)}", start_xy=(0.0, 0.0), goal_x=field_x1,
                   regions=regions,
                   description=f"paper field: 300 squares of 5 x 5 cm, {int(removed)} removed (seed {int(seed)})")


def stepping_stones() -> Terrain:
    """The paper's Fig. 2 scene: start square, 8 stones (3 stars, 2 circles, 3 rectangles), end square.

    The stones sit irregularly in a left lane (y ~ +0.12 m), a right lane (y ~ -0.12 m) and the
    middle, ~1 m along x; holes between consecutive stones of a lane are at most ~7 cm wide, so each
    leg's 5 x 5 candidate grid (5 cm spacing around its hip) always contains safe footholds.
    """
    stones = [
        _circle((0.37, 0.12), 0.085),
        _rect((0.39, -0.13), (0.17, 0.16), yaw=0.12),
        _rect((0.585, 0.145), (0.14, 0.12), yaw=-0.2),
        _star((0.62, -0.095), 0.15, 0.08, 5, yaw=0.3),
        _star((0.80, 0.10), 0.12, 0.07, 6, yaw=0.1),
        _circle((0.87, -0.14), 0.095),
        _star((1.065, 0.125), 0.13, 0.07, 5, yaw=-0.25),
        _rect((1.08, -0.12), (0.16, 0.18), yaw=0.3),
    ]
    end_x0 = 1.25
    regions = [_rect((0.0, 0.0), (0.5, 0.5)), *stones, _rect((end_x0 + 0.25, 0.0), (0.5, 0.5))]
    return Terrain(name="stepping_stones", start_xy=(0.0, 0.0), goal_x=end_x0 + 0.15, regions=regions,
                   description="paper Fig. 2: 8 stepping stones (3 stars, 2 circles, 3 rectangles)")


def narrow_stones(bar_width_m: float | None = None, last_gap_m: float | None = None) -> Terrain:
    """The paper's Fig. 6 scene: start square, 3 narrow bars across the path, end square.

    The paper gives no dimensions, only "narrow", "different sizes", "unevenly spaced" and "the last
    stepping stone farthest from the previous". Ours: bars 4.5, 4 and 5 cm wide along x and 42, 50 and
    38 cm long along y, behind gaps of 7, 9 and 18 cm, then a 9 cm gap to the end square. "Narrow" is
    measured against the candidate grid: a bar narrower than the 5 cm candidate spacing plus twice the
    planner's 8 mm edge margin (6.6 cm) has, for part of the hip positions, no candidate of a given leg
    on it, so a leg whose turn it is may have no safe option, which is the situation the paper's Fig. 6
    is about. The acyclic ContactNet crosses it and the fixed cyclic gait falls; the map of bar width x
    last gap (`contactnet experiment narrow_map`, README) shows this is not a knife edge.

    ``bar_width_m`` makes all three bars that wide and ``last_gap_m`` sets the gap before the last bar
    (the map's two axes); the terrain is then named ``narrow_stones_w<cm>_g<cm>`` (the parts given).
    """
    widths = (0.045, 0.04, 0.05)
    gaps = [0.07, 0.09, 0.18]
    name = "narrow_stones"
    for label, value, low, high in (("bar_width_m", bar_width_m, 0.01, 0.2), ("last_gap_m", last_gap_m, 0.0, 0.4)):
        if value is not None and (not isinstance(value, numbers.Real) or isinstance(value, bool)
                                  or not low <= float(value) <= high):
            raise TerrainError(f"narrow_stones: {label} must be a number in [{low}, {high}] m, got {show(value)}")
    if bar_width_m is not None:
        widths = (float(bar_width_m),) * 3
        name += f"_w{100 * widths[0]:g}"
    if last_gap_m is not None:
        gaps[2] = float(last_gap_m)
        name += f"_g{100 * gaps[2]:g}"
    lengths_y, centers_y = (0.42, 0.50, 0.38), (0.01, -0.01, 0.0)
    start_x1 = 0.25
    regions = [_rect((0.0, 0.0), (0.5, 0.5))]
    x = start_x1
    for gap, width, length, center_y in zip(gaps, widths, lengths_y, centers_y, strict=True):
        x += gap
        regions.append(_rect((round(x + 0.5 * width, 6), center_y), (width, length)))
        x += width
    end_x0 = round(x + 0.09, 6)
    regions.append(_rect((end_x0 + 0.25, 0.0), (0.5, 0.5)))
    return Terrain(name=name, start_xy=(0.0, 0.0), goal_x=end_x0 + 0.15, regions=regions,
                   description="paper Fig. 6: 3 narrow bars (narrower than the 5 cm candidate spacing), "
                               "unevenly spaced, the last gap the widest")


def push_field(seed: int = 0) -> Terrain:
    """Flat 4 x 2 m ground with random 10 x 10 cm holes (~15 % of the area) for the push experiment.

    No hole within the 0.6 x 0.6 m square around the start (0, 0); goal_x = 3 m.
    """
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool) or seed < 0:
        raise TerrainError(f"push_field: seed must be a non-negative integer, got {show(seed)}")
    cell, cols, rows, origin_xy = 0.1, 40, 20, (-0.5, -1.0)
    col_index, row_index = np.meshgrid(np.arange(cols), np.arange(rows))
    cell_x0 = origin_xy[0] + cell * col_index
    cell_y0 = origin_xy[1] + cell * row_index
    keep_clear = (cell_x0 + cell > -0.3 + 1e-9) & (cell_x0 < 0.3 - 1e-9) & (cell_y0 + cell > -0.3 + 1e-9) & (
        cell_y0 < 0.3 - 1e-9)
    eligible = np.flatnonzero(~keep_clear.ravel())
    n_holes = round(0.15 * cols * rows)
    chosen = np.sort(np.random.default_rng(int(seed)).choice(eligible, size=n_holes, replace=False))
    removed = [[int(i % cols), int(i // cols)] for i in chosen]
    grid = {"shape": "grid", "origin": list(origin_xy), "cell": cell, "cols": cols, "rows": rows, "removed": removed}
    name = "push_field" if seed == 0 else f"push_field_{int(seed)}"
    return Terrain(name=name, start_xy=(0.0, 0.0), goal_x=3.0, regions=[grid],
                   description=f"4 x 2 m ground with {n_holes} random 10 x 10 cm holes (seed {int(seed)})")


_GENERATORS: Mapping[str, Callable[..., Terrain]] = MappingProxyType({
    "flat": flat, "narrow_stones": narrow_stones, "push_field": push_field, "stepping_stones": stepping_stones,
})


def by_name(name: str, removed: int | None = None, seed: int = 0) -> Terrain:
    """Generator by name: 'flat', 'random' (needs ``removed``), 'stepping_stones', 'narrow_stones', 'push_field'."""
    if name == "random":
        if removed is None:
            raise TerrainError("random: the random field needs 'removed' (number of squares to remove, 0..300)")
        return random_field(removed, seed)
    if name == "push_field":
        return push_field(seed)
    if name in _GENERATORS:
        return _GENERATORS[name]()
    raise TerrainError(f"unknown terrain generator {show(name)}; expected one of: random, {', '.join(_GENERATORS)}")


def terrains_dir() -> Path:
    """Directory of the shipped terrain files: $CONTACTNET_TERRAINS, else <repo>/terrains."""
    override = os.environ.get("CONTACTNET_TERRAINS")
    return Path(override) if override else Path(__file__).resolve().parents[2] / "terrains"


def available() -> list[str]:
    """Sorted stems of the terrain files in :func:`terrains_dir`."""
    directory = terrains_dir()
    return sorted(p.stem for p in directory.glob("*.json")) if directory.is_dir() else []


def resolve(name_or_path: str | os.PathLike[str], removed: int | None = None, seed: int = 0) -> Terrain:
    """Terrain from a CLI argument: a .json path, 'random' (with ``removed``/``seed``), or a shipped name.

    Order: an existing file or a name ending in .json is loaded; 'random' builds the random field
    (and 'push_field' with a non-zero ``seed`` builds that field); ``<terrains_dir>/<name>.json`` is
    loaded; a generator name ('flat', ...) is generated; anything else raises TerrainError listing
    the available names.
    """
    text = os.fspath(name_or_path)
    if text.endswith(".json") or Path(text).is_file():
        return Terrain.load(text)
    if text == "random" or (text == "push_field" and seed != 0):
        return by_name(text, removed=removed, seed=seed)
    shipped = terrains_dir() / f"{text}.json"
    if shipped.is_file():
        return Terrain.load(shipped)
    if text in _GENERATORS:
        return by_name(text, seed=seed)
    names = sorted({*available(), *_GENERATORS, "random"})
    raise TerrainError(f"unknown terrain {show(text)}: expected a .json path or one of: {', '.join(names)}")


SHIPPED: Mapping[str, Callable[[], Terrain]] = MappingProxyType({
    "flat": flat,
    "stepping_stones": stepping_stones,
    "narrow_stones": narrow_stones,
    "push_field": push_field,
    "random_80_0": lambda: random_field(80, 0),
})
"""File stem -> generator of the terrain files shipped in terrains/."""


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m contactnet.terrain [--out DIR]``: regenerate the shipped terrain files."""
    parser = argparse.ArgumentParser(prog="python -m contactnet.terrain", description=main.__doc__)
    parser.add_argument("--out", type=Path, default=None, help="output directory (default: terrains_dir())")
    args = parser.parse_args(argv)
    out_dir = args.out or terrains_dir()
    out_dir.mkdir(parents=True, exist_ok=True)
    for stem, generate in SHIPPED.items():
        terrain = generate()
        terrain.save(out_dir / f"{stem}.json")
        print(f"wrote {out_dir / f'{stem}.json'}  ({terrain.steppable.area:.3f} m^2 steppable)")
    return 0
