#!/usr/bin/env python3
"""Re-run the checks of benchmarks/library over its MANIFEST.csv and print a summary.

For every program (kind=program):
  * rs274: LinuxCNC's stand-alone interpreter, `rs274 -g -t TOOL.TBL FILE OUT`
    with stdin from /dev/null and a 60 s timeout.  The program is accepted when
    rs274 exits with status 0 (its error messages go to stdout, after the line
    "executing"; they rarely contain the word "error", so the exit status is the
    test, and the first message line is reported).  The tool table, T1..T999, all
    of diameter 0.1 and length 0, is written to a temporary directory (a small
    diameter, so that cutter-compensation entry checks do not reject programs
    written for tools other than a guessed one).
  * fuzzyfeed: `fuzzyfeed advise FILE -o /tmp/.../x.csv` run from the project
    root with a 120 s timeout: "ok" on exit status 0, else the last line of stderr.
For every drawing (kind=drawing):
  * fuzzyfeed as above, and ezdxf.readfile() in the project's venv.

Usage (from the repository root or anywhere):
    python3 benchmarks/library/check_library.py [--jobs N] [--only program|drawing]
                                                [--update] [--venv PATH] [FILTER]
FILTER keeps the MANIFEST rows whose file contains it.  --summary-only prints the
summary of the results stored in the MANIFEST without running anything.  --update rewrites the
rs274_ok / fuzzyfeed_reads columns (and the ezdxf note of drawings) of MANIFEST.csv
with the new results; without it the MANIFEST is only compared with them.
Standard library only; the checks themselves are subprocess calls.
"""
import argparse
import collections
import concurrent.futures
import csv
import os
import re
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
MANIFEST = os.path.join(HERE, "MANIFEST.csv")
FIELDS = ["kind", "file", "repo", "repo_path", "commit", "licence", "generator",
          "units", "lines", "bytes", "rs274_ok", "fuzzyfeed_reads", "notes"]
RS274 = shutil.which("rs274") or "/usr/bin/rs274"


def make_tool_table(directory):
    path = os.path.join(directory, "tool.tbl")
    with open(path, "w") as f:
        for t in range(1, 1000):
            f.write(f"T{t} P{t} D0.1 Z0 ;\n")
    return path


def _rs274(path, tool_table, workdir):
    """Run rs274 once in its own scratch directory; return (returncode, messages)."""
    scratch = tempfile.mkdtemp(dir=workdir)
    out = os.path.join(scratch, "canon.txt")
    try:
        with open(os.devnull) as devnull:
            p = subprocess.run([RS274, "-g", "-t", tool_table, path, out], stdin=devnull,
                               capture_output=True, timeout=60, cwd=scratch)
    except subprocess.TimeoutExpired:
        return None, ["rs274: timeout after 60 s"]
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    text = p.stdout.decode("utf-8", "replace") + p.stderr.decode("utf-8", "replace")
    return p.returncode, [l.strip() for l in text.splitlines() if l.strip() and l.strip() != "executing"]


NO_END = "File ended with no percent sign or program end"


def check_rs274(path, tool_table, workdir):
    """Return (ok: bool, message: str).  Accepted: exit status 0 and no message
    line containing "error".  A run killed by a signal is retried once."""
    rc, msgs = _rs274(path, tool_table, workdir)
    if rc is not None and rc < 0:
        rc, msgs = _rs274(path, tool_table, workdir)
    if rc == 0 and not any("error" in l.lower() for l in msgs):
        return True, ""
    first = msgs[0] if msgs else f"exit status {rc}"
    at = f" [at: {msgs[1][:80]}]" if len(msgs) > 1 else ""  # rs274 prints the message, then the block
    if msgs and msgs[0].startswith(NO_END):
        # say whether the missing program end is the only complaint
        with tempfile.NamedTemporaryFile("wb", suffix=os.path.splitext(path)[1], dir=workdir,
                                         delete=False) as tmp:
            with open(path, "rb") as f:
                tmp.write(f.read().rstrip(b"%\r\n\t ") + b"\nM2\n")
        rc2, msgs2 = _rs274(tmp.name, tool_table, workdir)
        os.remove(tmp.name)
        if rc2 == 0:
            first += " (accepted with M2 appended)"
        elif msgs2:
            first += f" (with M2 appended: {msgs2[0][:80]})"
    return False, first + at


