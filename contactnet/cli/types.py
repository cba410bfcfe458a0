"""The command line's argument types: each parses one option's text and says in one line, naming the option, what
was wrong (argparse prints it and exits 2)."""

from __future__ import annotations

import argparse


def bounded_float(name: str, low: float, high: float):
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (low <= value <= high):  # also rejects nan
            raise argparse.ArgumentTypeError(f"{name} must be in [{low}, {high}], got {text}")
        return value

    return parse


def choices(name: str, allowed: tuple[str, ...]):
    def parse(text: str) -> tuple[str, ...]:
        items = tuple(t.strip() for t in text.split(",") if t.strip())
        bad = [t for t in items if t not in allowed]
        if bad or not items:
            raise argparse.ArgumentTypeError(f"{name}: expected a comma-separated list of {', '.join(allowed)}, got {text!r}")
        return items

    return parse


def number_list(name: str, low: float, high: float, kind: type = float):
    """Comma-separated numbers of ``kind`` (int: whole numbers), each in [low, high] (nan rejected)."""
    what = "whole numbers" if kind is int else "numbers"
    bounds = f"{low}..{high}" if kind is int else f"[{low:g}, {high:g}]"

    def parse(text: str) -> tuple:
        try:
            items = tuple(kind(t) for t in text.split(",") if t.strip())
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name}: expected comma-separated {what}, got {text!r}") from None
        if not items or any(not low <= v <= high for v in items):
            raise argparse.ArgumentTypeError(f"{name}: every value must be in {bounds}, got {text!r}")
        return items

    return parse


def bounded_int(name: str, low: int, high: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a whole number, got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{name} must be in {low}..{high}, got {value}")
        return value

    return parse


def positive_int(name: str, high: int):
    return bounded_int(name, 1, high)


__all__ = ["bounded_float", "bounded_int", "choices", "number_list", "positive_int"]
