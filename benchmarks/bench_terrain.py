"""Speed of ``Terrain.is_safe`` against plain prepared-shapely ``contains_xy``.

Usage: ``python benchmarks/bench_terrain.py [--repeats 2000]``. Prints median and p90 microseconds
per call for 1, 100 and 1000 random points on ``random_field(80, 0)`` and ``stepping_stones()``,
at margin 0 and at the planner's foot-radius margin. The timing itself lives in
:func:`contactnet.terrain.benchmark_is_safe` so a CLI can reuse it; this script only formats it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

try:
    from contactnet.terrain import benchmark_is_safe
except ImportError:  # run from a checkout without the package installed
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from contactnet.terrain import benchmark_is_safe


def run(repeats: int = 2000) -> list[dict[str, Any]]:
    """Rows of timings (see :func:`contactnet.terrain.benchmark_is_safe`)."""
    return benchmark_is_safe(repeats=repeats)


def format_table(rows: list[dict[str, Any]]) -> str:
    """A fixed-width text table of the rows."""
    header = (f"{'terrain':<16} {'margin':>7} {'points':>6} | {'is_safe med':>11} {'p90':>7} | "
              f"{'shapely med':>11} {'p90':>7} | {'speedup':>7}")
    lines = [header, "-" * len(header)]
    for row in rows:
        lines.append(
            f"{row['terrain']:<16} {row['margin_m']:>7.3f} {row['n_points']:>6d} | "
            f"{row['is_safe_median_us']:>9.1f}us {row['is_safe_p90_us']:>5.1f}us | "
            f"{row['shapely_median_us']:>9.1f}us {row['shapely_p90_us']:>5.1f}us | {row['speedup']:>6.2f}x")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2000, help="timed calls per row (default 2000)")
    args = parser.parse_args(argv)
    print(format_table(run(args.repeats)))
    print("speedup = shapely median / is_safe median; shapely = contains_xy on a prepared copy of the same "
          "(shrunk) geometry")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
