"""Where ``advise PROGRAM --machine M -o m.csv --gcode m.ngc --report r.html`` holds its memory, stage
by stage (issue 36: the ``--report`` peak on many cuts grew ~40 B a line).

Runs the CLI in this process with the stages of
:func:`~fuzzyfeed.program.machine_windows.evaluate_in_windows` (its ``progress`` names), the limit
reference, the report's trace, its table and its HTML wrapped: at the start and end of each it
prints the process's resident memory (``VmRSS``) and the peak since the last mark (``VmHWM``, reset
through ``/proc/self/clear_refs``), glibc's heap (``mallinfo2``: in use / free) and, with
``--trace``, tracemalloc's current and peak traced bytes and (``--top N``) the largest allocation
sites still held at the end of each stage; ``--dump P`` keeps those snapshots (``P_<mark>.pkl``)
and ``--compare SMALL.pkl LARGE.pkl`` (no run) prints what the second holds more than the first
by allocation site (e.g. 250 k / 100 cuts against 1 M / 400 cuts: what grows with the cuts).

    python benchmarks/probe_report_memory.py /tmp/r1m_400.ngc [--trace] [--top 15] [--dump s1m]
    python benchmarks/probe_report_memory.py --compare s250k_end.pkl s1m_end.pkl

The figures are MB; the CLI's own outputs go to a scratch folder (``--out DIR``: kept there).
"""

from __future__ import annotations

import argparse
import ctypes
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path


def _status() -> tuple[int, int]:
    d = {}
    for line in open("/proc/self/status"):
        k, v = line.split(":", 1)
        d[k] = v.strip()
    return int(d["VmRSS"].split()[0]) // 1024, int(d["VmHWM"].split()[0]) // 1024


def _reset_peak() -> None:
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


class _Mallinfo2(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                "fsmblks", "uordblks", "fordblks", "keepcost")]


def _heap() -> tuple[int, int]:
    """glibc's heap: (in use, free) MB, or (-1, -1)."""
    try:
        f = ctypes.CDLL("libc.so.6").mallinfo2
    except (OSError, AttributeError):
        return -1, -1
    f.restype = _Mallinfo2
    m = f()
    return m.uordblks >> 20, m.fordblks >> 20


class Probe:
    def __init__(self, trace: bool, top: int, dump: Path | None = None):
        self.trace, self.top, self.dump = trace, top, dump
        self.t0 = time.perf_counter()
        self.snap = None
        print(f"{'mark':<34}{'t s':>7}{'rss':>6}{'peak':>6}{'heap':>6}{'free':>6}"
              + (f"{'traced':>8}{'tr.peak':>8}" if trace else ""), flush=True)

    def mark(self, name: str, top: bool = False) -> None:
        rss, peak = _status()
        used, free = _heap()
        row = f"{name:<34}{time.perf_counter() - self.t0:7.1f}{rss:6d}{peak:6d}{used:6d}{free:6d}"
        if self.trace:
            cur, tpeak = tracemalloc.get_traced_memory()
            row += f"{cur / 2**20:8.1f}{tpeak / 2**20:8.1f}"
            tracemalloc.reset_peak()
        print(row, flush=True)
        if self.trace and top and (self.top or self.dump):
            snap = tracemalloc.take_snapshot()
            for stat in snap.statistics("lineno")[:self.top]:
                print(f"    {stat.size / 2**20:8.2f} MB {stat.count:8d}  {stat.traceback}", flush=True)
            if self.dump:
                snap.dump(f"{self.dump}_{name.replace(' ', '_')}.pkl")
        _reset_peak()

    def wrap(self, module, name: str, label: str, top: bool = False, describe=None):
        real = getattr(module, name)

        def wrapped(*a, **k):
            self.mark(f"{label} start")
            out = real(*a, **k)
            self.mark(f"{label} end", top)
            if describe is not None:
                print(f"    {describe(out)}", flush=True)
            return out
        setattr(module, name, wrapped)


