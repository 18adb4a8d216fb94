"""The two input rates of issue 28 on a library of public programs and drawings.

Programs: of the programs LinuxCNC's ``rs274`` accepts (with a tool table T1…T999 of diameter
0.1 mm, as the library's check uses), the share that round-trips: ``fuzzyfeed advise PROGRAM -o
X.csv --gcode OUT.ngc --tool-table TOOLS --tool-units inch`` (the stand-alone rs274 reads tool
tables in inches) exits 0, rs274 accepts OUT.ngc, and OUT's canonical
calls equal the original's except feed rates and split moves (tests/canon.py's comparison: same
rapids, same feed-move geometry within 1 µm, every feed > 0 and at most the programmed one).
Every program that round-trips counts; the summary says how many had a feed lowered, how many were
written back unchanged with the "nothing to advise" notice (only rapids, rotary moves, drilling
cycles) and how many were advised without a feed going down (F already at the 10 mm/min step).

Drawings: of the DXF drawings with path geometry (a LINE, ARC, CIRCLE, ELLIPSE, SPLINE,
LWPOLYLINE or POLYLINE in model space or in a block inserted there, by ezdxf), the share for
which ``fuzzyfeed advise DRAWING -o X.csv`` gives contours (exit 0).

    python benchmarks/bench_inputs.py [--library DIR] [--jobs N] [FILTER]

prints both rates and every file that still fails, with fuzzyfeed's (or rs274's) first line.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import csv
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
DEFAULT_LIBRARY = Path(os.environ.get("FUZZYFEED_LIBRARY", ROOT / "benchmarks" / "library"))
PATH_TYPES = ("LINE", "ARC", "CIRCLE", "ELLIPSE", "SPLINE", "LWPOLYLINE", "POLYLINE")


def _venv_exe(name: str) -> str:
    exe = Path(sys.executable).parent / name
    return str(exe) if exe.exists() else name


def _rs274(program: Path, tools: Path, scratch: Path):
    """(ok, message, canonical calls) of rs274 on ``program``."""
    from canon import _CALL

    scratch.mkdir(parents=True, exist_ok=True)
    out = scratch / "canon.txt"
    try:
        done = subprocess.run(["rs274", "-t", str(tools), "-g", str(program), str(out)],
                              capture_output=True, stdin=subprocess.DEVNULL, timeout=120,
                              cwd=scratch, env={**os.environ, "HOME": str(scratch)})
    except subprocess.TimeoutExpired:
        return False, "rs274: timeout after 120 s", []
    said = [ln.strip() for ln in (done.stdout + done.stderr).decode("utf-8", "replace").splitlines()
            if ln.strip() and ln.strip() != "executing"]
    if done.returncode != 0:
        return False, "rs274: " + (said[0] if said else f"exit {done.returncode}"), []
    calls = []
    for line in out.read_text(errors="replace").splitlines():
        m = _CALL.match(line)
        if m:
            calls.append((m.group(1), m.group(2)))
    return True, "", calls


def _fuzzyfeed(argv: list[str], cwd: Path) -> tuple[int, str, str]:
    try:
        done = subprocess.run([_venv_exe("fuzzyfeed"), *argv], capture_output=True, text=True,
                              stdin=subprocess.DEVNULL, timeout=600, cwd=cwd)
    except subprocess.TimeoutExpired:
        return -1, "", "timeout after 600 s"
    return done.returncode, done.stdout, done.stderr


def check_program(path: Path, tools: Path, scratch: Path) -> dict:
    """The round trip of one program (see the module docstring)."""
    from canon import compare

    ok, msg, original = _rs274(path, tools, scratch / "a")
    if not ok:
        return {"file": path, "kind": "program", "counted": False, "result": msg}
    out_ngc = scratch / ("out" + path.suffix)
    t0 = time.perf_counter()
    code, _, err = _fuzzyfeed(["advise", str(path), "-o", str(scratch / "x.csv"), "--gcode", str(out_ngc),
                               "--tool-table", str(tools), "--tool-units", "inch"], scratch)
    seconds = time.perf_counter() - t0
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if code != 0:
        return {"file": path, "kind": "program", "counted": True, "ok": False, "seconds": seconds,
                "result": lines[-1] if lines else f"exit {code}"}
    ok, msg, rewritten = _rs274(out_ngc, tools, scratch / "b")
    if not ok:
        return {"file": path, "kind": "program", "counted": True, "ok": False, "seconds": seconds,
                "result": "rewritten program refused by " + msg}
    try:
        result = compare(original, rewritten)
    except AssertionError as exc:
        return {"file": path, "kind": "program", "counted": True, "ok": False, "seconds": seconds,
                "result": "canonical calls differ: " + str(exc).splitlines()[0][:160]}
    passed = any("nothing to advise" in ln for ln in lines)
    if passed:
        how = "written back unchanged (nothing to advise)"
    elif result.min_ratio < 1.0:
        how = "advised"
    else:                     # e.g. F10 mm/min: the advice cannot go below one 10 mm/min step
        how = "advised, no feed lowered (the F words are at the feed step)"
    return {"file": path, "kind": "program", "counted": True, "ok": True,
            "seconds": seconds, "result": how, "notices": [ln for ln in lines if "notice" in ln]}


def _has_path_geometry(path: Path) -> bool | None:
    import ezdxf
    from ezdxf import recover

    try:
        doc, _ = recover.readfile(str(path))
    except Exception:                                  # noqa: BLE001 - any unreadable file
        return None
    msp = doc.modelspace()
    if any(e.dxftype() in PATH_TYPES for e in msp):
        return True
    for insert in msp.query("INSERT"):
        block = doc.blocks.get(insert.dxf.name)
        if block is not None and any(e.dxftype() in PATH_TYPES for e in block):
            return True
    del ezdxf
    return False


def check_drawing(path: Path, scratch: Path) -> dict:
    geometry = _has_path_geometry(path)
    if geometry is False:
        return {"file": path, "kind": "drawing", "counted": False, "result": "no path geometry"}
    scratch.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    code, _, err = _fuzzyfeed(["advise", str(path), "-o", str(scratch / "x.csv")], scratch)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    return {"file": path, "kind": "drawing", "counted": True, "ok": code == 0,
            "seconds": time.perf_counter() - t0,
            "result": "contours" if code == 0 else (lines[-1] if lines else f"exit {code}"),
            "notices": [ln for ln in lines if "notice" in ln]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("filter", nargs="?", default="")
    ap.add_argument("--library", type=Path, default=DEFAULT_LIBRARY)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    with open(args.library / "MANIFEST.csv", newline="") as handle:
        rows = [r for r in csv.DictReader(handle) if args.filter in r["file"]]
    work = Path(tempfile.mkdtemp(prefix="bench_inputs_"))
    tools = work / "tools.tbl"
    tools.write_text("".join(f"T{t} P{t} D0.1 Z0 ;\n" for t in range(1, 1000)))
    results = []
    try:
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            futures = []
            for k, row in enumerate(rows):
                path = (args.library / row["file"]).resolve()
                if not path.exists():
                    continue
                scratch = work / str(k)
                if row["kind"] == "program":
                    futures.append(pool.submit(check_program, path, tools, scratch))
                else:
                    futures.append(pool.submit(check_drawing, path, scratch))
            for fut in concurrent.futures.as_completed(futures):
                res = fut.result()
                results.append(res)
                mark = "-" if not res["counted"] else ("ok" if res["ok"] else "FAIL")
                print(f"{mark:4} {res['file'].relative_to(args.library.resolve())}: {res['result'][:150]}",
                      file=sys.stderr)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for kind, what in (("program", "programs rs274 accepts that round-trip with feeds advised"),
                       ("drawing", "drawings with path geometry that give contours")):
        counted = [r for r in results if r["kind"] == kind and r["counted"]]
        good = [r for r in counted if r["ok"]]
        if counted:
            print(f"{kind}s: {len(good)}/{len(counted)} = {100 * len(good) / len(counted):.1f} % of {what}"
                  f" ({sum(not r['counted'] for r in results if r['kind'] == kind)} not counted)")
        if kind == "program" and counted:
            unchanged = sum(r["result"].startswith("written back") for r in good)
            flat = sum(r["result"].startswith("advised, no feed") for r in good)
            print(f"  of which {unchanged} written back unchanged (nothing to advise), {flat} advised "
                  f"with no feed lowered; slowest {max(r['seconds'] for r in counted):.1f} s")
        for r in sorted(counted, key=lambda r: str(r["file"])):
            if not r["ok"]:
                print(f"  FAIL {r['file'].relative_to(args.library.resolve())}: {r['result'][:200]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
