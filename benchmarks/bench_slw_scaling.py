"""How the SLW schedule and the comparison scale with the path: CPU time, peak memory, growth.

Random smooth NURBS (degree 3, 2-D, legs of about 2 mm, turning up to ±0.6 rad) with 10², 10³ and
10⁴ knot spans on the default machine. Each measurement runs in a fresh process, so the peak
resident memory (ru_maxrss) is that run's; the anchor is the same process importing fuzzyfeed and
numba and scheduling a 10-span curve (the interpreter's own footprint), subtracted from every
figure. Each child loads the compiled NURBS kernel (numba's cache) and runs its own command
(schedule or compare) on a small curve first (imports and first calls are paid once per process,
not per path), then times the run. The memory figure is the 10^4-span run's peak over the
anchor per 10^6 ticks, with the marginal figure (10^3 -> 10^4 spans) beside it. The growth exponent is the slope of log CPU over log spans (1.0 = linear).

Runs of 10² and 10³ spans (schedule and compare) are the least CPU of three fresh processes.

Run: python benchmarks/bench_slw_scaling.py
The comparison runs on 10^3 spans (its ratio to one schedule is the last figure) and on 10^4 spans
(memory per 10^6 simulated ticks, growth). The same two jobs are also timed as the commands a user
runs (`fuzzyfeed schedule` and `fuzzyfeed compare` on the 10^3-span curve written as a shape file,
start-up and output included): the command `schedule` also computes the bound with its halved-grid
check and simulates its trajectory, which the library's `schedule` does not.
Last line: growth_exponent=E peak_mb_per_1e6_ticks=M compare_over_schedule=R (library functions)
command_compare_over_schedule=C (commands)
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

CHILD = r"""
import json, resource, sys, time
import numpy as np
from fuzzyfeed.machine.limits import MachineLimits
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.slw import schedule
spans, what = int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(spans)
n = spans + 3
ang = np.cumsum(rng.uniform(-0.6, 0.6, n))
pts = np.cumsum(np.column_stack([np.cos(ang), np.sin(ang)]) * rng.uniform(1.5, 2.5, n)[:, None], axis=0)
knots = np.concatenate([[0.0] * 4, np.linspace(0, 1, spans + 1)[1:-1], [1.0] * 4])
curve = Nurbs(3, knots, pts)
lim = MachineLimits()
small = Nurbs(3, [0, 0, 0, 0, 1, 1, 1, 1], [[0, 0], [5, 5], [10, -5], [15, 0]])
from fuzzyfeed.geometry._kernels import nurbs_kernel
nurbs_kernel()  # the compiled NURBS loop long paths use: loaded in the anchor too


def run(path):  # the measured command; run once on a small curve first (imports, first calls)
    if what == "schedule":
        return schedule(path, lim, planner="window", transition="cosine").t_s.size
    from fuzzyfeed.report.compare import compare
    from fuzzyfeed.geometry.sampling import sample_uniform_u
    c = compare(sample_uniform_u(path, 2000), lim)
    return sum(sim.law.s_mm.size for sim in c.simulations.values())