def check_fuzzyfeed(path, venv, workdir):
    exe = os.path.join(venv, "bin", "fuzzyfeed")
    out = os.path.join(workdir, "ff_" + re.sub(r"\W", "_", os.path.basename(path)) + ".csv")
    try:
        rel = os.path.relpath(path, ROOT)  # messages then name the file relative to the repository
        p = subprocess.run([exe, "advise", rel, "-o", out], cwd=ROOT, capture_output=True,
                           timeout=120, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return "timeout after 120 s"
    finally:
        if os.path.exists(out):
            os.remove(out)
    if p.returncode == 0:
        return "ok"
    lines = [l.strip() for l in p.stderr.decode("utf-8", "replace").splitlines() if l.strip()]
    if not lines:
        lines = [l.strip() for l in p.stdout.decode("utf-8", "replace").splitlines() if l.strip()]
    return (lines[-1] if lines else f"exit status {p.returncode}").replace("\n", " ")


def check_ezdxf(path, venv):
    py = os.path.join(venv, "bin", "python")
    code = "import ezdxf,sys; ezdxf.readfile(sys.argv[1])"
    try:
        p = subprocess.run([py, "-c", code, path], capture_output=True, timeout=120)
    except subprocess.TimeoutExpired:
        return "timeout"
    if p.returncode == 0:
        return "ok"
    lines = [l.strip() for l in p.stderr.decode("utf-8", "replace").splitlines() if l.strip()]
    return lines[-1] if lines else f"exit status {p.returncode}"


EZ_NOTE = re.compile(r"ezdxf: [^;]*")


def run_row(row, tool_table, venv, workdir):
    path = os.path.join(HERE, row["file"])
    res = {"file": row["file"], "kind": row["kind"]}
    if row["kind"] == "program":
        ok, msg = check_rs274(path, tool_table, workdir)
        res["rs274_ok"] = "yes" if ok else "no"
        res["rs274_msg"] = msg
    else:
        res["rs274_ok"] = "n/a"
        res["ezdxf"] = check_ezdxf(path, venv)
    res["fuzzyfeed_reads"] = check_fuzzyfeed(path, venv, workdir)
    return res


def normalise(msg):
    """Group refusal messages: file name, DXF handles, numbers and quoted text replaced."""
    m = re.sub(r"^fuzzyfeed: error: ", "", msg)
    m = re.sub(r"\S*benchmarks/library/.*?\.(ngc|nc|gcode|gc|tap|cnc|dxf)(:\d+)?:\s*", "FILE: ", m, flags=re.I)
    m = re.sub(r"\b(LINE|ARC|CIRCLE|ELLIPSE|SPLINE|LWPOLYLINE|POLYLINE) [0-9A-F]+\b", "ENTITY <h>", m)
    m = re.sub(r"\bINSERT [0-9A-F]+\b", "INSERT <h>", m)
    m = re.sub(r"\((block|layer) [^)]*\)", r"(\1 …)", m)
    m = re.sub(r"'[^']*'|\"[^\"]*\"", "'…'", m)
    m = re.sub(r"(?<![A-Za-z0-9.])[-+]?\d+(\.\d+)?(e[-+]?\d+)?", "N", m)
    return m


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("filter", nargs="?", default="")
    ap.add_argument("--jobs", type=int, default=max(1, (os.cpu_count() or 2)))
    ap.add_argument("--only", choices=["program", "drawing"])
    ap.add_argument("--update", action="store_true")
    ap.add_argument("--venv", default=os.path.join(ROOT, ".venv"))
    ap.add_argument("--summary-only", action="store_true",
                    help="print the summary of the results stored in MANIFEST.csv; run nothing")
    args = ap.parse_args()

    with open(MANIFEST, newline="") as f:
        rows = list(csv.DictReader(f))
    todo = [r for r in rows if args.filter in r["file"] and (not args.only or r["kind"] == args.only)]
    results = {}
    if args.summary_only:
        for r in todo:
            notes = dict((n.split(":", 1)[0].strip(), n.split(":", 1)[1].strip())
                         for n in r["notes"].split("; ") if n.startswith(("rs274:", "ezdxf:")))
            results[r["file"]] = {"file": r["file"], "kind": r["kind"], "rs274_ok": r["rs274_ok"],
                                  "rs274_msg": notes.get("rs274", ""), "ezdxf": notes.get("ezdxf", ""),
                                  "fuzzyfeed_reads": r["fuzzyfeed_reads"]}
        todo_run = []
    else:
        todo_run = todo
    workdir = tempfile.mkdtemp(prefix="fflib_")
    tool_table = make_tool_table(workdir)
    try:
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as ex:
            futs = {ex.submit(run_row, r, tool_table, args.venv, workdir): r for r in todo_run}
            for i, fut in enumerate(concurrent.futures.as_completed(futs), 1):
                res = fut.result()
                results[res["file"]] = res
                print(f"[{i}/{len(todo_run)}] {res['file']}: rs274={res['rs274_ok']} fuzzyfeed={res['fuzzyfeed_reads'][:90]}",
                      file=sys.stderr)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)

    # ---- summary
    progs = [r for r in todo if r["kind"] == "program"]
    draws = [r for r in todo if r["kind"] == "drawing"]
    print(f"\n{len(progs)} programs, {len(draws)} drawings, "
          f"{len({r['repo'] for r in todo})} repositories, "
          f"{len({r['generator'] for r in progs})} program generators")
    print("\nPrograms per generator (rs274 yes / fuzzyfeed ok / files):")
    by_gen = collections.defaultdict(list)
    for r in progs:
        by_gen[r["generator"]].append(results[r["file"]])
    for gen, lst in sorted(by_gen.items(), key=lambda kv: (-len(kv[1]), kv[0])):
        rs = sum(x["rs274_ok"] == "yes" for x in lst)
        ff = sum(x["fuzzyfeed_reads"] == "ok" for x in lst)
        print(f"  {rs:3d} / {ff:3d} / {len(lst):3d}  {gen}")
    if progs:
        rs = sum(results[r["file"]]["rs274_ok"] == "yes" for r in progs)
        ff = sum(results[r["file"]]["fuzzyfeed_reads"] == "ok" for r in progs)
        print(f"\nrs274 accepts {rs}/{len(progs)} programs ({100*rs/len(progs):.0f} %)")
        print(f"fuzzyfeed reads {ff}/{len(progs)} programs ({100*ff/len(progs):.0f} %)")
    if draws:
        ez = sum(results[r["file"]]["ezdxf"] == "ok" for r in draws)
        ff = sum(results[r["file"]]["fuzzyfeed_reads"] == "ok" for r in draws)
        print(f"ezdxf.readfile opens {ez}/{len(draws)} drawings; "
              f"fuzzyfeed reads {ff}/{len(draws)} drawings ({100*ff/len(draws):.0f} %)")
    refusals = collections.Counter()
    examples = {}
    for res in results.values():
        if res["fuzzyfeed_reads"] != "ok":
            key = (res["kind"], normalise(res["fuzzyfeed_reads"]))
            refusals[key] += 1
            examples.setdefault(key, res["fuzzyfeed_reads"])
    if refusals:
        print("\nfuzzyfeed refusals (kind, count, message pattern; e.g.):")
        for (kind, pat), n in refusals.most_common():
            print(f"  {kind:8s} {n:3d}  {pat}\n               e.g. {examples[(kind, pat)][:160]}")
    rsfail = collections.Counter(normalise(results[r['file']].get("rs274_msg", "")).split(" [at:")[0]
                                 for r in progs if results[r["file"]]["rs274_ok"] == "no")
    if rsfail:
        print("\nrs274 rejections:")
        for m, n in rsfail.most_common():
            print(f"  {n:3d}  {m}")

    # ---- compare with / update the MANIFEST
    changed = 0
    for r in rows:
        res = results.get(r["file"])
        if not res:
            continue
        new_ff = res["fuzzyfeed_reads"]
        new_rs = res["rs274_ok"]
        if r["fuzzyfeed_reads"] != new_ff or r["rs274_ok"] != new_rs:
            changed += 1
            if not args.update:
                print(f"  differs from MANIFEST: {r['file']}: rs274 {r['rs274_ok']} -> {new_rs}; "
                      f"fuzzyfeed {r['fuzzyfeed_reads'][:60]} -> {new_ff[:60]}")
        if args.update:
            r["rs274_ok"], r["fuzzyfeed_reads"] = new_rs, new_ff
            notes = [n.strip() for n in r["notes"].split(";") if n.strip()]
            notes = [n for n in notes if not n.startswith(("rs274:", "ezdxf:"))]
            if r["kind"] == "program" and new_rs == "no":
                notes.append("rs274: " + res["rs274_msg"].replace(";", ","))
            if r["kind"] == "drawing":
                notes.append("ezdxf: " + res["ezdxf"].replace(";", ","))
            r["notes"] = "; ".join(notes)
    if args.summary_only:
        return
    print(f"\n{changed} row(s) differ from MANIFEST.csv" + (" (updated)" if args.update else ""))
    if args.update:
        with open(MANIFEST, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=FIELDS)
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
