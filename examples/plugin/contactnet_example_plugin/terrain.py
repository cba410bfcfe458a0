"""``gap_course``: flat ground with three gaps across the path, 6, 8 and 10 cm wide."""

from __future__ import annotations

from contactnet.terrain import Terrain, register_terrain


def gap_course() -> Terrain:
    edges_x = [-0.5, 0.5, 0.56, 1.0, 1.08, 1.5, 1.6, 2.5]  # pairs: the tops between the gaps
    regions = [{"shape": "rect", "center": [(a + b) / 2, 0.0], "size": [b - a, 1.0]}
               for a, b in zip(edges_x[0::2], edges_x[1::2], strict=True)]
    return Terrain(name="gap_course", start_xy=(0.0, 0.0), goal_x=2.0, regions=regions,
                   description="three gaps across the path: 6, 8 and 10 cm (examples/plugin)")


def register() -> None:
    register_terrain("gap_course", gap_course)
