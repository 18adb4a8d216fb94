"""``fuzzyfeed batch`` / ``fuzzyfeed.advise_library``: a generated library (good, refused and corrupt files,
programs and drawings in sub-folders) advised on a real Dask LocalCluster of worker processes.
Every result is compared byte for byte with what the single-file command ``fuzzyfeed advise``
writes; a worker is killed mid-run (nothing lost, nothing written twice); a rerun keeps what is
unchanged; Ctrl-C (SIGINT to the process group, as a terminal sends it) keeps the finished files."""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pandas as pd
import pytest

import fuzzyfeed
from fuzzyfeed.cli import main

CORPUS = Path(__file__).resolve().parent / "programs" / "corpus"
FUZZYFEED = [sys.executable, "-m", "fuzzyfeed"]
QUIET = {"progress": False, "echo": lambda line: None}

GENERATED = """(a generated part: pocket and chamfer)
G21 G90 G94 G17
G0 Z5
G0 X0 Y0
G1 Z-1 F200
G1 X40 F1200
G2 X50 Y10 I0 J10
G1 Y30
G3 X40 Y40 I-10 J0
G1 X0
G1 Y0
G0 Z5
G0 X60 Y0
G1 Z-1 F200
G1 X70 Y3 F900
G1 X80 Y0
G1 X90 Y3
G1 X100 Y0
G0 Z5
M2
"""


def write_dxf(path: Path, contours: int) -> None:
    import ezdxf

    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_circle((0, 0), 20)
    if contours > 1:
        msp.add_lwpolyline([(30, 0), (80, 0), (80, 30, 0, 0, 0.4), (30, 30)], close=True)
    doc.saveas(path)


