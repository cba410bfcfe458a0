"""The paper's scenes as terrain generators, the shipped terrain files and name resolution.

Generators: `flat`, `random_field` (experiment 3), `stepping_stones` (experiment 1),
`narrow_stones` (experiment 2) and `push_field` (experiment 5); beyond the paper, with
tops at several heights: `stairs`, `raised_stones` and `random_heights`; with sloped tops: `ramps`. Each
scene's geometry (platforms, stones, fields, heights) is written here in metres; none depends on a
robot. :data:`SHIPPED`
names the files in ``terrains/``; ``python -m contactnet.terrain`` (`main`) rewrites them.
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
from contactnet.terrain.schema import MAX_HEIGHT_OFFSET_M, TerrainError, finite_float, is_number, show


def _rect(center_xy: Sequence[float], size_xy: Sequence[float], yaw: float = 0.0,
          z: float | None = None) -> dict[str, Any]:
    rect = {"shape": "rect", "center": [float(v) for v in center_xy], "size": [float(v) for v in size_xy],
            "yaw": float(yaw)}
    return rect if z is None else {**rect, "z": float(z)}


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
    flat_index, _ = _random_field_cells("random_field", removed, seed)
    cell, platform = RANDOM_FIELD_CELL_M, RANDOM_FIELD_PLATFORM_M
    width_y = RANDOM_FIELD_ROWS * cell
    field_x0 = 0.5 * platform
    field_x1 = field_x0 + RANDOM_FIELD_COLS * cell
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


def _random_field_cells(what: str, removed: Any, seed: Any) -> tuple[np.ndarray, np.random.Generator]:
    """(the removed squares' flat indices ``default_rng(seed).choice(300, removed)``, that generator after it)."""
    n_cells = RANDOM_FIELD_COLS * RANDOM_FIELD_ROWS
    if not is_number(removed) or not isinstance(removed, numbers.Integral) or not 0 <= removed <= n_cells:
        raise TerrainError(f"{what}: removed must be an integer in 0..{n_cells}, got {show(removed)}")
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool) or seed < 0:
        raise TerrainError(f"{what}: seed must be a non-negative integer, got {show(seed)}")
    rng = np.random.default_rng(int(seed))
    return rng.choice(n_cells, size=int(removed), replace=False), rng


RANDOM_HEIGHTS_DEFAULT_M = 0.03


def random_heights(removed: int, seed: int, height_m: float = RANDOM_HEIGHTS_DEFAULT_M) -> Terrain:
    """The paper's random field with heights: the squares of `random_field` (the same ``removed`` ones
    missing for the same ``seed``), each remaining square's top at a random height within +-``height_m``.

    The heights are ``uniform(-height_m, height_m)`` from the same generator, drawn after the removed
    squares, rounded to the millimetre (and kept within +-``height_m``); the platforms stay at 0. Each
    square is a 5 x 5 cm ``rect`` region with its ``z``. Named ``random_heights_<removed>_<seed>``, with
    ``_h<cm>`` appended when ``height_m`` is not the default 3 cm.
    """
    flat_index, rng = _random_field_cells("random_heights", removed, seed)
    height = finite_float(height_m)
    if height is None or not 0.0 <= height <= MAX_HEIGHT_OFFSET_M:
        raise TerrainError(f"random_heights: height_m must be a number in [0, {MAX_HEIGHT_OFFSET_M:g}] m, "
                           f"got {show(height_m)}")
    kept = np.setdiff1d(np.arange(RANDOM_FIELD_COLS * RANDOM_FIELD_ROWS), flat_index)
    tops_z = np.clip(np.round(rng.uniform(-height, height, len(kept)), 3), -height, height)
    cell, platform = RANDOM_FIELD_CELL_M, RANDOM_FIELD_PLATFORM_M
    width_y = RANDOM_FIELD_ROWS * cell
    field_x0 = 0.5 * platform
    field_x1 = field_x0 + RANDOM_FIELD_COLS * cell
    col, row = kept % RANDOM_FIELD_COLS, kept // RANDOM_FIELD_COLS
    squares = [_rect((round(field_x0 + (c + 0.5) * cell, 9), round(-0.5 * width_y + (r + 0.5) * cell, 9)),
                     (cell, cell), z=float(z) + 0.0)  # + 0.0: no -0.0 in the file
               for c, r, z in zip(col.tolist(), row.tolist(), tops_z.tolist(), strict=True)]
    regions = [_rect((0.0, 0.0), (platform, width_y)), *squares,
               _rect((field_x1 + 0.5 * platform, 0.0), (platform, width_y))]
    name = f"random_heights_{int(removed)}_{int(seed)}"
    if height != RANDOM_HEIGHTS_DEFAULT_M:
        name += f"_h{100 * height:g}"
    return Terrain(name=name, start_xy=(0.0, 0.0), goal_x=field_x1, regions=regions,
                   description=f"paper field with heights: 300 squares of 5 x 5 cm, {int(removed)} removed "
                               f"(seed {int(seed)}), tops within +-{100 * height:g} cm")


