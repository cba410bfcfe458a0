"""A `Terrain`'s regions are read-only: normalized region dicts frozen into mappings and tuples, and thawed
back into plain dicts and lists for JSON (`Terrain.to_dict`). A terrain is shared between threads (the live
session, the 3D view, the planner) and cached by value; freezing its regions makes that safe."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any


def freeze(value: Any) -> Any:
    """Recursively turn dicts into read-only mappings and lists into tuples."""
    kind = type(value)
    if kind is float or kind is int or kind is str:  # fast paths for what normalized regions hold
        return value
    if kind is list or kind is tuple:
        return tuple(map(freeze, value))
    if isinstance(value, Mapping):
        return MappingProxyType({k: freeze(v) for k, v in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(freeze(v) for v in value)
    return value


def freeze_region(region: Mapping[str, Any]) -> Mapping[str, Any]:
    """`freeze` of a normalized region (from `parse_fields`), fast: its lists of numbers and of
    number pairs (vertices, removed cells) become tuples in C-level passes."""
    frozen: dict[str, Any] = {}
    for key, value in region.items():
        if type(value) is list:
            value = tuple(map(tuple, value)) if value and type(value[0]) is list else tuple(value)
        frozen[key] = value
    return MappingProxyType(frozen)


def thaw(value: Any) -> Any:
    """Inverse of `freeze`: plain dicts and lists for JSON."""
    if isinstance(value, Mapping):
        return {k: thaw(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [thaw(v) for v in value]
    return value
