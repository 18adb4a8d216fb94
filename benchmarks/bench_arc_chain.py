"""The chord-exact interpolator's whole inversion u(s), unchained and chained (issue 38, cpu9), on a program
cut's own servo ticks: CPU of each in one process and |s(u) − s| read back through the arc-length table.

Run: PYTHONPATH=<tree> python benchmarks/bench_arc_chain.py PROGRAM TICKS.npz [CHAIN ...]
(PROGRAM as bench_slw prints it, cut #1; TICKS.npz a bench_slw_case.py output whose s are the ticks).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_slw import LIBRARY  # noqa: E402


def main() -> None:
    from fuzzyfeed.geometry.polyline_fit import fit_polyline
    from fuzzyfeed.io.shapes import load_shapes
    from fuzzyfeed.slw.warm import warm_kernels

    prog, ticks = sys.argv[1], sys.argv[2]
    chains = [float(x) for x in sys.argv[3:]] or [0.05]
    curve = load_shapes(LIBRARY / prog)[0].curve
    if curve.degree == 1:               # the scheduler's blended fit (schedule(blend=True))
        curve = fit_polyline(curve, None).curve
    s = np.load(ticks)["s"]
    warm_kernels()
    total = curve.length
    print(f"{prog}: {s.size} ticks, L {total:.6g} mm, {curve.arc_table.breaks.size - 1} table intervals, "
          f"Newton tolerance {1e-14 * max(total, 1.0):.3g} mm")
    every = slice(None, None, 7)        # s(u) read back at every 7th tick (GL8 from the interval's start)
    t0 = time.process_time()
    exact = curve.param_at_length(s)
    print(f"unchained cpu {time.process_time() - t0:.2f} s  max |s(u) - s| "
          f"{np.abs(curve.arc_length(exact[every]) - s[every]).max():.3g} mm")
    for chain in chains:
        t0 = time.process_time()
        u = curve.param_at_length(s, chain=chain)
        cpu = time.process_time() - t0
        print(f"chain {chain:g} cpu {cpu:.2f} s  max |s(u) - s| {np.abs(curve.arc_length(u[every]) - s[every]).max():.3g} mm"
              f"  max |u - u_unchained| {np.abs(u - exact).max():.3g}")


if __name__ == "__main__":
    main()