def stepping_stones() -> Terrain:
    """The paper's Fig. 2 scene: start square, 8 stones (3 stars, 2 circles, 3 rectangles), end square.

    The stones sit irregularly in a left lane (y ~ +0.12 m), a right lane (y ~ -0.12 m) and the
    middle, ~1 m along x; holes between consecutive stones of a lane are at most ~7 cm wide, so each
    leg's 5 x 5 candidate grid (5 cm spacing around its hip) always contains safe footholds.
    """
    end_x0 = 1.25
    regions = [_rect((0.0, 0.0), (0.5, 0.5)), *_stones(), _rect((end_x0 + 0.25, 0.0), (0.5, 0.5))]
    return Terrain(name="stepping_stones", start_xy=(0.0, 0.0), goal_x=end_x0 + 0.15, regions=regions,
                   description="paper Fig. 2: 8 stepping stones (3 stars, 2 circles, 3 rectangles)")


def _stones() -> list[dict[str, Any]]:
    """The 8 stones of `stepping_stones` (and `raised_stones`)."""
    return [
        _circle((0.37, 0.12), 0.085),
        _rect((0.39, -0.13), (0.17, 0.16), yaw=0.12),
        _rect((0.585, 0.145), (0.14, 0.12), yaw=-0.2),
        _star((0.62, -0.095), 0.15, 0.08, 5, yaw=0.3),
        _star((0.80, 0.10), 0.12, 0.07, 6, yaw=0.1),
        _circle((0.87, -0.14), 0.095),
        _star((1.065, 0.125), 0.13, 0.07, 5, yaw=-0.25),
        _rect((1.08, -0.12), (0.16, 0.18), yaw=0.3),
    ]


RAISED_STONES_SPREAD_M = 0.06


def raised_stones(seed: int = 0, spread_m: float = RAISED_STONES_SPREAD_M) -> Terrain:
    """The stepping stones (`stepping_stones`) with their tops spread over +-``spread_m`` (default 6 cm).

    The 8 tops are evenly spaced from ``-spread_m`` to ``+spread_m`` (rounded to the millimetre), so the
    spread is always the full range, and shuffled by ``default_rng(seed)``; the platforms stay at 0.
    Named ``raised_stones``, or ``raised_stones_<seed>`` for another seed.
    """
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool) or seed < 0:
        raise TerrainError(f"raised_stones: seed must be a non-negative integer, got {show(seed)}")
    spread = finite_float(spread_m)
    if spread is None or not 0.0 <= spread <= MAX_HEIGHT_OFFSET_M:
        raise TerrainError(f"raised_stones: spread_m must be a number in [0, {MAX_HEIGHT_OFFSET_M:g}] m, "
                           f"got {show(spread_m)}")
    tops_z = np.random.default_rng(int(seed)).permutation(np.round(np.linspace(-spread, spread, 8), 3))
    base = stepping_stones().to_dict()
    stones = [{**stone, "z": float(z) + 0.0} for stone, z in zip(_stones(), tops_z.tolist(), strict=True)]
    regions = [base["regions"][0], *stones, base["regions"][-1]]
    return Terrain(name="raised_stones" if seed == 0 else f"raised_stones_{int(seed)}", start_xy=base["start"],
                   goal_x=base["goal_x"], regions=regions,
                   description=f"the 8 stepping stones of paper Fig. 2 with tops from {-100 * spread:g} to "
                               f"+{100 * spread:g} cm (seed {int(seed)})")


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


