"""Merge the outputs of a bench_slw run split across processes (--builtin-only, --programs,
--first-cut, --machine, --program) into one summary per planner / transition: cases, failures,
ticks over a limit, cycle time / floor (median, 90th percentile, worst; built-ins, each cut number
and program cuts alone), against the floor without the corner chain, compute (median, worst, over
15 s). A case in several files counts once: the last file's row.

Run: python benchmarks/bench_slw_merge.py OUT1.txt OUT2.txt ...
"""

from __future__ import annotations

import re
import sys

import numpy as np

#: Over a limit: bench_slw.OVER; compute budget per case (issue 38).
OVER = 1 + 5e-5
BUDGET_S = 15.0
KIND = r"(?:cosine|seven-phase|optimal)"
ROW = re.compile(r"^(?P<name>\S.*?/(?:equal|slow-y)/" + KIND + r")\s+(?P<nums>[-0-9. ]+?)\s+(?P<limit>[a-z_]+)\s+"
                 r"(?P<crit>\d+)\s+(?P<cpu>[0-9.]+)(?:\s+[0-9.]+)?$")
FAIL = re.compile(r"^(?P<name>\S.*?/(?:equal|slow-y)/" + KIND + r")\s+FAILED after (?P<cpu>[0-9.]+) s: (?P<why>.*)$")


def read(paths: list[str]) -> tuple[list[dict], list[dict]]:
    """(rows, failures), one per case: a case read again (a later file) replaces the earlier."""
    cases: dict[str, dict] = {}
    for path in paths:
        for line in open(path, encoding="utf-8"):
            line = line.rstrip("\n")
            m = FAIL.match(line)
            if m:
                cases[m["name"]] = {"name": m["name"], "cpu": float(m["cpu"]), "why": m["why"], "fail": True}
                continue
            m = ROW.match(line)
            if m:
                length, time, bound, floor, ratio, old, worst = (float(x) for x in m["nums"].split())
                cases[m["name"]] = {"name": m["name"], "time": time, "floor": floor, "ratio": ratio, "old": old,
                                    "worst": worst, "cpu": float(m["cpu"]), "program": "#" in m["name"]}
    rows = [r for r in cases.values() if "fail" not in r]
    return rows, [r for r in cases.values() if "fail" in r]


def _part(label: str, rows: list[dict]) -> None:
    if rows:
        r = np.array([x["ratio"] for x in rows])
        c = np.array([x["cpu"] for x in rows])
        worst, slow = rows[int(r.argmax())], rows[int(c.argmax())]
        print(f"  {label}: {len(rows)} cases, median {np.median(r):.4f}, 90th percentile {np.percentile(r, 90):.4f}, "
              f"worst {r.max():.4f} ({worst['name']}); compute median {np.median(c):.2f} s, worst {c.max():.2f} s "
              f"({slow['name']})")


def summary(kind: str, rows: list[dict], fails: list[dict]) -> None:
    ratio = np.array([r["ratio"] for r in rows])
    prog = [r for r in rows if r["program"]]
    worst = max(rows, key=lambda r: r["ratio"])
    over = [r["name"] for r in rows if r["worst"] > OVER]
    slow = sorted((r for r in rows + fails if r["cpu"] > BUDGET_S), key=lambda r: -r["cpu"])
    print(f"{kind}: {len(rows) + len(fails)} cases, failed {len(fails)}, over a limit {len(over)} {over[:6]}, "
          f"worst tick {max(r['worst'] for r in rows):.5f} x its limit")
    for f in fails:
        print(f"  failed: {f['name']} after {f['cpu']:.1f} s: {f['why'][:160]}")
    print(f"  ratio to the floor: median {np.median(ratio):.4f}, 90th percentile {np.percentile(ratio, 90):.4f}, "
          f"worst {worst['ratio']:.4f} ({worst['name']}: {worst['time']:.3f} s, floor {worst['floor']:.3f} s)")
    _part("built-ins", [r for r in rows if not r["program"]])
    for cut in sorted({r["name"].rsplit("#", 1)[1].split("/")[0] for r in prog}, key=int):
        _part(f"program cuts #{cut}", [r for r in prog if f"#{cut}/" in r["name"]])
    _part("program cuts", prog)
    print(f"  programs: {len({r['name'].rsplit('#', 1)[0] for r in prog})}; against the floor without the corner "
          f"chain: median {np.median([r['old'] for r in rows]):.4f}, worst {max(r['old'] for r in rows):.4f}")
    print(f"  compute over {BUDGET_S:g} s on {len(slow)}: " + ", ".join(f"{r['name']} {r['cpu']:.1f}" for r in slow))
    print(f"median_ratio_to_floor={np.median(ratio):.4f} worst_ratio_to_floor={worst['ratio']:.4f} "
          f"worst_compute_s={max(r['cpu'] for r in rows + fails):.2f} failed={len(fails)} over_limit={len(over)}")


def main() -> None:
    rows, fails = read(sys.argv[1:])
    for kind in sorted({r["name"].rsplit("/", 1)[1] for r in rows + fails}):
        summary(kind, [r for r in rows if r["name"].endswith("/" + kind)],
                [r for r in fails if r["name"].endswith("/" + kind)])


if __name__ == "__main__":
    main()
