"""Plugins: robots, planners, gaits and terrains registered by other installed packages.

A package declares entry points in its ``pyproject.toml``, one group per kind::

    [project.entry-points."contactnet.planners"]
    wide_margin = "my_package.planners"            # a module whose import registers (register_planner(...))
    [project.entry-points."contactnet.robots"]
    a1 = "my_package.robots:register"              # or a function called with no arguments

`load_plugins` loads them all once per process, before the names are read: ``contactnet.registry`` calls it when
it is imported (so the command line, ``serve``, the pool's and Ray's workers all see the plugins), and the terrain
and robot lookups call it before they say a name is unknown. A plugin that fails to load is reported in one line on
stderr and skipped: a broken package never stops the tool. ``examples/plugin/`` is a complete one.
"""

from __future__ import annotations

import functools
import sys
from dataclasses import dataclass

#: The entry-point groups read, one per kind of thing a plugin registers.
GROUPS = ("contactnet.robots", "contactnet.gaits", "contactnet.planners", "contactnet.terrains")


@dataclass(frozen=True)
class PluginLoad:
    """One entry point loaded: its group, name, where it points, and the error that stopped it (None: loaded)."""

    group: str
    name: str
    value: str
    error: str | None = None


#: Non-empty while the plugins load: a plugin that reaches a lookup calling `load_plugins` again gets nothing
#: (its own registrations are under way), not a second round of loading.
_LOADING: list[bool] = []


def load_plugins() -> tuple[PluginLoad, ...]:
    """Load every entry point of `GROUPS` (once per process); returns what was loaded and what failed."""
    return () if _LOADING else _load_once()


@functools.cache
def _load_once() -> tuple[PluginLoad, ...]:
    from importlib.metadata import entry_points

    _LOADING.append(True)
    try:
        return _load_groups(entry_points)
    finally:
        _LOADING.clear()


def _load_groups(entry_points) -> tuple[PluginLoad, ...]:  # noqa: ANN001 - importlib.metadata.entry_points
    loads = []
    for group in GROUPS:
        for point in sorted(entry_points(group=group), key=lambda p: p.name):
            try:
                loaded = point.load()
                if callable(loaded):
                    loaded()
                loads.append(PluginLoad(group, point.name, point.value))
            except Exception as exc:  # noqa: BLE001 - any failure of a foreign package: reported and skipped
                error = f"{type(exc).__name__}: {exc}".splitlines()[0]
                loads.append(PluginLoad(group, point.name, point.value, error))
                print(f"contactnet: plugin {point.name} ({group}, {point.value}) did not load: {error}",
                      file=sys.stderr)
    return tuple(loads)


__all__ = ["GROUPS", "PluginLoad", "load_plugins"]
