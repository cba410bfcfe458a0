"""Real-time factor of the standing simulation: sphere feet vs the URDF's mesh feet (same run).

    python benchmarks/bench_sim.py        (the same table as `contactnet bench sim`)
"""

from contactnet.bench import bench_sim, format_table

if __name__ == "__main__":
    print(format_table(bench_sim()))
