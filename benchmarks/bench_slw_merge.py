"""Merge the outputs of a bench_slw run split across processes (--builtin-only, --programs) into
one summary: cases, failures, ticks over a limit, cycle time / floor (median, 90th percentile,
worst, program cuts alone), against the floor without the corner chain, compute over 15 s.

Run: python benchmarks/bench_slw_merge.py OUT1.txt OUT2.txt ...
"""

from __future__ import annotations

import re
import sys

import numpy as np

#: Over a limit: bench_slw.OVER; compute budget per case (issue 38).
OVER = 1 + 5e-5
BUDGET_S = 15.0
ROW = re.compile(r"^(?P<name>\S.*?/(?:equal|slow-y)/(?:cosine|seven-phase))\s+(?P<nums>[-0-9. ]+?)\s+(?P<limit>[a-z_]+)\s+"
                 r"(?P<crit>\d+)\s+(?P<cpu>[0-9.]+)$")
FAIL = re.compile(r"^(?P<name>\S.*?/(?:equal|slow-y)/(?:cosine|seven-phase))\s+FAILED after (?P<cpu>[0-9.]+) s: (?P<why>.*)$")


def read(paths: list[str]) -> tuple[list[dict], list[dict]]:
    rows, fails = [], []
    for path in paths:
        for line in open(path, encoding="utf-8"):
            line = line.rstrip("\n")
            m = FAIL.match(line)
            if m:
                fails.append({"name": m["name"], "cpu": float(m["cpu"]), "why": m["why"]})
                continue
            m = ROW.match(line)
            if m:
                length, time, bound, floor, ratio, old, worst = (float(x) for x in m["nums"].split())
                rows.append({"name": m["name"], "time": time, "floor": floor, "ratio": ratio, "old": old,
                             "worst": worst, "cpu": float(m["cpu"]), "program": "#" in m["name"]})
    return rows, fails


def main() -> None:
    rows, fails = read(sys.argv[1:])
    ratio = np.array([r["ratio"] for r in rows])
    prog = np.array([r["ratio"] for r in rows if r["program"]])
    worst = max(rows, key=lambda r: r["ratio"])
    over = [r["name"] for r in rows if r["worst"] > OVER]
    slow = sorted((r for r in rows + fails if r["cpu"] > BUDGET_S), key=lambda r: -r["cpu"])
    print(f"{len(rows) + len(fails)} cases, failed {len(fails)}, over a limit {len(over)} {over[:6]}")
    for f in fails:
        print(f"  failed: {f['name']} after {f['cpu']:.1f} s: {f['why'][:160]}")
    print(f"ratio to the floor: median {np.median(ratio):.4f}, 90th percentile {np.percentile(ratio, 90):.4f}, "
          f"worst {worst['ratio']:.4f} ({worst['name']}: {worst['time']:.3f} s, floor {worst['floor']:.3f} s); "
          f"program cuts alone median {np.median(prog):.4f}, worst {prog.max():.4f}")
    print(f"against the floor without the corner chain: median {np.median([r['old'] for r in rows]):.4f}, "
          f"worst {max(r['old'] for r in rows):.4f}")
    print(f"compute over {BUDGET_S:g} s on {len(slow)}: " + ", ".join(f"{r['name']} {r['cpu']:.1f}" for r in slow))
    print(f"median_ratio_to_floor={np.median(ratio):.4f} worst_ratio_to_floor={worst['ratio']:.4f} "
          f"failed={len(fails)} over_limit={len(over)}")


if __name__ == "__main__":
    main()