run(small)
t0 = time.process_time()
ticks = run(curve)
cpu = time.process_time() - t0
print(json.dumps({"spans": spans, "what": what, "cpu": cpu, "ticks": ticks, "length": curve.length,
                  "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


WRITE_SHAPE = CHILD.split("lim = MachineLimits()")[0].replace("spans, what = int(sys.argv[1]), sys.argv[2]",
                                                                "spans = int(sys.argv[1])") + r"""
with open(sys.argv[2], "w") as f:
    json.dump({"name": f"random{spans}", "units": "mm", "degree": 3,
               "knotvector": [float(k) for k in knots], "control_points": pts.tolist()}, f)
"""


def run(spans: int, what: str, repeat: int = 1) -> dict:
    """The run with the least CPU of ``repeat`` fresh processes (the host is shared: a slow run
    is someone else's load, not ours)."""
    best = None
    for _ in range(repeat):
        out = subprocess.run([sys.executable, "-c", CHILD, str(spans), what], capture_output=True,
                             text=True, check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        best = r if best is None or r["cpu"] < best["cpu"] else best
    return best


def commands(spans: int, repeat: int = 3) -> dict[str, float]:
    """CPU seconds of ``fuzzyfeed schedule`` and ``fuzzyfeed compare`` on the same random curve
    (written as a shape file), each the least of ``repeat`` fresh processes: what a user waits for."""
    with tempfile.TemporaryDirectory() as tmp:
        shape = Path(tmp) / f"random{spans}.json"
        subprocess.run([sys.executable, "-c", WRITE_SHAPE, str(spans), str(shape)], check=True)
        out = {}
        for what in ("schedule", "compare"):
            best = np.inf
            for _ in range(repeat):
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                subprocess.run([sys.executable, "-m", "fuzzyfeed", what, str(shape), "-o",
                                str(Path(tmp) / f"{what}.csv")], check=True, capture_output=True)
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                best = min(best, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
            out[what] = best
    return out


def main() -> None:
    base = run(10, "schedule")
    print(f"anchor: 10 spans, {base['length']:.0f} mm, peak {base['rss_mb']:.0f} MB (the interpreter, "
          f"numpy, numba and fuzzyfeed), {base['cpu']:.2f} s CPU")
    print(f"{'spans':>6} {'length mm':>10} {'ticks':>9} {'CPU s':>8} {'peak MB':>8} {'MB over anchor':>15} "
          f"{'MB per 1e6 ticks':>17}")
    rows = []
    for spans in (100, 1000, 10_000):
        r = run(spans, "schedule", repeat=3 if spans <= 1000 else 1)
        extra = max(r["rss_mb"] - base["rss_mb"], 0.0)
        r["per_1e6"] = extra / r["ticks"] * 1e6
        rows.append(r)
        print(f"{spans:6d} {r['length']:10.0f} {r['ticks']:9d} {r['cpu']:8.2f} {r['rss_mb']:8.0f} "
              f"{extra:15.0f} {r['per_1e6']:17.0f}", flush=True)
    slope = np.polyfit(np.log([r["spans"] for r in rows]), np.log([r["cpu"] for r in rows]), 1)[0]
    # memory per tick at the margin: what 10^4 spans take over 10^3 (fixed costs cancel)
    marginal = (rows[-1]["rss_mb"] - rows[-2]["rss_mb"]) / (rows[-1]["ticks"] - rows[-2]["ticks"]) * 1e6
    print(f"marginal peak memory 10^3 -> 10^4 spans: {marginal:.0f} MB per 10^6 ticks; at 10^4 spans over "
          f"the anchor: {rows[-1]['per_1e6']:.0f} MB per 10^6 ticks")
    cmp_ = run(1000, "compare", repeat=3)
    one = next(r for r in rows if r["spans"] == 1000)
    print(f"compare on 1000 spans: {cmp_['cpu']:.2f} s CPU, peak {cmp_['rss_mb']:.0f} MB "
          f"({cmp_['cpu'] / one['cpu']:.2f}x one schedule: it runs two schedules, the bound and five "
          f"simulations of {cmp_['ticks']} ticks in all, {cmp_['ticks'] / one['ticks']:.1f}x the schedule's)")
    cmd = commands(1000)
    print(f"as commands on 1000 spans (fresh processes, start-up included, least of 3): fuzzyfeed schedule "
          f"{cmd['schedule']:.2f} s CPU (schedule, bound with its halved-grid check, simulation, CSV), "
          f"fuzzyfeed compare {cmd['compare']:.2f} s CPU ({cmd['compare'] / cmd['schedule']:.2f}x)")
    big = run(10_000, "compare")
    big_extra = max(big["rss_mb"] - base["rss_mb"], 0.0)
    growth = np.log(big["cpu"] / cmp_["cpu"]) / np.log(10.0)
    print(f"compare on 10000 spans: {big['cpu']:.2f} s CPU ({big['cpu'] / rows[-1]['cpu']:.2f}x one schedule), "
          f"peak {big['rss_mb']:.0f} MB, {big_extra / big['ticks'] * 1e6:.0f} MB per 10^6 simulated ticks over "
          f"the anchor; CPU growth 10^3 -> 10^4 spans: exponent {growth:.3f}")
    print()
    print(f"growth_exponent={slope:.3f} peak_mb_per_1e6_ticks={rows[-1]['per_1e6']:.0f} "
          f"compare_over_schedule={cmp_['cpu'] / one['cpu']:.2f} "
          f"command_compare_over_schedule={cmd['compare'] / cmd['schedule']:.2f}")


if __name__ == "__main__":
    main()
