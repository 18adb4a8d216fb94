"""Cost of the advice on a machine against the plain advice: CPU and peak memory, per program.

    python benchmarks/bench_machine_advice.py [--set library tiger raster] [--tiger PATH ...]
        [--raster-lines 1000000 ...] [--modes plain machine report] [--timeout 600] [--mem-gb 8]
        [--every 1] [--before DIR --modes plain machine before] [--gcode]

For every program three commands, each one child process:

- plain:   ``fuzzyfeed advise P -o x.csv``
- machine: ``fuzzyfeed advise P -o x.csv --machine reference``
- report:  ``fuzzyfeed advise P -o x.csv --machine reference --report r.html``
- before (only if asked): the machine command with ``PYTHONPATH=DIR`` (``--before DIR``, another
  checkout: the code before a change), its ratios to plain and of machine to it

(each with ``--gcode y.ngc`` too when ``--gcode`` is given).

CPU s = the child's user + system time, peak RSS = its ru_maxrss (``os.wait4``). A run past
``--timeout`` s is killed and reported as ``timeout`` (its ratio a lower bound, ``>=``); the child's
address space is capped at ``--mem-gb`` (``RLIMIT_AS``) and a run that breaks the cap is reported as
``memory cap``. Sets: ``library`` = every program of benchmarks/library the library's MANIFEST says
fuzzyfeed reads (``--every N``: every N-th of them, by size); ``tiger`` = the paths given with
``--tiger`` (camotics examples/tiger/tiger.nc, 67 426 lines: ``git show
HEAD:examples/tiger/tiger.nc`` in github.com/CauldronDevelopmentLLC/CAMotics; GPL-2.0-or-later, not
committed here); ``raster`` = the 3D finishing raster of benchmarks/make_raster.py at each
``--raster-lines`` (one cut), written to a temporary folder. One line per program, then the summary
``machine_over_plain_median=... report_over_plain_median=... largest_machine_over_plain=...
peak_rss_mb_max=...`` (medians over the library; ``largest``: the program with the most lines;
peak RSS over every run of the plain advice and, as ``peak_rss_mb_max_all``, of every run).
"""

from __future__ import annotations

import argparse
import csv
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
LIBRARY = HERE / "library"
MODES = ("plain", "machine", "report", "before")


def run_child(cmd: list[str], timeout_s: float, mem_bytes: int, env: dict | None = None) -> dict:
    """Run ``cmd``; its CPU s, peak RSS MB and status (ok, timeout, memory cap, error N)."""
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (mem_bytes, mem_bytes))

    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err, preexec_fn=limit,
                                start_new_session=True, env=env)
        start = time.monotonic()
        status = "ok"
        while True:
            pid, code, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - start > timeout_s:
                os.killpg(proc.pid, signal.SIGKILL)
                _, code, usage = os.wait4(proc.pid, 0)
                status = "timeout"
                break
            time.sleep(0.05)
        proc.returncode = os.waitstatus_to_exitcode(code)
        err.seek(0)
        text = err.read().decode(errors="replace")
    if status == "ok" and proc.returncode != 0:
        status = "memory cap" if "MemoryError" in text or "std::bad_alloc" in text or proc.returncode == -9 \
            else f"error {proc.returncode}: {text.strip().splitlines()[-1][:120] if text.strip() else ''}"
    return {"cpu": usage.ru_utime + usage.ru_stime, "rss_mb": usage.ru_maxrss / 1024.0, "status": status,
            "wall": time.monotonic() - start}


def library_programs(every: int) -> list[Path]:
    with open(LIBRARY / "MANIFEST.csv", newline="") as handle:
        rows = [r for r in csv.DictReader(handle) if r["kind"] == "program" and r["fuzzyfeed_reads"] == "ok"]
    rows.sort(key=lambda r: int(r["bytes"]))
    return [LIBRARY / r["file"] for r in rows][::every]


def count_lines(path: Path) -> int:
    with open(path, "rb") as handle:
        return sum(chunk.count(b"\n") for chunk in iter(lambda: handle.read(1 << 20), b""))


def command(program: Path, mode: str, out: Path, gcode: bool = False) -> list[str]:
    cmd = [sys.executable, "-m", "fuzzyfeed", "advise", str(program), "-o", str(out / "x.csv")]
    if gcode:
        cmd += ["--gcode", str(out / "y.ngc")]
    if mode in ("machine", "report", "before"):
        cmd += ["--machine", "reference"]
    if mode == "report":
        cmd += ["--report", str(out / "r.html")]
    return cmd


def fmt(r: dict | None) -> str:
    if r is None:
        return "-"
    text = f"{r['cpu']:7.1f} s {r['rss_mb']:6.0f} MB"
    return text if r["status"] == "ok" else f"{text} [{r['status']}]"


def ratio(r: dict | None, base: dict | None) -> tuple[float, bool] | None:
    """(CPU ratio, censored): a run that timed out or hit the cap gives a lower bound."""
    if r is None or base is None or base["status"] != "ok" or base["cpu"] <= 0:
        return None
    if r["status"] == "ok":
        return r["cpu"] / base["cpu"], False
    if r["status"] in ("timeout", "memory cap"):
        return r["cpu"] / base["cpu"], True
    return None


