"""Matplotlib top view of a terrain: steppable area filled (coloured by the height of its tops when they
differ), holes white, start, feet and goal line marked."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

if TYPE_CHECKING:
    from matplotlib.axes import Axes



class TerrainView(Protocol):
    """What a top view needs of a terrain (``contactnet.terrain.Terrain`` is one)."""

    name: str
    goal_x: float

    @property
    def bounds(self) -> tuple[float, float, float, float]: ...

    @property
    def steppable(self) -> BaseGeometry: ...

    @property
    def start_xy(self) -> np.ndarray: ...

    @property
    def levels(self) -> tuple[tuple[float, BaseGeometry], ...]: ...


def render(terrain: TerrainView, ax: Axes | None = None, show_start: bool = True,
           feet_xy_start: Sequence[Sequence[float]] | np.ndarray | None = None) -> Axes:
    """Top view: steppable area filled, holes white, start marked (``show_start``), goal line.

    With tops at one height the area is one sand colour; with several, each top is coloured by its
    height (a colour bar gives z in metres) and outlined, so risers show as lines. ``feet_xy_start`` (N, 2), world-frame x, y in metres, are marked as the feet at the start (the
    terrain knows no robot: e.g. the CLI passes the robot's nominal stance placed at the start);
    None marks no feet.
    """
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MplPath

    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=_figure_size(terrain.bounds))
    minx, miny, maxx, maxy = terrain.bounds
    pad = 0.05 * max(maxx - minx, maxy - miny, 0.2)
    ax.set_facecolor("white")
    levels = terrain.levels
    sloped = getattr(terrain, "sloped", False)
    planes: Any = terrain  # with sloped tops: a Terrain (top_z_range, level_planes, level_height)
    heights = list(planes.top_z_range()) if sloped else [z for z, _ in levels]
    mappable = _height_colours(ax, heights) if len(levels) > 1 or sloped else None
    for index, (top_z, geometry) in enumerate(levels):
        tilted = sloped and bool(planes.level_planes[index, :2].any())
        for polygon in shapely.get_parts(geometry):
            polygon = orient(polygon, sign=1.0)
            rings = [np.asarray(polygon.exterior.coords)] + [np.asarray(r.coords) for r in polygon.interiors]
            path = MplPath.make_compound_path(*[MplPath(r, closed=True) for r in rings])
            if tilted:  # a sloped top: its triangles shaded by the plane's height
                from contactnet.terrain.mesh import _triangulate

                xy, triangles = _triangulate(polygon)
                ax.tripcolor(xy[:, 0], xy[:, 1], triangles, planes.level_height(index, xy), shading="gouraud",
                             cmap=mappable.cmap, norm=mappable.norm)
            colour = "#cdb891" if mappable is None else mappable.to_rgba(top_z)
            ax.add_patch(PathPatch(path, facecolor="none" if tilted else colour, edgecolor="#6b5a3a", linewidth=0.6))
    ax.axvline(terrain.goal_x, color="#2a8a3a", linestyle="--", linewidth=1.2,
               label=f"goal x = {terrain.goal_x:g} m")
    if show_start:
        ax.plot(*terrain.start_xy, marker="o", color="#c0392b", markersize=6, linestyle="none", label="start")
    if feet_xy_start is not None:
        feet_xy = np.asarray(feet_xy_start, dtype=float).reshape(-1, 2)
        ax.plot(feet_xy[:, 0], feet_xy[:, 1], marker="x", color="#c0392b", markersize=5, linestyle="none",
                label="nominal feet")
    ax.set_xlim(min(minx, terrain.goal_x) - pad, max(maxx, terrain.goal_x) + pad)
    ax.set_ylim(miny - pad, maxy + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(terrain.name)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
    return ax


def _figure(terrain: TerrainView, feet_xy_start: Sequence[Sequence[float]] | np.ndarray | None) -> Any:
    """The top view on a figure of its own (the Agg backend: no display, no pyplot state)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=_figure_size(terrain.bounds))
    FigureCanvasAgg(figure)
    render(terrain, ax=figure.add_subplot(), show_start=True, feet_xy_start=feet_xy_start)
    figure.tight_layout()
    return figure


def render_png(terrain: TerrainView, path: str | os.PathLike[str], dpi: int = 120,
               feet_xy_start: Sequence[Sequence[float]] | np.ndarray | None = None) -> Path:
    """Render the top view (start marked, and ``feet_xy_start`` if given) to a PNG with the Agg backend.

    No display and no pyplot state; the parent directories are created. Returns the path written.
    """
    figure = _figure(terrain, feet_xy_start)
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(target, dpi=dpi)
    return target


def render_rgb(terrain: TerrainView, dpi: int = 80,
               feet_xy_start: Sequence[Sequence[float]] | np.ndarray | None = None) -> np.ndarray:
    """The top view as an image, (H, W, 3) uint8 RGB: e.g. the browser's preview of an imported map."""
    figure = _figure(terrain, feet_xy_start)
    figure.set_dpi(dpi)
    figure.canvas.draw()
    return np.asarray(figure.canvas.buffer_rgba())[..., :3].copy()


def _height_colours(ax: Axes, tops_z: Sequence[float]) -> Any:
    """A colour map over the terrain's tops (metres: ``to_rgba(z)``, ``cmap``, ``norm``), with a colour bar beside
    ``ax``."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    low, high = min(tops_z), max(tops_z)
    mappable = ScalarMappable(Normalize(low, high if high > low else low + 1e-3), colormaps["viridis"])
    ax.figure.colorbar(mappable, ax=ax, label="top z [m]", fraction=0.04, pad=0.02)
    return mappable


def _figure_size(bounds: tuple[float, float, float, float]) -> tuple[float, float]:
    """Figure (width, height) in inches for a top view of ``bounds``, aspect clamped to 0.5..6."""
    width, height = max(bounds[2] - bounds[0], 0.1), max(bounds[3] - bounds[1], 0.1)
    aspect = min(max(width / height, 0.5), 6.0)
    return (min(4.0 * aspect, 14.0), min(4.0 * aspect, 14.0) / aspect + 1.0)
