"""Timing helpers shared by the benchmarks."""

from __future__ import annotations

import os
import time
from collections.abc import Callable


def pin_single_core() -> Callable[[], None]:
    """Pin the process to one CPU and torch to one thread; return a function that undoes it."""
    affinity = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    if affinity:
        os.sched_setaffinity(0, {min(affinity)})
    try:
        import torch
    except ImportError:  # pragma: no cover
        torch = None
    threads = torch.get_num_threads() if torch is not None else None
    if torch is not None:
        torch.set_num_threads(1)

    def restore() -> None:
        if affinity:
            os.sched_setaffinity(0, affinity)
        if torch is not None:
            torch.set_num_threads(threads)

    return restore


def time_calls(fn: Callable[[], object], repeats: int, warmup: int = 10) -> list[float]:
    """Wall times (s) of `repeats` calls of fn after `warmup` untimed ones."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return times
