"""Benchmark of the terrain's hot path: ``Terrain.is_safe`` against plain prepared-shapely ``contains_xy``;
and of validating a large terrain (issue 11: a 500 x 500 grid with 20,000 cells removed took 43 s).

Printed by ``contactnet bench terrain``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import numpy as np
import shapely

from contactnet.terrain import random_field, stepping_stones


def benchmark_is_safe(repeats: int = 2000, margins: Sequence[float] | None = None,
                      sizes: Sequence[int] = (1, 100, 1000),
                      robot_name: str = "solo12", validation_repeats: int = 3) -> list[dict[str, Any]]:
    """Time ``is_safe`` against plain prepared-shapely ``contains_xy`` on the same geometry.

    Points are uniform in the terrain's bounds padded by 5 cm (seeded). One row per terrain, margin
    and batch size with median and p90 microseconds of each and ``speedup`` = shapely / is_safe
    (median). ``margins`` default to 0 and the foot radius of the robot ``robot_name``. Then, unless
    ``validation_repeats`` is 0, the rows of `benchmark_validation`.
    """
    if margins is None:
        from contactnet.robots import load_robot

        margins = (0.0, load_robot(robot_name).description.foot_radius_m)
    rows: list[dict[str, Any]] = []
    rng = np.random.default_rng(0)
    for terrain in (random_field(80, 0), stepping_stones()):
        minx, miny, maxx, maxy = terrain.bounds
        for margin in margins:
            reference = shapely.from_wkb(shapely.to_wkb(terrain.safe_region(margin)))
            shapely.prepare(reference)
            for n_points in sizes:
                points_xy_world = rng.uniform((minx - 0.05, miny - 0.05), (maxx + 0.05, maxy + 0.05), (n_points, 2))
                x_world, y_world = points_xy_world[:, 0].copy(), points_xy_world[:, 1].copy()
                ours, theirs = _time_pair_us(partial(terrain.is_safe, points_xy_world, margin=margin),
                                             partial(shapely.contains_xy, reference, x_world, y_world), repeats)
                rows.append({
                    "terrain": terrain.name, "margin_m": float(margin), "n_points": int(n_points),
                    "is_safe_median_us": float(np.median(ours)), "is_safe_p90_us": float(np.percentile(ours, 90)),
                    "shapely_median_us": float(np.median(theirs)),
                    "shapely_p90_us": float(np.percentile(theirs, 90)),
                    "speedup": float(np.median(theirs) / np.median(ours)),
                })
    return rows + (benchmark_validation(validation_repeats) if validation_repeats else [])


def large_grid_dict(cols: int = 500, rows: int = 500, removed: int = 20_000, cell: float = 0.025, seed: int = 0,
                    clear_m: float = 0.35) -> dict[str, Any]:
    """A terrain dict: one grid of ``cols`` x ``rows`` cells with ``removed`` random cells gone (seeded), its
    start at the centre with no hole within ``clear_m`` of it (so a robot can stand there)."""
    rng = np.random.default_rng(seed)
    centre = (0.5 * cols * cell, 0.5 * rows * cell)
    row, col = np.divmod(rng.permutation(cols * rows), cols)
    far = (np.abs((col + 0.5) * cell - centre[0]) > clear_m) | (np.abs((row + 0.5) * cell - centre[1]) > clear_m)
    chosen = np.flatnonzero(far)[:removed]
    return {"name": f"grid_{cols}x{rows}_{removed}_removed", "start": [centre[0], centre[1]],
            "goal_x": cols * cell - cell, "regions": [{
                "shape": "grid", "origin": [0.0, 0.0], "cell": cell, "cols": cols, "rows": rows,
                "removed": np.column_stack([col[chosen], row[chosen]]).tolist()}]}


def benchmark_validation(repeats: int = 3) -> list[dict[str, Any]]:
    """Rows: validating (JSON bytes to ``Terrain``) and meshing the 500 x 500 grid with 20,000 cells removed.

    Median and max seconds over ``repeats``; the issue's target is <= 1 s for any terrain that validates.
    """
    import json

    from contactnet.terrain import Terrain

    content = json.dumps(large_grid_dict()).encode()
    terrain = Terrain.from_json(content)
    rows = []
    for name, call in (("validate 500x500 grid, 20k removed", partial(Terrain.from_json, content)),
                       ("mesh 500x500 grid, 20k removed", terrain.mesh)):
        times_s = []
        for _ in range(repeats):
            start = time.perf_counter()
            call()
            times_s.append(time.perf_counter() - start)
        rows.append({"terrain": name, "json_bytes": len(content), "median_s": float(np.median(times_s)),
                     "max_s": float(np.max(times_s)), "runs": repeats})
    return rows


def _time_pair_us(first: Callable[[], Any], second: Callable[[], Any], repeats: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-call wall times (microseconds) of two calls, alternated so both see the same machine load."""
    for _ in range(min(20, repeats)):
        first()
        second()
    times_ns = np.empty((2, repeats))
    clock = time.perf_counter_ns
    for i in range(repeats):
        t0 = clock()
        first()
        t1 = clock()
        second()
        times_ns[0, i], times_ns[1, i] = t1 - t0, clock() - t1
    return times_ns[0] / 1e3, times_ns[1] / 1e3