STAIRS_RISER_M = 0.05
STAIRS_TREAD_M = 0.20


def stairs(riser_m: float = STAIRS_RISER_M, tread_m: float = STAIRS_TREAD_M, steps: int = 3,
           top_m: float = 0.4) -> Terrain:
    """Stairs up, then down: a flat start platform, ``steps`` risers up, a top landing, ``steps`` down, a flat
    landing at the goal.

    Along x: the 0.5 x 0.5 m start platform at z = 0 centred on the start (0, 0); ``steps - 1`` treads
    ``tread_m`` deep (20 cm) at z = riser, 2 risers, ...; the top landing ``top_m`` deep (40 cm, room
    for the whole robot) at ``steps`` risers (15 cm by default); the same treads down; the 0.5 m
    landing at z = 0, ``goal_x`` 15 cm into it. Every riser is ``riser_m`` (5 cm). 0.5 m wide, each
    tread a ``rect`` with its ``z``, abutting its neighbours.
    """
    checks = (("riser_m", riser_m, 0.005, MAX_HEIGHT_OFFSET_M), ("tread_m", tread_m, 0.05, 2.0),
              ("top_m", top_m, 0.05, 5.0))
    for label, value, low, high in checks:
        number = finite_float(value)
        if number is None or not low <= number <= high:
            raise TerrainError(f"stairs: {label} must be a number in [{low:g}, {high:g}] m, got {show(value)}")
    if not isinstance(steps, numbers.Integral) or isinstance(steps, bool) or not 1 <= steps <= 20:
        raise TerrainError(f"stairs: steps must be an integer in 1..20, got {show(steps)}")
    riser, tread, top = float(riser_m), float(tread_m), float(top_m)
    if steps * riser > MAX_HEIGHT_OFFSET_M + 1e-12:
        raise TerrainError(f"stairs: the top ({steps} x {riser:g} m) must be at most {MAX_HEIGHT_OFFSET_M:g} m high")
    width_y, platform = 0.5, 0.5
    depths = [tread] * (steps - 1) + [top] + [tread] * (steps - 1)
    levels = [*range(1, steps), steps, *range(steps - 1, 0, -1)]
    regions = [_rect((0.0, 0.0), (platform, width_y))]
    x = 0.5 * platform
    for depth, level in zip(depths, levels, strict=True):
        regions.append(_rect((round(x + 0.5 * depth, 9), 0.0), (depth, width_y), z=round(level * riser, 9)))
        x = round(x + depth, 9)
    regions.append(_rect((round(x + 0.5 * platform, 9), 0.0), (platform, width_y)))
    name = "stairs" + "".join(f"_{label}{value:g}" for label, value, default in (
        ("r", 100 * riser, 100 * STAIRS_RISER_M), ("t", 100 * tread, 100 * STAIRS_TREAD_M), ("s", steps, 3),
        ("top", 100 * top, 40.0)) if value != default)  # the parts that differ from the shipped stairs, in cm
    return Terrain(name=name, start_xy=(0.0, 0.0), goal_x=round(x + 0.15, 9), regions=regions,
                   description=f"stairs: {int(steps)} risers of {100 * riser:g} cm up and down, treads "
                               f"{100 * tread:g} cm, top landing {100 * top:g} cm")


RAMPS_SLOPES_DEG = (10.0, 15.0)
"""The ramps crossed up then down, in order (degrees)."""
RAMPS_ACROSS_DEG = (10.0,)
"""The ramps crossed with their slope across the walking direction (rising toward +y), in order (degrees)."""


