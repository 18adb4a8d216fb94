"""The output transaction (fuzzyfeed.base.outputs): nothing lost, whatever the destination or signal.

Every data-loss case of issue 10 is here: an output equal to an input (also via a symlink or a hard
link), two outputs naming one file, a bad second destination after a good first one, symlinks,
devices, FIFOs, '-', the umask, and SIGTERM/SIGHUP/SIGINT while a command is writing.
"""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.base.atomic import atomic_write
from fuzzyfeed.base.outputs import OutputPathError, OutputSet

from hostile_cases import FAST, SHAPE  # the catalogue's tiny shape and quick sampling


def snapshot(folder: Path) -> dict[str, tuple]:
    """Every entry under ``folder``: type, mode, content or link target (to prove nothing changed)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        st = p.lstat()
        if p.is_symlink():
            out[str(p)] = ("link", os.readlink(p))
        elif stat.S_ISREG(st.st_mode):
            out[str(p)] = ("file", stat.S_IMODE(st.st_mode), p.read_bytes())
        else:
            out[str(p)] = ("other", stat.S_IFMT(st.st_mode))
    return out


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(SHAPE)
    return tmp_path


def refused(capsys, argv, folder: Path, needle: str) -> str:
    before = snapshot(folder)
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fuzzyfeed: error: "), err
    assert needle in lines[0], lines[0]
    assert snapshot(folder) == before, "a refused command changed the folder"
    return lines[0]


# -- an output that is an input ------------------------------------------------------------------
def test_output_equal_to_the_shape_is_refused(work, capsys):
    refused(capsys, ["advise", "s.toml", "-o", "s.toml", *FAST], work, "-o s.toml: is the input SHAPE")


def test_output_equal_to_the_shape_via_symlink_and_hard_link(work, capsys):
    os.symlink("s.toml", work / "sym.toml")
    os.link(work / "s.toml", work / "hard.toml")
    refused(capsys, ["advise", "s.toml", "-o", "sym.toml", *FAST], work, "is the input SHAPE")
    refused(capsys, ["advise", "hard.toml", "-o", "s.toml", *FAST], work, "is the input SHAPE")
    refused(capsys, ["advise", "s.toml", "-o", str(work / "." / "s.toml"), *FAST], work, "is the input")


def test_output_equal_to_the_rule_table_or_the_program(work, capsys):
    main(["rules", "show", "--format", "toml"])
    (work / "r.toml").write_text(capsys.readouterr().out)
    refused(capsys, ["advise", "s.toml", "--rules", "r.toml", "-o", "r.toml", *FAST], work,
            "-o r.toml: is the input --rules")
    (work / "p.ngc").write_text("G21 G90\nG0 X0 Y0\nG1 X10 Y0 F600\nG1 X10 Y10\nG1 X20 Y10\nM2\n")
    refused(capsys, ["advise", "p.ngc", "-o", "out.csv", "--gcode", "p.ngc"], work,
            "--gcode p.ngc: is the input SHAPE")
    refused(capsys, ["advise", "p.ngc#1", "-o", "p.ngc"], work, "is the input SHAPE")


def test_plot_equal_to_output_and_gcode_equal_to_output(work, capsys):
    refused(capsys, ["advise", "s.toml", "-o", "a.csv", "--plot", "a.csv", *FAST], work,
            "--plot a.csv: -o already writes to the same file")
    refused(capsys, ["advise", "s.toml", "-o", "a.csv", "--gcode", "./a.csv", *FAST], work,
            "same file")


# -- a bad second destination leaves the first untouched -------------------------------------------
@pytest.mark.parametrize("flag", ["--plot", "--gcode", "--gcode-g52"])
def test_bad_later_destination_keeps_existing_csv(work, capsys, flag):
    (work / "a.csv").write_text("precious\n")
    refused(capsys, ["advise", "s.toml", "-o", "a.csv", flag, "nodir/x.out", *FAST], work,
            f"{flag} nodir/x.out: folder")
    assert (work / "a.csv").read_text() == "precious\n"


@pytest.mark.parametrize("make, needle", [
    (lambda p: p.mkdir(), "is a folder"),
    (lambda p: (p.write_text("ro"), p.chmod(0o444)), "read-only"),
])
def test_unwritable_destinations(work, capsys, make, needle):
    make(work / "dest")
    refused(capsys, ["advise", "s.toml", "-o", "dest", *FAST], work, needle)


def test_trailing_slash_and_empty_name(work, capsys):
    refused(capsys, ["advise", "s.toml", "-o", "out/", *FAST], work, "give a file name")
    refused(capsys, ["advise", "s.toml", "-o", "", *FAST], work, "-o: the file name is empty")


def test_symlink_loop(work, capsys):
    os.symlink("loop2", work / "loop1")
    os.symlink("loop1", work / "loop2")
    refused(capsys, ["advise", "s.toml", "-o", "loop1", *FAST], work, "-o loop1")


def test_an_error_while_computing_keeps_every_output(work, capsys):
    (work / "a.csv").write_text("old csv\n")
    (work / "a.ngc").write_text("old program\n")
    # --gcode-g52 --g52-whole on a non-uniform knot vector is refused after the CSV is computed
    (work / "nu.toml").write_text(SHAPE.replace("0.5", "0.3"))
    before = snapshot(work)
    assert main(["advise", "nu.toml", "-o", "a.csv", "--gcode-g52", "a.ngc", "--g52-whole", *FAST]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert snapshot(work) == before


# -- what a successful write looks like -------------------------------------------------------------
def test_symlink_is_written_through(work, capsys):
    (work / "real.csv").write_text("old\n")
    os.symlink("real.csv", work / "link.csv")
    assert main(["advise", "s.toml", "-o", "link.csv", *FAST]) == 0
    assert os.readlink(work / "link.csv") == "real.csv"
    assert (work / "real.csv").read_text().startswith("u,x_mm")
    dangling = work / "dangling.csv"
    os.symlink("new_target.csv", dangling)
    assert main(["advise", "s.toml", "-o", "dangling.csv", *FAST]) == 0
    assert dangling.is_symlink() and (work / "new_target.csv").read_text().startswith("u,x_mm")


def test_dev_null_stays_a_device(work, capsys):
    assert main(["advise", "s.toml", "-o", os.devnull, "--plot", os.devnull, *FAST]) == 0
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)
    assert capsys.readouterr().err == ""


def test_fifo_is_streamed_to(work, capsys):
    fifo = work / "pipe"
    os.mkfifo(fifo)
    got = {}

    def reader():
        with open(fifo, "rb") as f:
            got["data"] = f.read()

    t = threading.Thread(target=reader)
    t.start()
    assert main(["advise", "s.toml", "-o", str(fifo), *FAST]) == 0
    t.join(10)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert got["data"].startswith(b"u,x_mm") and got["data"].count(b"\n") == 61


def test_dash_is_standard_output_and_messages_move_to_stderr(work, capsys):
    assert main(["advise", "s.toml", "-o", "-", *FAST]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("u,x_mm") and out.count("\n") == 61
    assert "tiny: 60 points" in err
    refused(capsys, ["advise", "s.toml", "-o", "-", "--gcode", "-", *FAST], work, "standard output")


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_new_files_honour_the_umask(work, capsys, umask, mode):
    old = os.umask(umask)
    try:
        assert main(["advise", "s.toml", "-o", "a.csv", "--gcode", "a.ngc", *FAST]) == 0
    finally:
        os.umask(old)
    for name in ("a.csv", "a.ngc"):
        assert stat.S_IMODE((work / name).stat().st_mode) == mode


def test_a_replaced_file_keeps_its_mode(work, capsys):
    (work / "a.csv").write_text("old\n")
    (work / "a.csv").chmod(0o640)
    assert main(["advise", "s.toml", "-o", "a.csv", *FAST]) == 0
    assert stat.S_IMODE((work / "a.csv").stat().st_mode) == 0o640


def test_rules_set_edits_in_place(work, capsys):
    main(["rules", "show", "--format", "toml"])
    (work / "r.toml").write_text(capsys.readouterr().out)
    (work / "r.toml").chmod(0o604)
    assert main(["rules", "set", "r.toml", "VS", "M", "HF"]) == 0
    assert stat.S_IMODE((work / "r.toml").stat().st_mode) == 0o604
    assert [p.name for p in work.iterdir() if p.name.startswith(".")] == []


# -- the API: atomic_write and OutputSet ---------------------------------------------------------
def test_atomic_write_error_keeps_old_content(tmp_path):
    target = tmp_path / "t.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_write(target) as f:
            f.write("new")
            raise RuntimeError("boom")
    assert target.read_text() == "old" and sorted(os.listdir(tmp_path)) == ["t.txt"]


def test_output_set_renames_together(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    with pytest.raises(KeyboardInterrupt):
        with OutputSet([("-o", str(a)), ("--plot", str(b))]):
            with atomic_write(str(a)) as f:
                f.write("A")
            assert not a.exists()  # written, not yet renamed
            raise KeyboardInterrupt
    assert os.listdir(tmp_path) == []
    with OutputSet([("-o", str(a)), ("--plot", str(b))]):
        with atomic_write(str(a)) as f:
            f.write("A")
        with atomic_write(str(b), "wb") as f:
            f.write(b"B")
    assert a.read_text() == "A" and b.read_bytes() == b"B"


def test_output_set_refuses_an_input(tmp_path):
    src = tmp_path / "in.toml"
    src.write_text("x")
    with pytest.raises(OutputPathError, match="is the input SHAPE"):
        OutputSet([("-o", str(src))], [("SHAPE", str(src))])


def test_disk_full_names_the_users_file(tmp_path):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    with pytest.raises(OutputPathError, match=r"^/dev/full: cannot write \(No space left on device\)"):
        with atomic_write("/dev/full") as f:
            f.write("x" * 100)


# -- signals while writing ------------------------------------------------------------------------
SIGNAL_SCRIPT = textwrap.dedent("""
    import os, signal, sys, time
    # a terminal's dispositions, whatever this test runs under (nohup ignores SIGHUP, a background
    # job SIGINT, and the outputs keep an ignored signal ignored)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    from fuzzyfeed.base import outputs
    marker = sys.argv[1]
    real_open = outputs.OutputSet.open
    calls = []

    def slow_open(self, path, mode="w", newline=None):
        calls.append(path)
        cm = real_open(self, path, mode, newline)
        handle = cm.__enter__()
        if len(calls) == 2:  # the CSV's temporary file is complete, the program's is open
            handle.write("G21\\n"); handle.flush()
            open(marker, "w").close()
            time.sleep(30)

        class Wrap:
            def __enter__(s):
                return handle
            def __exit__(s, *exc):
                return cm.__exit__(*exc)
        return Wrap()

    outputs.OutputSet.open = slow_open
    from fuzzyfeed.cli import main
    sys.exit(main(sys.argv[2:]))
""")


@pytest.mark.parametrize("signum, code", [(signal.SIGTERM, 143), (signal.SIGHUP, 129),
                                          (signal.SIGINT, 130)])
def test_signal_during_a_write_changes_nothing(work, signum, code):
    (work / "a.csv").write_text("old csv\n")
    (work / "a.ngc").write_text("old program\n")
    before = snapshot(work)
    marker = work.parent / f"marker-{signum}"
    proc = subprocess.Popen([sys.executable, "-c", SIGNAL_SCRIPT, str(marker), "advise", "s.toml",
                             "-o", "a.csv", "--gcode", "a.ngc", *FAST], cwd=work,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not marker.exists():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert len([p for p in work.iterdir() if p.name.endswith(".part")]) == 2  # both pending
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == code, err
    assert err.strip().splitlines()[-1].startswith("fuzzyfeed: ") and "no output written" in err
    assert "Traceback" not in err
    assert snapshot(work) == before  # no .part left, CSV and program both old
