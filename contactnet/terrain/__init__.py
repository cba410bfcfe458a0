"""Terrain: the steppable surface the planner checks candidate footholds against.

A terrain is the union of 2D regions whose flat tops (each at its own height ``z``) are steppable;
everything else is a hole. The package:

- ``schema``: the JSON file format (limits and the complexity budget, `TerrainError`, strict
  validation, reading/writing);
- ``planes``: sloped tops (``slope_deg``, ``slope_dir_deg``): their fields, gradient and centre;
- ``regions``: region shapes as shapely geometry (grids traced from their cells in linear time);
- ``union``: the steppable union of the regions, within the complexity budget;
- ``levels``: the tops of a terrain with several heights (which part has its top at which z);
- ``locate``: fast exact point location (rasters, shapely next to the edges);
- ``geometry``: `Terrain` (``from_dict``, ``from_json``, ``load``), ``validate_terrain_bytes``
  and the point queries (``is_safe``, ``height_at``, ``ground_z``);
- ``scenes``: the paper's scenes as generators, the shipped files, name resolution
  (``python -m contactnet.terrain`` rewrites the shipped files);
- ``importing``: terrain from a height map or a mesh, segmented into steppable tops (``terrain import``);
- ``mesh``: the extruded triangle mesh; ``render``: the matplotlib top view;
- ``edits``: pure edit operations on terrain dicts (holes, stones, moves, undo).
"""

from __future__ import annotations

from contactnet.terrain.geometry import Terrain, region_geometry, validate_terrain_bytes
from contactnet.terrain.importing import ImportReport, SegmentConfig, import_terrain
from contactnet.terrain.scenes import (
    SHIPPED,
    available,
    by_name,
    flat,
    main,
    narrow_stones,
    push_field,
    raised_stones,
    ramps,
    random_field,
    random_heights,
    register_terrain,
    registered_terrains,
    resolve,
    scaled,
    stairs,
    stepping_stones,
    stone_grid,
    terrains_dir,
)
from contactnet.terrain.schema import TerrainError

__all__ = [
    "SHIPPED",
    "ImportReport",
    "SegmentConfig",
    "Terrain",
    "TerrainError",
    "available",
    "by_name",
    "flat",
    "import_terrain",
    "main",
    "narrow_stones",
    "push_field",
    "raised_stones",
    "random_field",
    "random_heights",
    "ramps",
    "region_geometry",
    "register_terrain",
    "registered_terrains",
    "resolve",
    "scaled",
    "stairs",
    "stepping_stones",
    "stone_grid",
    "terrains_dir",
    "validate_terrain_bytes",
]
