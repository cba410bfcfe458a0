"""Benchmark of the SRBD trajectory optimizer (contactnet.trajopt): median / p99 per solve on one core.

Usage: .venv/bin/python benchmarks/bench_trajopt.py [n_solves]
"""

from __future__ import annotations

import os
import sys

# one BLAS thread: the solves are small; set before numpy is imported
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from contactnet.trajopt import benchmark, format_table  # noqa: E402


def main() -> None:
    n_solves = int(sys.argv[1]) if len(sys.argv) > 1 else 50
    print(format_table(benchmark(n_solves=n_solves)))


if __name__ == "__main__":
    main()
