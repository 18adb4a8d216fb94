"""Mamdani throughput on seed 002's 30-rule controller (rules/paper.toml): fuzzyfeed's exact
numba engine vs scikit-fuzzy 0.5 (array input, and its per-point loop), measured in one run.

    python benchmarks/bench_fuzzy.py [--points 100000] [--loop-points 2000] [--big 10000000] [--repeat 3]

Inputs: random (κ, Dκ) pairs over the universes (κ up to 1.2 × κ_top, so clipping is exercised),
the same for every method. fuzzyfeed is timed after its kernel is compiled/loaded, best of
--repeat; scikit-fuzzy once (it takes minutes). The outputs are compared on the same points
(scikit-fuzzy's 1001-point output universe limits the agreement to its discretisation error).
--big points are run in a fresh subprocess that reports its peak RSS. The last line is
speedup_vs_skfuzzy_array=X (fuzzyfeed points/s over scikit-fuzzy array-input points/s).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

import numpy as np

from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.fuzzy.skfuzzy_ref import build_control_system, skfuzzy_feed_pct

BIG_CHILD = r"""
import json, resource, sys, time
import numpy as np
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
n = int(sys.argv[1])
engine = compile_table(load_rule_table())
engine.feed_pct(np.array([0.1]), np.array([0.2]))        # load the cached kernel
base_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
rng = np.random.default_rng(1)
kappa = rng.uniform(0.0, 1.2, n)
dk = rng.uniform(0.0, 1.0, n)
t0 = time.perf_counter()
out = engine.feed_pct(kappa, dk)
dt = time.perf_counter() - t0
peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"n": n, "seconds": dt, "peak_rss_mb": peak_kb / 1024, "base_rss_mb": base_kb / 1024,
                  "finite": bool(np.isfinite(out).all())}))
"""


def inputs(n: int, seed: int, k_top: float):
    rng = np.random.default_rng(seed)
    return rng.uniform(0.0, 1.2 * k_top, n), rng.uniform(0.0, 1.0, n)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=100_000, help="N for fuzzyfeed and scikit-fuzzy array input")
    parser.add_argument("--loop-points", type=int, default=2000, help="N for scikit-fuzzy's per-point loop")
    parser.add_argument("--big", type=int, default=10_000_000, help="N for the peak-RSS run (0: skip)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    table = load_rule_table()
    engine = compile_table(table)
    k_top = table.curvature.universe[1]
    kappa, dk = inputs(args.points, 0, k_top)
    engine.feed_pct(kappa[:10], dk[:10])   # compile / load the cached kernel outside the timing

    best = float("inf")
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        ours = engine.feed_pct(kappa, dk)
        best = min(best, time.perf_counter() - t0)
    ff_rate = args.points / best

    system = build_control_system(table)
    t0 = time.perf_counter()
    sk_array = skfuzzy_feed_pct(table, kappa, dk, array=True, system=system)
    sk_array_rate = args.points / (time.perf_counter() - t0)

    lk, ld = inputs(args.loop_points, 2, k_top)
    t0 = time.perf_counter()
    sk_loop = skfuzzy_feed_pct(table, lk, ld, array=False, system=system)
    sk_loop_rate = args.loop_points / (time.perf_counter() - t0)
    ours_loop = engine.feed_pct(lk, ld)

    print(f"Mamdani, {len(table.rules)}-rule controller of seed 002 (rules/{table.name}.toml), "
          f"exact centroid vs scikit-fuzzy {__import__('skfuzzy').__version__} (1001-point output universe)")
    print(f"{'method':<34} {'N':>10} {'points/s':>14} {'us/point':>10}")
    for label, n, rate in (("fuzzyfeed (numba, one core)", args.points, ff_rate),
                           ("scikit-fuzzy array input", args.points, sk_array_rate),
                           ("scikit-fuzzy per-point loop", args.loop_points, sk_loop_rate)):
        print(f"{label:<34} {n:>10,} {rate:>14,.0f} {1e6 / rate:>10.3f}")
    print(f"max |fuzzyfeed - scikit-fuzzy| (%-feed): array {np.max(np.abs(ours - sk_array)):.2e} "
          f"over {args.points:,} points, loop {np.max(np.abs(ours_loop - sk_loop)):.2e} "
          f"over {args.loop_points:,}")
    print(f"speedup vs scikit-fuzzy per-point loop: {ff_rate / sk_loop_rate:,.0f}x")

    if args.big:
        result = subprocess.run([sys.executable, "-c", BIG_CHILD, str(args.big)], capture_output=True,
                                text=True, check=True)
        big = json.loads(result.stdout.strip().splitlines()[-1])
        print(f"fuzzyfeed at N = {big['n']:,} (fresh process): {big['n'] / big['seconds']:,.0f} points/s, "
              f"peak RSS {big['peak_rss_mb']:,.0f} MB (after imports {big['base_rss_mb']:,.0f} MB; "
              f"inputs + output {3 * 8 * big['n'] / 2**20:,.0f} MB), all finite: {big['finite']}")
    print(f"speedup_vs_skfuzzy_array={ff_rate / sk_array_rate:.0f}")


if __name__ == "__main__":
    main()