def ramps(slopes_deg: Sequence[float] = RAMPS_SLOPES_DEG, across_deg: Sequence[float] = RAMPS_ACROSS_DEG,
          run_m: float = 0.3, landing_m: float = 0.4, width_m: float = 0.5) -> Terrain:
    """Ramps: up, a landing, down, for each slope of ``slopes_deg``, then for each of ``across_deg`` a stretch
    sloped across the walking direction, each followed by flat ground.

    Along x: the 0.5 x ``width_m`` start platform at z = 0 centred on the start (0, 0); for each slope a ramp
    rising along +x over a horizontal run of ``run_m`` (30 cm: 5.3 cm up at 10 degrees, 8.0 cm at 15), the landing
    ``landing_m`` deep (40 cm, room for the whole robot) at the ramp's top, the same ramp down, and ``landing_m``
    of flat ground at z = 0; for each slope across, a stretch 2 x ``run_m`` long rising toward +y (z = 0 on its
    centre line, so its ends meet the flat ground with a riser of up to ``width_m`` / 2 x tan(slope): 2.6 cm at
    the feet of a Solo12 at 10 degrees), then ``landing_m`` flat; the 0.5 m end platform, ``goal_x`` 15 cm into it.
    Every piece is a ``rect`` abutting its neighbours, the ramps with ``slope_deg`` and ``slope_dir_deg``.
    """
    checks = (("run_m", run_m, 0.05, 5.0), ("landing_m", landing_m, 0.05, 5.0), ("width_m", width_m, 0.1, 5.0))
    for label, value, low, high in checks:
        number = finite_float(value)
        if number is None or not low <= number <= high:
            raise TerrainError(f"ramps: {label} must be a number in [{low:g}, {high:g}] m, got {show(value)}")
    for label, values in (("slopes_deg", slopes_deg), ("across_deg", across_deg)):
        if not isinstance(values, Sequence) or len(values) > 10 or not all(
                (finite_float(v) is not None and 0.0 < float(v) <= 45.0) for v in values):
            raise TerrainError(f"ramps: {label} must be at most 10 slopes in (0, 45] degrees, got {show(values)}")
    run, landing, width = float(run_m), float(landing_m), float(width_m)
    platform = 0.5
    regions = [_rect((0.0, 0.0), (platform, width))]
    x = 0.5 * platform

    def piece(depth: float, z: float = 0.0, slope: float = 0.0, direction: float = 0.0) -> None:
        nonlocal x
        region = _rect((round(x + 0.5 * depth, 9), 0.0), (depth, width), z=round(z, 9) if z or slope else None)
        if slope:
            region.update(slope_deg=float(slope), slope_dir_deg=float(direction))
        regions.append(region)
        x = round(x + depth, 9)

    for slope in slopes_deg:
        rise = run * np.tan(np.radians(float(slope)))
        piece(run, 0.5 * rise, float(slope), 0.0)
        piece(landing, rise)
        piece(run, 0.5 * rise, float(slope), 180.0)
        piece(landing)
    for slope in across_deg:
        piece(2.0 * run, 0.0, float(slope), 90.0)
        piece(landing)
    regions.pop()  # the last flat stretch becomes the end platform
    x = round(x - landing, 9)
    piece(platform)
    defaults = tuple(slopes_deg) == RAMPS_SLOPES_DEG and tuple(across_deg) == RAMPS_ACROSS_DEG and (
        run, landing, width) == (0.3, 0.4, 0.5)
    name = "ramps" if defaults else "ramps" + "".join(f"_u{float(v):g}" for v in slopes_deg) + "".join(
        f"_a{float(v):g}" for v in across_deg) + ("" if (run, landing, width) == (0.3, 0.4, 0.5) else
                                                   f"_r{100 * run:g}_l{100 * landing:g}_w{100 * width:g}")
    parts = [f"{float(v):g} degrees up and down" for v in slopes_deg] + [f"{float(v):g} degrees across"
                                                                         for v in across_deg]
    return Terrain(name=name, start_xy=(0.0, 0.0), goal_x=round(x - platform + 0.15, 9), regions=regions,
                   description=f"ramps: {', '.join(parts) or 'none'}; runs of {100 * run:g} cm, landings "
                               f"{100 * landing:g} cm, {100 * width:g} cm wide")


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


#: The smallest stepping stones an open Go2 contact planner is shown on (esfal: square stones of about 11 cm at a
#: pitch of 19 cm along x and 14.7 cm across), m.
STONE_GRID_SIDE_M = 0.11
STONE_GRID_PITCH_XY_M = (0.19, 0.147)