@pytest.fixture(scope="module")
def library(tmp_path_factory) -> Path:
    """Programs in sub-folders (.ngc, .NC, .tap, .gcode), two drawings, two refused programs, four
    corrupt files and two files that are neither."""
    lib = tmp_path_factory.mktemp("shop") / "library"
    for rel, name in (("jobA/part.ngc", "freecad_00"), ("jobA/rev2/part.ngc", "freecad_01"),
                      ("jobB/pocket.NC", "fusion_03"), ("jobB/helix.tap", "lcnc_05"),
                      ("jobC/grbl.ngc", "grbl_02")):
        (lib / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(CORPUS / f"{name}.ngc", lib / rel)
    (lib / "jobC" / "generated.gcode").write_text(GENERATED)
    (lib / "jobD").mkdir()
    write_dxf(lib / "jobD" / "plate.dxf", 2)
    write_dxf(lib / "jobD" / "ring.dxf", 1)
    (lib / "refused").mkdir()
    (lib / "refused" / "sub.ngc").write_text("G21\no100 call\nG1 X1 F100\nM2\n")
    (lib / "refused" / "comp.ngc").write_text("G21\nG0 X0 Y0\nG41.1\nG1 X10 F100\nM2\n")
    (lib / "corrupt").mkdir()
    (lib / "corrupt" / "garbage.nc").write_bytes(bytes(range(256)) * 8)
    (lib / "corrupt" / "empty.ngc").write_text("")
    (lib / "corrupt" / "latin1.ngc").write_bytes("G21\n(\xe9bauche)\nG0 X0 Y0\nG1 X10 F100 Y\xff\n".encode("latin-1"))
    text = (lib / "jobD" / "plate.dxf").read_text()
    (lib / "corrupt" / "cut.dxf").write_text(text[: len(text) // 3])
    (lib / "jobA" / "notes.txt").write_text("not a program")
    (lib / "jobA" / "photo.png").write_bytes(b"\x89PNG")
    return lib


@pytest.fixture(scope="module")
def cluster():
    """A real local Dask cluster: two worker processes, one thread each."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as lc, \
            Client(lc, set_as_default=False) as client:
        client.wait_for_workers(2)
        yield lc, client


def advise_cli(argv: list[str]) -> tuple[int, str]:
    """The single-file command, as the console script runs it (exit code, stderr)."""
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, err.getvalue()


def reference(library: Path, ref: Path, rel: str, program_words: list[str], drawing_words: list[str],
              plots: bool = False) -> tuple[int, str, list[Path]]:
    """``fuzzyfeed advise`` on one file with the outputs a user would name for it (same base names
    as the batch's, so the CSV sidecar's url is the same)."""
    src = library / rel
    base = ref / rel
    base.parent.mkdir(parents=True, exist_ok=True)
    argv = ["advise", str(src), "-o", f"{base}.csv"]
    files = [Path(f"{base}.csv"), Path(f"{base}.csv-metadata.json")]
    if src.suffix.lower() == ".dxf":
        argv += drawing_words
    else:
        argv += ["--gcode", str(base)] + (["--plot", f"{base}.png"] if plots else []) + program_words
        files += [base] + ([Path(f"{base}.png")] if plots else [])
    code, err = advise_cli(argv)
    return code, err, files


EXPECTED_OK = {"jobA/part.ngc", "jobA/rev2/part.ngc", "jobB/pocket.NC", "jobB/helix.tap", "jobC/grbl.ngc",
               "jobC/generated.gcode", "jobD/plate.dxf", "jobD/ring.dxf"}
EXPECTED_REFUSED = {"refused/sub.ngc", "refused/comp.ngc", "corrupt/garbage.nc", "corrupt/empty.ngc",
                    "corrupt/latin1.ngc", "corrupt/cut.dxf"}


def files_under(folder: Path) -> dict[str, tuple[int, int]]:
    """Every file below ``folder``: relative path -> (inode, mtime_ns)."""
    out = {}
    for path in folder.rglob("*"):
        if path.is_file():
            st = path.stat()
            out[str(path.relative_to(folder))] = (st.st_ino, st.st_mtime_ns)
    return out


def test_results_are_the_single_file_commands_bytes(library, cluster, tmp_path):
    lc, _ = cluster
    out = tmp_path / "results"
    frame = fuzzyfeed.advise_library([library], out, scheduler=lc.scheduler_address,
                            feed_step_mm_min=50, step_mm=0.5, points=500, **QUIET)
    assert isinstance(frame, pd.DataFrame)
    assert set(frame["file"]) == EXPECTED_OK | EXPECTED_REFUSED          # .txt and .png are not inputs
    assert frame["file"].is_unique
    status = dict(zip(frame["file"], frame["status"]))
    assert {f for f, s in status.items() if s == "ok"} == EXPECTED_OK
    assert {f for f, s in status.items() if s == "refused"} == EXPECTED_REFUSED
    # the summary on disk is the frame
    on_disk = pd.read_csv(out / "summary.csv", keep_default_na=False)
    assert list(on_disk["file"]) == list(frame["file"])
    assert "<img" in (out / "summary.html").read_text()
    ref = tmp_path / "ref"
    for row in frame.itertuples():
        code, err, files = reference(library, ref, row.file, ["--feed-step-mm-min", "50", "--step-mm", "0.5"],
                                     ["--points", "500"])
        if row.status == "ok":
            assert code == 0, err
            for expected in files:
                mine = out / expected.relative_to(ref)
                assert mine.read_bytes() == expected.read_bytes(), mine
            assert row.cuts >= 1 and row.time_written_s > 0 and row.time_advised_s > 0
            assert 0 < row.feed_pct_min <= row.feed_pct_mean <= 100
            assert row.time_saved_s == pytest.approx(row.time_written_s - row.time_advised_s)
        else:   # the same one line the command prints, and no result at all
            assert code == 2
            assert f"fuzzyfeed: error: {row.reason}" in err.splitlines()
            assert not any((out / f.relative_to(ref)).exists() for f in files)
    # a drawing with two contours: both in its CSV, as one advise command writes them
    plate = frame.set_index("file").loc["jobD/plate.dxf"]
    assert plate.cuts == 2 and not (out / "jobD" / "plate.dxf").exists()
    # nothing beside the inputs, nothing but the results under RESULTS_DIR
    assert sorted(p.name for p in (library / "jobA").iterdir()) == ["notes.txt", "part.ngc", "photo.png", "rev2"]
    assert not list(out.rglob("*.part"))


def test_plots_and_value_reports_on_a_machine_are_the_commands(library, cluster, tmp_path):
    """With a machine (made in Python as the flags make it) and --plots --reports html: the value
    report, the plot and the program advised for the machine are advise's bytes; the summary
    carries the report's row."""
    lc, _ = cluster
    out = tmp_path / "results"
    machine = fuzzyfeed.Machine(contour_tol_um=50, axis_acc_mm_s2=(1000, 800, 500),
                                servo=fuzzyfeed.ServoModel(kv_1_s=30), corner_mm=0.01)
    options = fuzzyfeed.AdviceOptions(machine=machine, reference=False)
    frame = fuzzyfeed.advise_library([str(library / "jobC" / "*.gcode")], out, options, scheduler=lc.scheduler_address,
                                     plots=True, reports="html", **QUIET)
    assert list(frame["file"]) == ["generated.gcode"] and frame["status"].tolist() == ["ok"]
    words = ["--contour-tol-um", "50", "--axis-acc-mm-s2", "1000,800,500", "--servo-kv-1-s", "30",
             "--junction-deviation-mm", "0.01", "--no-reference"]
    ref = tmp_path / "ref"
    ref.mkdir()
    base = str(ref / "generated.gcode")
    code, err = advise_cli(["advise", str(library / "jobC" / "generated.gcode"), "-o", base + ".csv", "--gcode",
                            base, "--plot", base + ".png", "--report", base + ".report.html", *words])
    assert code == 0, err
    names = sorted(p.name for p in ref.iterdir())
    assert names == ["generated.gcode", "generated.gcode.csv", "generated.gcode.csv-metadata.json",
                     "generated.gcode.png", "generated.gcode.report.html"]
    for name in names:
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name
    row = frame.iloc[0]
    assert row.contour_tol_um == 50 and row.machine == "reference"
    assert row.written_max_um > 0 and row.advised_max_um > 0 and row.time_written_s > 0
    assert "written_max_um" in (out / "summary.csv").read_text().splitlines()[0]
    assert (out / "summary.html").read_text().count("<img") == 3     # time, max and p99 error


def test_the_console_command(library, cluster, tmp_path):
    """As a user types it, from the library's parent folder (relative paths): exit code 1 because
    some files were refused, 0 on a library of good files; the dashboard address printed."""
    lc, _ = cluster
    cwd = library.parent
    run = subprocess.run(FUZZYFEED + ["batch", "library", "--out", str(tmp_path / "r1"), "--scheduler",
                                      lc.scheduler_address], cwd=cwd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 1, run.stderr
    assert "dashboard: http" in run.stdout
    assert "refused: refused/sub.ngc: library/refused/sub.ngc:2: subroutine O100 is not defined" in run.stdout
    assert "Traceback" not in run.stderr
    # the relative path is the one the sidecar records, as `fuzzyfeed advise library/jobA/part.ngc` would
    ref = tmp_path / "ref"
    ref.mkdir()
    subprocess.run(FUZZYFEED + ["advise", "library/jobA/part.ngc", "-o", str(ref / "part.ngc.csv"), "--gcode",
                                str(ref / "part.ngc")], cwd=cwd, check=True, capture_output=True)
    for name in ("part.ngc", "part.ngc.csv", "part.ngc.csv-metadata.json"):
        assert (tmp_path / "r1" / "jobA" / name).read_bytes() == (ref / name).read_bytes()
    good = subprocess.run(FUZZYFEED + ["batch", "library/jobA", "library/jobC/*.gcode", "--out", str(tmp_path / "r2"),
                                       "--scheduler", lc.scheduler_address], cwd=cwd, capture_output=True,
                          text=True, timeout=300)
    assert good.returncode == 0, good.stdout + good.stderr
    assert sorted(pd.read_csv(tmp_path / "r2" / "summary.csv")["file"]) == \
        ["jobA/part.ngc", "jobA/rev2/part.ngc", "jobC/generated.gcode"]


def test_rerun_keeps_what_is_unchanged(library, cluster, tmp_path):
    lc, _ = cluster
    lib = tmp_path / "lib"
    shutil.copytree(library, lib)
    out = tmp_path / "out"
    rules = tmp_path / "mine.toml"
    shutil.copy(Path(fuzzyfeed.__file__).parents[1] / "rules" / "paper.toml", rules)
    args = dict(scheduler=lc.scheduler_address, rules=str(rules), **QUIET)
    first = fuzzyfeed.advise_library([lib], out, **args)
    assert not first["earlier_run"].any()
    before = files_under(out)
    second = fuzzyfeed.advise_library([lib], out, **args)
    assert second["earlier_run"].all()                      # refused files too: a refusal repeats
    after = files_under(out)
    changed = {p for p in before if p in after and before[p] != after[p]}
    assert changed <= {"summary.csv", "summary.html"}, changed   # no result rewritten
    pd.testing.assert_frame_equal(first.drop(columns=["earlier_run"]), second.drop(columns=["earlier_run"]))
    # one input edited, one result deleted: those two are redone
    with open(lib / "jobC" / "grbl.ngc", "a") as handle:
        handle.write("(revised)\n")
    os.unlink(out / "jobA" / "part.ngc.csv")
    third = fuzzyfeed.advise_library([lib], out, **args)
    redone = set(third.loc[~third["earlier_run"], "file"])
    assert redone == {"jobC/grbl.ngc", "jobA/part.ngc"}
    assert (out / "jobA" / "part.ngc.csv").is_file()
    # the rule table's bytes are part of the options: editing it redoes everything
    rules.write_text(rules.read_text() + "\n# edited\n")
    assert not fuzzyfeed.advise_library([lib], out, **args)["earlier_run"].any()
    # --force redoes everything
    assert not fuzzyfeed.advise_library([lib], out, force=True, **args)["earlier_run"].any()
    # a file that now fails loses its old results (they would not match it)
    (lib / "jobA" / "part.ngc").write_text("G21\nG41.1\nG1 X1 F100\n")
    last = fuzzyfeed.advise_library([lib], out, **args).set_index("file")
    assert last.loc["jobA/part.ngc", "status"] == "refused"
    assert not (out / "jobA" / "part.ngc").exists() and not (out / "jobA" / "part.ngc.csv").exists()


def test_a_killed_worker_loses_nothing_and_doubles_nothing(cluster, tmp_path):
    """SIGKILL one of the two worker processes while the batch runs: its chunk is run again
    elsewhere; every file ends ok exactly once, no result is committed twice (each output keeps
    the inode of its first rename), no temporary file is left, and the bytes are the command's."""
    lc, client = cluster
    lib = tmp_path / "lib"
    for n, src in enumerate(sorted(CORPUS.glob("*.ngc"))[:20]):
        (lib / f"job{n % 4}").mkdir(parents=True, exist_ok=True)
        shutil.copy(src, lib / f"job{n % 4}" / src.name)
    out = tmp_path / "out"
    pids = client.run(os.getpid)
    result: dict = {}

    def run():
        try:
            result["frame"] = fuzzyfeed.advise_library([lib], out, scheduler=lc.scheduler_address, **QUIET)
        except BaseException as exc:  # reported by the main thread
            result["error"] = exc

    thread = threading.Thread(target=run)
    thread.start()
    first_seen: dict[str, int] = {}
    rewritten: set[str] = set()
    killed = None
    while thread.is_alive():
        for path in list(out.rglob("*")) if out.exists() else []:
            with contextlib.suppress(FileNotFoundError):
                if path.is_file() and not path.name.endswith(".part") and path.name != "lock":
                    ino = path.stat().st_ino
                    if first_seen.setdefault(str(path), ino) != ino:
                        rewritten.add(str(path.relative_to(out)))
        entries = list((out / ".manifest").rglob("*.json")) if out.exists() else []
        if killed is None and len(entries) >= 4:
            victim = sorted(pids)[0]
            os.kill(pids[victim], signal.SIGKILL)
            killed = len(entries)
        time.sleep(0.01)
    thread.join()
    assert "error" not in result, result.get("error")
    frame = result["frame"]
    assert killed is not None and killed < 20, "the worker was not killed mid-run"
    assert pids[sorted(pids)[0]] not in client.run(os.getpid).values()     # it really died
    assert len(frame) == 20 and frame["file"].is_unique and (frame["status"] == "ok").all()
    assert rewritten <= {"summary.csv", "summary.html"}, rewritten
    assert not list(out.rglob("*.part"))
    ref = tmp_path / "ref"
    for rel in frame["file"]:
        code, err, files = reference(lib, ref, rel, [], [])
        assert code == 0, err
        for expected in files:
            assert (out / expected.relative_to(ref)).read_bytes() == expected.read_bytes()
    client.wait_for_workers(2)      # the nanny restarted it for the next test


def _terminal_sigint() -> None:
    """The child gets SIGINT's default action, as in a terminal (a test run started in the background
    by a non-interactive shell inherits SIGINT ignored, and Python then installs no Ctrl-C handler)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_ctrl_c_keeps_the_finished_files(cluster, tmp_path):
    """SIGINT to the command's whole process group (what a terminal's Ctrl-C does) on a local
    cluster: exit code 130, one line, no worker traceback; the finished files and their entries
    are there and whole; the same command again finishes the rest and keeps what was done."""
    lib = tmp_path / "lib"
    for n, src in enumerate(sorted(CORPUS.glob("*.ngc"))):
        (lib / f"job{n % 3}").mkdir(parents=True, exist_ok=True)
        shutil.copy(src, lib / f"job{n % 3}" / src.name)
    out = tmp_path / "out"
    proc = subprocess.Popen(FUZZYFEED + ["batch", str(lib), "--out", str(out), "--workers", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_terminal_sigint)
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and len(list((out / ".manifest").rglob("*.json"))) < 3:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stdout + stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    assert "SIGINT stopped the batch; finished files are kept" in stderr
    summary = pd.read_csv(out / "summary.csv", keep_default_na=False)
    done = set(summary.loc[summary["status"] == "ok", "file"])
    assert 3 <= len(done) < len(summary) and set(summary["status"]) <= {"ok", "not run"}
    assert not list(out.rglob("*.part"))
    ref = tmp_path / "ref"
    for rel in sorted(done)[:5]:
        code, err, files = reference(lib, ref, rel, [], [])
        for expected in files:
            assert (out / expected.relative_to(ref)).read_bytes() == expected.read_bytes()
    lc, _ = cluster
    again = fuzzyfeed.advise_library([lib], out, scheduler=lc.scheduler_address, **QUIET)
    assert (again["status"] == "ok").all()
    assert set(again.loc[again["earlier_run"], "file"]) == done


def test_workers_that_cannot_do_the_work_are_refused_by_name(library, cluster, tmp_path):
    """The start-up check, on the real workers: another fuzzyfeed version, a results folder or an
    input they cannot reach; each refusal names the worker."""
    from fuzzyfeed.batch.cluster import check_workers
    from fuzzyfeed.errors import BatchError

    _, client = cluster
    source = str(library / "jobA" / "part.ngc")
    assert check_workers(client, fuzzyfeed.__version__, str(tmp_path), source, os.getcwd()) == 2
    with pytest.raises(BatchError, match=r"worker tcp://\S+: runs fuzzyfeed .*, this is 0\.0\.0-other"):
        check_workers(client, "0.0.0-other", str(tmp_path), source, os.getcwd())
    with pytest.raises(BatchError, match=r"worker tcp://\S+: cannot write .*nowhere; the workers need"):
        check_workers(client, fuzzyfeed.__version__, str(tmp_path / "nowhere"), source, os.getcwd())
    with pytest.raises(BatchError, match=r"worker tcp://\S+: cannot read .*missing.ngc"):
        check_workers(client, fuzzyfeed.__version__, str(tmp_path), str(tmp_path / "missing.ngc"), os.getcwd())