def _trace_size(tr) -> str:
    """The feed trace's arrays: rows and MB."""
    arrays = {"written steps": tr.feed_mm_min["as written"], "advised steps": tr.feed_mm_min["advised"],
              "segments": tr.advised_fraction, "over": tr.over_s_mm}
    nbytes = sum(a.nbytes for pair in tr.s_mm.values() for a in pair) + sum(a.nbytes for a in tr.feed_mm_min.values())
    nbytes += tr.segments.nbytes + tr.advised_fraction.nbytes + tr.over_s_mm.nbytes + tr.over_xyz.nbytes
    return "trace: " + ", ".join(f"{k} {v.size}" for k, v in arrays.items()) + f"; {nbytes / 2**20:.2f} MB"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("program", type=Path, nargs="?")
    ap.add_argument("--machine", default="reference")
    ap.add_argument("--trace", action="store_true", help="tracemalloc (slow: ~2x)")
    ap.add_argument("--top", type=int, default=0, help="largest allocation sites held after each stage")
    ap.add_argument("--dump", type=Path, help="keep the tracemalloc snapshot of each stage's end in DUMP_<mark>.pkl")
    ap.add_argument("--compare", type=Path, nargs=2, metavar=("SMALL", "LARGE"),
                    help="no run: what LARGE.pkl holds more than SMALL.pkl, by allocation site")
    ap.add_argument("--no-report", action="store_true", help="--machine alone")
    ap.add_argument("--out", type=Path, help="write the CLI's outputs here (kept) instead of a scratch folder")
    ap.add_argument("--save-trace", type=Path, help="keep the value plot's feed trace here (.npz)")
    ap.add_argument("rest", nargs="*")
    args = ap.parse_args(argv)
    if args.compare:
        small, large = (tracemalloc.Snapshot.load(str(p)) for p in args.compare)
        for stat in large.compare_to(small, "lineno")[:max(args.top, 20)]:
            print("   ", stat)
        for stat in large.compare_to(small, "traceback")[:5]:
            print("   ", stat)
            for line in stat.traceback.format():
                print("       ", line)
        return 0
    if args.trace:
        tracemalloc.start(8)
    probe = Probe(args.trace, args.top, args.dump)

    import fuzzyfeed.program.machine_windows as mw
    import fuzzyfeed.program.reference as reference
    import fuzzyfeed.report.value as value
    import fuzzyfeed.report.value_files as value_files
    import fuzzyfeed.report.value_trace as value_trace

    real_eval = mw.evaluate_in_windows

    def evaluate(*a, **k):
        outer = k.get("progress")

        def step(stage: str) -> None:
            probe.mark(f"stage {stage}", top=True)
            if outer:
                outer(stage)
        k["progress"] = step
        out = real_eval(*a, **k)
        probe.mark("evaluate end", top=True)
        return out
    mw.evaluate_in_windows = evaluate
    probe.wrap(reference, "limit_reference", "limit reference")
    def describe(tr):
        if args.save_trace:
            import numpy as np

            np.savez(args.save_trace, ws=tr.s_mm["as written"][0], we=tr.s_mm["as written"][1],
                     wf=tr.feed_mm_min["as written"], as_=tr.s_mm["advised"][0], ae=tr.s_mm["advised"][1],
                     af=tr.feed_mm_min["advised"], segments=tr.segments, fraction=tr.advised_fraction,
                     over_s=tr.over_s_mm, over_xyz=tr.over_xyz)
        return _trace_size(tr)
    probe.wrap(value_trace, "feed_trace", "feed trace", describe=describe)
    probe.wrap(value, "windowed_report", "windowed report")
    probe.wrap(value_files, "write_value_report", "write report")

    from fuzzyfeed.cli import main as cli

    with tempfile.TemporaryDirectory(prefix="probe-report-") as out:
        o = Path(out) if args.out is None else args.out
        o.mkdir(parents=True, exist_ok=True)
        argv = ["advise", str(args.program), "--machine", args.machine, "-o", str(o / "m.csv"),
                "--gcode", str(o / "m.ngc"), *([] if args.no_report else ["--report", str(o / "r.html")]),
                *args.rest]
        probe.mark("start")
        rc = cli(argv)
        probe.mark("end", top=True)
    return rc


if __name__ == "__main__":
    sys.exit(main())