def stone_grid(side_m: float = STONE_GRID_SIDE_M, pitch_xy_m: Sequence[float] = STONE_GRID_PITCH_XY_M,
               columns: int = 8, rows: int = 5) -> Terrain:
    """A grid of square stones between a start and an end square: ``columns`` x ``rows`` stones of ``side_m``, their
    centres ``pitch_xy_m`` apart, the rows centred on y = 0 (with 5 rows at 0, +-14.7 and +-29.4 cm, under the
    feet of Go2 and Solo12, about 14 cm to each side). Gaps of 8 cm along x and 3.7 cm across at the defaults."""
    pitch_x, pitch_y = (float(v) for v in pitch_xy_m)
    if not (0.0 < side_m <= min(pitch_x, pitch_y)) or columns < 1 or rows < 1:
        raise TerrainError(f"stone_grid: stones of {show(side_m)} m at a pitch of {show(list(pitch_xy_m))} m do not "
                           "fit (0 < side <= pitch, at least one column and row)")
    start_half = 0.25
    first_x = start_half + pitch_x - side_m / 2
    stones = [_rect((first_x + i * pitch_x, (j - (rows - 1) / 2) * pitch_y), (side_m, side_m))
              for i in range(columns) for j in range(rows)]
    end_x = first_x + (columns - 1) * pitch_x + pitch_x - side_m / 2 + start_half
    width = rows * pitch_y
    regions = [_rect((0.0, 0.0), (2 * start_half, width)), *stones, _rect((end_x, 0.0), (2 * start_half, width))]
    return Terrain(name="stone_grid", start_xy=(0.0, 0.0), goal_x=end_x - start_half + 0.15, regions=regions,
                   description=f"{columns} x {rows} square stones of {100 * side_m:g} cm at a pitch of "
                               f"{100 * pitch_x:g} x {100 * pitch_y:g} cm (esfal's Go2 stepping stones)")


_GENERATORS: Mapping[str, Callable[..., Terrain]] = MappingProxyType({
    "flat": flat, "narrow_stones": narrow_stones, "push_field": push_field, "raised_stones": raised_stones,
    "ramps": ramps, "stairs": stairs, "stepping_stones": stepping_stones, "stone_grid": stone_grid,
})
#: Terrains registered by name from outside the package (``register_terrain``; plugins: ``contactnet.plugins``).
_REGISTERED: dict[str, Callable[[], Terrain]] = {}
_SEEDED = ("push_field", "raised_stones")  # generators that take a seed (0 is the shipped file)


def register_terrain(name: str, generate: Callable[[], Terrain]) -> None:
    """Make a terrain known by ``name`` (``--terrain NAME`` on every command, the browser's list): ``generate()``
    builds it. A shipped or generated terrain's name cannot be taken."""
    if name in _GENERATORS or name in _FIELDS or name in available() or name in _REGISTERED:
        raise ValueError(f"a terrain named {name!r} already exists")
    _REGISTERED[name] = generate


def registered_terrains() -> tuple[str, ...]:
    """The names of the terrains registered with ``register_terrain`` (plugins included)."""
    from contactnet.plugins import load_plugins

    load_plugins()
    return tuple(_REGISTERED)
_FIELDS = ("random", "random_heights")  # generators that need ``removed``


def by_name(name: str, removed: int | None = None, seed: int = 0, height_m: float | None = None) -> Terrain:
    """Generator by name: 'flat', 'random' and 'random_heights' (need ``removed``; the latter's tops within
    +-``height_m``, default 3 cm), 'stepping_stones', 'narrow_stones', 'push_field', 'raised_stones' (these
    two with ``seed``), 'stairs'. ``height_m`` is for 'random_heights' only and ignored by the others."""
    if name in _FIELDS:
        if removed is None:
            raise TerrainError(f"{name}: the random field needs 'removed' (number of squares to remove, 0..300)")
        if name == "random":
            return random_field(removed, seed)
        return random_heights(removed, seed, RANDOM_HEIGHTS_DEFAULT_M if height_m is None else height_m)
    if name in _SEEDED:
        return _GENERATORS[name](seed)
    if name in _GENERATORS:
        return _GENERATORS[name]()
    raise TerrainError(f"unknown terrain generator {show(name)}; expected one of: {', '.join(_FIELDS)}, "
                       f"{', '.join(_GENERATORS)}")


#: A region's fields that are lengths (scaled with the scene); the rest (yaw, points, cols, rows, removed) are not.
_LENGTH_FIELDS = ("center", "size", "radius", "outer_radius", "inner_radius", "vertices", "origin", "cell", "z")


