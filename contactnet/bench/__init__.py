"""Every benchmark of ``contactnet bench ...``, one table format.

Machines here are noisy: every figure is a median over repeats, and each benchmark measures a reference
in the same run so that ratios stay meaningful. Each benchmark is a function returning rows (dicts);
``format_table`` prints them and ``--json`` dumps them. A benchmark takes ``robot_name`` when it runs a
robot (``contactnet bench sim --robot go2``).

| name       | module                           | what it times                                             |
|------------|----------------------------------|-----------------------------------------------------------|
| sim        | ``contactnet.bench.sim``         | PyBullet standing (reference) and the whole stack walking |
| planner    | ``contactnet.bench.planner``     | one ContactNet / fixed-gait plan, 0 vs 100 holes          |
| trajopt    | ``contactnet.bench.trajopt``     | the rigid-body optimizer, its solvers side by side        |
| cost       | ``contactnet.bench.cost``        | the ranking cost V of all candidates                      |
| terrain    | ``contactnet.bench.terrain``     | ``Terrain.is_safe`` against plain shapely                 |
| locomotion | ``contactnet.bench.locomotion``  | walking quality matrix (velocities, pushes, noise)        |
| live       | ``app.bench.live`` (the web tool) | real time with browsers connected; recording size         |
| upload     | ``app.bench.upload`` (the web tool) | ``GET /api/state`` latency while a large terrain uploads  |

``live`` and ``upload`` run the web tool, so they live in ``app/`` (the library never imports the app); the command
line reaches them as ``contactnet bench live`` / ``upload``.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable

#: name -> (module, function) of every benchmark.
BENCHMARKS: dict[str, tuple[str, str]] = {
    "sim": ("contactnet.bench.sim", "bench_sim"),
    "planner": ("contactnet.bench.planner", "bench_planner"),
    "trajopt": ("contactnet.bench.trajopt", "benchmark"),
    "cost": ("contactnet.bench.cost", "benchmark"),
    "terrain": ("contactnet.bench.terrain", "benchmark_is_safe"),
    "locomotion": ("contactnet.bench.locomotion", "bench_locomotion"),
}


def benchmark(name: str) -> Callable[..., list[dict]]:
    """The function of a named benchmark (imported on demand: each pulls in what it times)."""
    module, function = BENCHMARKS[name]
    return getattr(importlib.import_module(module), function)


def run(name: str, robot_name: str | None = None, runs: int | None = None) -> list[dict]:
    """Run a named benchmark; ``robot_name`` goes to the benchmarks that run a robot, ``runs`` (repeats of each row)
    to those that take it (`takes_runs`)."""
    fn = benchmark(name)
    given = {"robot_name": robot_name, "runs": runs}
    parameters = inspect.signature(fn).parameters
    return fn(**{key: value for key, value in given.items() if value is not None and key in parameters})


def takes_runs(name: str) -> bool:
    """Whether the named benchmark takes ``runs`` (``contactnet bench sim --runs N``)."""
    return name in BENCHMARKS and "runs" in inspect.signature(benchmark(name)).parameters


def format_table(rows: list[dict]) -> str:
    """A plain aligned text table of rows with the union of their keys."""
    keys: list[str] = []
    for row in rows:
        keys += [k for k in row if k not in keys]

    def fmt(value: object) -> str:
        if isinstance(value, float):
            return f"{value:.4g}"
        return "" if value is None else str(value)

    cells = [[fmt(row.get(k)) for k in keys] for row in rows]
    widths = [max(len(k), *(len(c[i]) for c in cells)) for i, k in enumerate(keys)]
    lines = ["  ".join(k.ljust(w) for k, w in zip(keys, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in cells]
    return "\n".join(lines)