def median(values: list[tuple[float, bool]]) -> str:
    """Median; censored values (lower bounds) sort as their bound; the median is a bound (>=) when
    a censored value is at or below it."""
    if not values:
        return "nan"
    vals = sorted(values, key=lambda v: (v[0], v[1]))
    mid = vals[(len(vals) - 1) // 2]
    bound = any(c for v, c in vals[:(len(vals) - 1) // 2 + 1])
    return (">=" if bound else "") + f"{mid[0]:.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--set", nargs="+", choices=("library", "tiger", "raster"),
                        default=["library", "tiger", "raster"])
    parser.add_argument("--tiger", nargs="*", default=[], metavar="PATH", help="tiger-sized programs")
    parser.add_argument("--raster-lines", nargs="*", type=int, default=[1_000_000])
    parser.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES[:3]))
    parser.add_argument("--before", metavar="DIR", default=None,
                        help="mode 'before': the machine advice with PYTHONPATH=DIR (another checkout, "
                             "e.g. /work/main), its ratio to plain and to 'machine' printed")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per run (default: 600)")
    parser.add_argument("--mem-gb", type=float, default=8.0, help="address-space cap per run (default: 8)")
    parser.add_argument("--every", type=int, default=1, help="library: every N-th program by size")
    parser.add_argument("--gcode", action="store_true", help="every command also writes the advised program "
                        "(--gcode y.ngc)")
    args = parser.parse_args()
    mem = int(args.mem_gb * 2**30)
    results = []
    with tempfile.TemporaryDirectory(prefix="ff_bench_machine_") as tmp:
        tmp = Path(tmp)
        programs: list[tuple[str, Path]] = []
        if "library" in args.set:
            programs += [("library", p) for p in library_programs(max(1, args.every))]
        if "tiger" in args.set:
            programs += [("tiger", Path(p)) for p in args.tiger]
        if "raster" in args.set:
            spec = __import__("importlib.util").util.spec_from_file_location("make_raster", HERE / "make_raster.py")
            mod = __import__("importlib.util").util.module_from_spec(spec)
            spec.loader.exec_module(mod)
            for n in args.raster_lines:
                path = tmp / f"raster_{n}.ngc"
                with open(path, "w", newline="\n") as handle:
                    mod.write_raster(handle, n, 1, 1)
                programs.append(("raster", path))
        print(f"{len(programs)} programs; modes {' '.join(args.modes)}; timeout {args.timeout:g} s, "
              f"address space cap {args.mem_gb:g} GB; python {sys.executable}", flush=True)
        for group, path in programs:
            lines = count_lines(path)
            row = {"group": group, "name": path.name, "lines": lines}
            for mode in args.modes:
                env = None
                if mode == "before":
                    if not args.before:
                        parser.error("mode 'before' needs --before DIR")
                    env = dict(os.environ, PYTHONPATH=args.before)
                row[mode] = run_child(command(path, mode, tmp, args.gcode), args.timeout, mem, env)
            results.append(row)
            rm = ratio(row.get("machine"), row.get("plain"))
            rr = ratio(row.get("report"), row.get("plain"))
            show = lambda r: "-" if r is None else (">=" if r[1] else "") + f"{r[0]:.2f}"
            print(f"{group:8s} {path.name[:34]:34s} {lines:8d} lines | plain {fmt(row.get('plain'))} | "
                  f"machine {fmt(row.get('machine'))} x{show(rm)} | report {fmt(row.get('report'))} "
                  f"x{show(rr)}" + (f" | before {fmt(row.get('before'))} x{show(ratio(row['before'], row.get('plain')))}"
                                    f", machine/before x{show(ratio(row.get('machine'), row['before']))}"
                                    if row.get("before") else ""), flush=True)
    lib = [r for r in results if r["group"] == "library"]
    mo = [x for x in (ratio(r.get("machine"), r.get("plain")) for r in lib) if x is not None]
    ro = [x for x in (ratio(r.get("report"), r.get("plain")) for r in lib) if x is not None]
    largest = max(results, key=lambda r: r["lines"]) if results else None
    lm = ratio(largest.get("machine"), largest.get("plain")) if largest else None
    plain_rss = [r["plain"]["rss_mb"] for r in results if r.get("plain") and r["plain"]["status"] == "ok"]
    all_rss = [r[m]["rss_mb"] for r in results for m in args.modes if r.get(m)]
    print(f"machine_over_plain_median={median(mo)} report_over_plain_median={median(ro)} "
          f"largest_machine_over_plain={'nan' if lm is None else ('>=' if lm[1] else '') + format(lm[0], '.2f')}"
          f" peak_rss_mb_max={max(plain_rss, default=float('nan')):.0f}"
          f" peak_rss_mb_max_all={max(all_rss, default=float('nan')):.0f}"
          + (f" (largest: {largest['name']}, {largest['lines']} lines)" if largest else ""))


if __name__ == "__main__":
    main()