def scaled(terrain: Terrain, scale: float) -> Terrain:
    """``terrain`` ``scale`` times larger: every length (positions, sizes, heights, the start and the goal) times
    ``scale``; ``scale`` 1 is ``terrain`` itself. The paper's scenes at another robot's size (``--scale``)."""
    value = finite_float(scale)
    if value is None or not 0.1 <= value <= 10.0:
        raise TerrainError(f"scale: expected a number in [0.1, 10], got {show(scale)}")
    if value == 1.0:
        return terrain

    def times(v: Any) -> Any:
        return [times(x) for x in v] if isinstance(v, list | tuple) else round(float(v) * value, 9)

    data = terrain.to_dict()
    data["regions"] = [{k: times(v) if k in _LENGTH_FIELDS else v for k, v in region.items()}
                       for region in data["regions"]]
    data.update(start=times(data["start"]), goal_x=times(data["goal_x"]), surface_z=times(data["surface_z"]),
                description=f"{data.get('description', '')} (x{value:g})".strip())
    return Terrain.from_dict(data, source=f"{terrain.name} x{value:g}")


def terrains_dir() -> Path:
    """Directory of the shipped terrain files: $CONTACTNET_TERRAINS, else <repo>/terrains."""
    override = os.environ.get("CONTACTNET_TERRAINS")
    return Path(override) if override else Path(__file__).resolve().parents[2] / "terrains"


def available() -> list[str]:
    """Sorted stems of the terrain files in `terrains_dir`."""
    directory = terrains_dir()
    return sorted(p.stem for p in directory.glob("*.json")) if directory.is_dir() else []


def resolve(name_or_path: str | os.PathLike[str], removed: int | None = None, seed: int = 0,
            height_m: float | None = None, scale: float = 1.0) -> Terrain:
    """Terrain from a CLI argument: a .json path, a height map or mesh (``.npy``, ``.png``, ``.stl``, ``.obj``, ``.ply``:
    ``contactnet.terrain.importing`` with its defaults), 'random' or 'random_heights' (with ``removed``/``seed``, the
    latter with ``height_m``), or a shipped name; a scene (not a file) ``scale`` times larger (`scaled`).

    Order: an existing file or a name ending in .json is loaded; 'random' and 'random_heights' build
    their fields (and 'push_field' and 'raised_stones' with a non-zero ``seed`` build that variant);
    ``<terrains_dir>/<name>.json`` is loaded; a generator name ('flat', ...) is generated; anything
    else raises TerrainError listing the available names.
    """
    text = os.fspath(name_or_path)
    from contactnet.terrain.importing import HEIGHT_MAP_SUFFIXES, MESH_SUFFIXES, import_terrain

    if text.lower().endswith(HEIGHT_MAP_SUFFIXES + MESH_SUFFIXES):  # a height map or a mesh, with the defaults
        return import_terrain(text)[0]
    if text.endswith(".json") or Path(text).is_file():  # a file is what it says, at any scale
        return Terrain.load(text)
    return scaled(_scene(text, removed, seed, height_m), scale)


def _scene(text: str, removed: int | None, seed: int, height_m: float | None) -> Terrain:
    """`resolve` of a name that is not a file: a field, a shipped file by name, a generator, a registered terrain."""
    if text in _FIELDS or (text in _SEEDED and seed != 0):
        return by_name(text, removed=removed, seed=seed, height_m=height_m)
    shipped = terrains_dir() / f"{text}.json"
    if shipped.is_file():
        return Terrain.load(shipped)
    if text in _GENERATORS:
        return by_name(text, seed=seed)
    if text in registered_terrains():
        return _REGISTERED[text]()
    names = sorted({*available(), *_GENERATORS, *_FIELDS, *_REGISTERED})
    raise TerrainError(f"unknown terrain {show(text)}: expected a .json path or one of: {', '.join(names)}")


SHIPPED: Mapping[str, Callable[[], Terrain]] = MappingProxyType({
    "flat": flat,
    "stepping_stones": stepping_stones,
    "narrow_stones": narrow_stones,
    "push_field": push_field,
    "random_80_0": lambda: random_field(80, 0),
    "stairs": stairs,
    "raised_stones": raised_stones,
    "ramps": ramps,
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
