"""LinuxCNC's own trajectory planner as a judge (issue 37): a fuzzyfeed machine file becomes an INI
and a HAL file that run LinuxCNC 2.9's uspace simulator headless; a program runs through it in AUTO
and the joints' commanded positions, the program line and the motion type are recorded every servo
period (HAL ``sampler`` + ``halsampler``).

Not part of the package: the tests (``tests/test_linuxcnc_sim.py``) and the benchmarks
(``benchmarks/bench_controllers.py``) import it (``sys.path`` holds ``tests/``). Use::

    from linuxcnc_sim import run_program, unavailable
    run = run_program(machine, "part.ngc")          # machine: fuzzyfeed.machine.description.Machine
    run.time_s, run.joints_mm, run.line, run.motion_type

How it runs. uspace's realtime refuses root, so LinuxCNC runs as the ordinary user
:data:`SIM_USER` (``runuser -u``; created with ``useradd`` when missing and we are root). Its
``[DISPLAY] DISPLAY`` is :data:`DISPLAY_PROGRAM`, a small Debian-``python3`` program using the
``linuxcnc`` module: machine on, AUTO, open the program, enable the sampler, run (resuming at once
after an M0/M1 pause, noted in :attr:`SimRun.messages`; the pause's periods are recorded), wait
until the interpreter is idle and the motion queue empty, disable the sampler, stop
``halsampler``, exit (LinuxCNC then shuts down). A run past its time is aborted by the DISPLAY
program, or else stopped from outside (the DISPLAY program, then the whole session). One LinuxCNC at a time on this computer (its shared memory keys and
``/tmp/linuxcnc.lock`` are global): runs are serialised by an ``flock`` on :data:`LOCK_PATH`.

Real time on a shared, busy computer: uspace without privileges runs its servo thread as an
ordinary thread, so a period can start late ("Unexpected realtime delay" in the log). The motion
controller still advances exactly one period per invocation, so the recorded per-tick positions
are what the planner commands; the delays are counted in :attr:`SimRun.realtime_delays` and only
the wall time is affected. A sampler FIFO overrun (a lost tick) is detected from the sample
numbers and is an error, not silently dropped.

Program units: the INI is in mm (``LINEAR_UNITS = mm``), joints record mm. Keep programs short:
LinuxCNC runs in real time (a 30 s program takes 30 s).
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import pwd
import shutil
import subprocess
import tempfile
import textwrap
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: The ordinary user LinuxCNC runs as (uspace refuses root).
SIM_USER = os.environ.get("FUZZYFEED_SIM_USER", "fuzzyfeed-sim")
#: One LinuxCNC at a time on this computer.
LOCK_PATH = "/tmp/fuzzyfeed-linuxcnc.lock"
#: HAL motion types (motion.motion-type): 1 traverse, 2 feed, 3 arc, 4 tool change, 5 probe.
TRAVERSE, FEED, ARC = 1, 2, 3
#: Sampler FIFO depth (ticks): halsampler drains it; 20 s at 1 kHz of slack.
SAMPLER_DEPTH = 20000
#: Seconds LinuxCNC gets to start and to shut down, on top of the program's own time.
OVERHEAD_S = 60.0
DEBIAN_PYTHON = "/usr/bin/python3"
#: The joints are sampled times this (nm): halsampler prints every value with 6 decimals.
POSITION_SCALE = 1e6

#: The pins recorded each servo period, in column order (sampler cfg letters).
PINS = (("joint.0.motor-pos-cmd", "f"), ("joint.1.motor-pos-cmd", "f"), ("joint.2.motor-pos-cmd", "f"),
        ("motion.program-line", "s"), ("motion.motion-type", "s"), ("motion.current-vel", "f"),
        ("motion.in-position", "b"))


class SimError(RuntimeError):
    """LinuxCNC could not run the program (its own message attached)."""


def unavailable() -> str | None:
    """Why the harness cannot run here (None when it can)."""
    for tool in ("linuxcnc", "halsampler", "halcmd", "runuser"):
        if shutil.which(tool) is None:
            return f"{tool} not found (Debian package linuxcnc-uspace)"
    if not os.path.exists(DEBIAN_PYTHON):
        return f"{DEBIAN_PYTHON} not found"
    probe = subprocess.run([DEBIAN_PYTHON, "-c", "import linuxcnc"], capture_output=True, text=True)
    if probe.returncode != 0:
        return f"the linuxcnc module of {DEBIAN_PYTHON} does not import: {probe.stderr.strip()[-200:]}"
    try:
        pwd.getpwnam(SIM_USER)
    except KeyError:
        if os.geteuid() != 0:
            return f"user {SIM_USER!r} missing and we are not root to create it"
    return None


def ensure_user() -> None:
    """Create :data:`SIM_USER` (a system user without login) when missing."""
    try:
        pwd.getpwnam(SIM_USER)
    except KeyError:
        subprocess.run(["useradd", "--system", "--create-home", "--shell", "/usr/sbin/nologin", SIM_USER],
                       check=True, capture_output=True)


@dataclass(frozen=True, eq=False)
class SimRun:
    """Every servo period of a run, from the period the program started to the one it ended.

    ``joints_mm`` (K, 3) joint.N.motor-pos-cmd; ``line`` (K,) motion.program-line; ``motion_type``
    (K,) motion.motion-type (0 idle, :data:`TRAVERSE`, :data:`FEED`, :data:`ARC`, ...);
    ``speed_mm_s`` (K,) motion.current-vel; ``ts_s`` the servo period; ``realtime_delays`` how
    many "Unexpected realtime delay" messages LinuxCNC logged (wall time only, see the module
    docstring); ``messages`` LinuxCNC's operator errors and texts."""

    ts_s: float
    joints_mm: np.ndarray
    line: np.ndarray
    motion_type: np.ndarray
    speed_mm_s: np.ndarray
    realtime_delays: int
    messages: tuple[str, ...]
    log: str

    @property
    def t_s(self) -> np.ndarray:
        return np.arange(self.line.size) * self.ts_s

    @property
    def time_s(self) -> float:
        """Time from the first period that moved to the last one that did (the program's motion)."""
        moving = np.flatnonzero(np.any(np.diff(self.joints_mm, axis=0) != 0.0, axis=1))
        if moving.size == 0:
            return 0.0
        return float((moving[-1] - moving[0] + 1) * self.ts_s)

    @property
    def motion_time_s(self) -> float:
        """The periods with a move in progress (motion.motion-type ≠ 0): :attr:`time_s` without the
        waits between moves for M-codes and tool changes (the I/O handshakes), which fuzzyfeed's
        planner does not time."""
        return float(np.count_nonzero(self.motion_type != 0) * self.ts_s)

    def moving(self) -> "SimRun":
        """The run cut to its motion: from the last period at rest before the first move to the
        first at rest after the last (so positions start and end on the program's points)."""
        moving = np.flatnonzero(np.any(np.diff(self.joints_mm, axis=0) != 0.0, axis=1))
        if moving.size == 0:
            return self
        part = slice(int(moving[0]), int(moving[-1]) + 2)
        return SimRun(ts_s=self.ts_s, joints_mm=self.joints_mm[part], line=self.line[part],
                      motion_type=self.motion_type[part], speed_mm_s=self.speed_mm_s[part],
                      realtime_delays=self.realtime_delays, messages=self.messages, log=self.log)


# -------------------------------------------------------------------------------------------
# configuration

def startup_code(machine) -> str:
    """RS274NGC_STARTUP_CODE of a machine: mm, XY plane, absolute, and its corner setting as
    LinuxCNC's G64 P (a junction-deviation machine gets G64 P with the same distance: LinuxCNC has
    no junction deviation)."""
    return f"G21 G17 G90 G94 G40 G49 G64 P{machine.corner_mm:.6g}"


def ini_text(machine, folder: Path, tool_table: str = "") -> str:
    """The INI of ``machine`` (a :class:`fuzzyfeed.machine.description.Machine`) for a headless run
    from ``folder``: its axis limits as [JOINT_n] and [AXIS_x], its path acceleration as [TRAJ]
    MAX_LINEAR_ACCELERATION (on ``acceleration = "axes"`` a path limit the axes never reach), its
    servo period, G64 P from its corner."""
    vel, acc = machine.axis_vel_mm_s, machine.axis_acc_mm_s2
    path_acc = machine.path_limit_mm_s2
    if path_acc is None:
        path_acc = math.sqrt(sum(a * a for a in acc))
    traj_vel = math.sqrt(sum(v * v for v in vel))        # the axes limit, the path never does
    period_ns = int(round(machine.ts_s * 1e9))
    lines = [
        "[EMC]", "VERSION = 1.1", f"MACHINE = fuzzyfeed-{machine.name}", "DEBUG = 0", "",
        "[DISPLAY]", f"DISPLAY = {folder / 'display.py'}", "CYCLE_TIME = 0.05", "",
        "[TASK]", "TASK = milltask", "CYCLE_TIME = 0.001", "",
        "[RS274NGC]", "PARAMETER_FILE = sim.var", f"RS274NGC_STARTUP_CODE = {startup_code(machine)}", "",
        "[EMCMOT]", "EMCMOT = motmod", "COMM_TIMEOUT = 4.0", f"SERVO_PERIOD = {period_ns}", "",
        "[EMCIO]", "EMCIO = io", "CYCLE_TIME = 0.100", f"TOOL_TABLE = {tool_table or 'tool.tbl'}", "",
        "[HAL]", "HALFILE = sim.hal", "", "[KINS]", "KINEMATICS = trivkins coordinates=xyz", "JOINTS = 3", "",
        "[TRAJ]", "COORDINATES = X Y Z", "LINEAR_UNITS = mm", "ANGULAR_UNITS = degree",
        f"DEFAULT_LINEAR_VELOCITY = {min(vel):.6g}", f"MAX_LINEAR_VELOCITY = {traj_vel:.6g}",
        f"DEFAULT_LINEAR_ACCELERATION = {path_acc:.6g}", f"MAX_LINEAR_ACCELERATION = {path_acc:.6g}",
        "NO_FORCE_HOMING = 1", "",
    ]
    for j, axis in enumerate("XYZ"):
        lines += [f"[AXIS_{axis}]", f"MAX_VELOCITY = {vel[j]:.9g}", f"MAX_ACCELERATION = {acc[j]:.9g}",
                  "MIN_LIMIT = -100000", "MAX_LIMIT = 100000", ""]
        lines += [f"[JOINT_{j}]", "TYPE = LINEAR", "HOME = 0", f"MAX_VELOCITY = {vel[j]:.9g}",
                  f"MAX_ACCELERATION = {acc[j]:.9g}", "MIN_LIMIT = -100000", "MAX_LIMIT = 100000",
                  "FERROR = 1000", "MIN_FERROR = 1000", "HOME_SEARCH_VEL = 0", "HOME_LATCH_VEL = 0",
                  "HOME_SEQUENCE = 0", ""]
    return "\n".join(lines)


def hal_text() -> str:
    """Motion with its joints' commands looped back as feedback (no servo: the servo model runs on
    the recorded commands), the I/O controller's handshakes looped, and the sampler."""
    cfg = "".join(kind for _, kind in PINS)
    lines = ["loadrt [KINS]KINEMATICS",
             "loadrt [EMCMOT]EMCMOT servo_period_nsec=[EMCMOT]SERVO_PERIOD num_joints=[KINS]JOINTS",
             f"loadrt sampler depth={SAMPLER_DEPTH} cfg={cfg}",
             "addf motion-command-handler servo-thread", "addf motion-controller servo-thread",
             "setp sampler.0.enable 0"]
    lines += ["loadrt scale count=3"]
    for j in range(3):   # halsampler prints 6 decimals: joints in nm (scale 1e6) keep 1e-12 mm
        lines += [f"addf scale.{j} servo-thread", f"setp scale.{j}.gain {POSITION_SCALE:g}",
                  f"net j{j}pos joint.{j}.motor-pos-cmd => joint.{j}.motor-pos-fb scale.{j}.in",
                  f"net j{j}scaled scale.{j}.out => sampler.0.pin.{j}"]
    for i, (pin, _) in enumerate(PINS[3:], start=3):
        lines.append(f"net s{i} {pin} => sampler.0.pin.{i}")
    lines += ["addf sampler.0 servo-thread",
              "net estop-loop iocontrol.0.user-enable-out => iocontrol.0.emc-enable-in",
              "net tool-prep-loop iocontrol.0.tool-prepare => iocontrol.0.tool-prepared",
              "net tool-change-loop iocontrol.0.tool-change => iocontrol.0.tool-changed"]
    return "\n".join(lines) + "\n"


#: The DISPLAY program (run by LinuxCNC with Debian's python3 as ``DISPLAY -ini FILE``).
DISPLAY_PROGRAM = textwrap.dedent('''\
    #!/usr/bin/python3
    import glob, json, os, shutil, subprocess, sys, time
    import linuxcnc
    folder = os.path.dirname(os.path.abspath(__file__))
    job = json.load(open(os.path.join(folder, "job.json")))
    status = {"done": False, "errors": [], "texts": []}
    def note():
        while True:
            m = err.poll()
            if not m:
                return
            kind, text = m
            (status["errors"] if kind in (linuxcnc.OPERATOR_ERROR, linuxcnc.NML_ERROR) else status["texts"]).append(text)
    def finish(code):
        subprocess.run(["halcmd", "setp", "sampler.0.enable", "0"])
        with open(os.path.join(folder, "log.txt"), "w") as log:  # LinuxCNC's own, deleted at its exit
            for name in sorted(glob.glob("/tmp/linuxcnc.debug.*") + glob.glob("/tmp/linuxcnc.print.*")):
                try:
                    if os.stat(name).st_uid == os.getuid():
                        log.write(open(name, errors="replace").read())
                except OSError:
                    pass
        time.sleep(0.3)
        sampler.terminate()
        try:
            sampler.wait(10)
        except subprocess.TimeoutExpired:
            sampler.kill()
        json.dump(status, open(os.path.join(folder, "status.json"), "w"))
        sys.exit(code)
    open(os.path.join(folder, "display.pid"), "w").write(str(os.getpid()))
    s, c, err = linuxcnc.stat(), linuxcnc.command(), linuxcnc.error_channel()
    sampler = subprocess.Popen(["halsampler", "-t"], stdout=open(os.path.join(folder, "samples.txt"), "w"))
    try:
        c.state(linuxcnc.STATE_ESTOP_RESET); c.wait_complete()
        c.state(linuxcnc.STATE_ON); c.wait_complete()
        # the machine's modes (G64 P ...): RS274NGC_STARTUP_CODE alone is not in force when a
        # program opened this way runs (measured: corners blended 1 mm wide under P0.01)
        c.mode(linuxcnc.MODE_MDI); c.wait_complete()
        c.mdi(job["startup"]); c.wait_complete()
        c.mode(linuxcnc.MODE_AUTO); c.wait_complete()
        c.program_open(job["program"]); c.wait_complete()
        time.sleep(0.2); note()
        if status["errors"]:
            finish(3)
        subprocess.run(["halcmd", "setp", "sampler.0.enable", "1"], check=True)
        time.sleep(0.05)
        c.auto(linuxcnc.AUTO_RUN, 0)
        deadline = time.time() + job["timeout_s"]
        started = False
        while time.time() < deadline:
            time.sleep(0.02)
            s.poll(); note()
            try:                 # the harness that started this run is gone: stop
                os.kill(job["caller"], 0)
            except ProcessLookupError:
                status["errors"].append("the caller ended before the program did")
                break
            except PermissionError:
                pass
            if s.paused:         # M0/M1 (or M60): the operator presses resume at once
                status["texts"].append(f"resumed a pause at line {s.current_line}")
                c.auto(linuxcnc.AUTO_RESUME)
                continue
            if s.interp_state != linuxcnc.INTERP_IDLE:
                started = True
            if started and s.interp_state == linuxcnc.INTERP_IDLE and s.queue == 0 and s.inpos:
                status["done"] = True
                break
            if status["errors"] and s.interp_state == linuxcnc.INTERP_IDLE:
                break
        if not status["done"]:
            c.abort()
        time.sleep(0.1); note()
    except Exception as exc:
        status["errors"].append(f"display: {type(exc).__name__}: {exc}")
    finish(0)
''')


# -------------------------------------------------------------------------------------------
# running

@contextmanager
def _one_linuxcnc():
    fd = os.open(LOCK_PATH, os.O_CREAT | os.O_RDWR, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)


def write_config(machine, folder: Path, program: Path, timeout_s: float, tool_table: str | Path | None = None) -> Path:
    """Write the INI, HAL, DISPLAY program, job and empty parameter/tool files into ``folder``;
    returns the INI's path."""
    folder = Path(folder)
    table = ""
    if tool_table is not None:
        shutil.copy(tool_table, folder / "tool_user.tbl")
        table = "tool_user.tbl"
    # without a table of its own: tools 1-99 of no length and no diameter (a T1 M6 is accepted and
    # G43 moves nothing)
    (folder / "tool.tbl").write_text("".join(f"T{t} P{t} Z0 D0 ;\n" for t in range(1, 100)))
    (folder / "sim.var").write_text("")
    (folder / "sim.hal").write_text(hal_text())
    (folder / "display.py").write_text(DISPLAY_PROGRAM)
    os.chmod(folder / "display.py", 0o755)
    (folder / "job.json").write_text(json.dumps({"program": str(program), "timeout_s": timeout_s,
                                                    "caller": os.getpid(),
                                                    "startup": startup_code(machine)}))
    ini = folder / "sim.ini"
    ini.write_text(ini_text(machine, folder, table))
    return ini


def run_program(machine, program: str | os.PathLike, *, timeout_s: float | None = None,
                expected_s: float = 30.0, tool_table: str | os.PathLike | None = None,
                keep: str | os.PathLike | None = None) -> SimRun:
    """Run ``program`` (a G-code file) on ``machine``'s LinuxCNC and record every servo period.

    ``expected_s`` the program's rough duration (the run is given 3x that plus
    :data:`OVERHEAD_S`; ``timeout_s`` overrides it); ``tool_table`` a LinuxCNC tool table (default:
    tools 1-99 of length 0 and diameter 0);
    ``keep`` a folder to leave the INI, HAL and samples in (for a look by hand). Raises
    :class:`SimError` when LinuxCNC reports an error, does not finish, or a tick is lost."""
    reason = unavailable()
    if reason:
        raise SimError(f"LinuxCNC harness unavailable: {reason}")
    ensure_user()
    timeout_s = 3.0 * expected_s + 10.0 if timeout_s is None else timeout_s
    user = pwd.getpwnam(SIM_USER)
    with tempfile.TemporaryDirectory(prefix="fuzzyfeed-lcnc-") as tmp:
        folder = Path(tmp)
        os.chmod(folder, 0o777)
        prog = folder / ("program" + (Path(program).suffix or ".ngc"))
        shutil.copy(program, prog)
        write_config(machine, folder, prog, timeout_s, tool_table)
        for path in folder.iterdir():
            os.chown(path, user.pw_uid, user.pw_gid)
        os.chown(folder, user.pw_uid, user.pw_gid)
        env = {"PATH": "/usr/bin:/bin:/usr/sbin:/sbin", "HOME": user.pw_dir, "USER": SIM_USER,
               "LOGNAME": SIM_USER, "LANG": "C.UTF-8"}
        home_logs = [Path(user.pw_dir) / "linuxcnc_debug.txt", Path(user.pw_dir) / "linuxcnc_print.txt"]
        with _one_linuxcnc():
            _wait_for_other_linuxcnc()
            for path in home_logs:          # LinuxCNC copies its log there when it ends in an error
                path.unlink(missing_ok=True)
            command = ["runuser", "-u", SIM_USER, "--", "env", "-i", *[f"{k}={v}" for k, v in env.items()],
                       "linuxcnc", str(folder / "sim.ini")]
            proc = subprocess.Popen(command, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                    stdin=subprocess.DEVNULL, text=True, start_new_session=True)
            try:
                log, _ = proc.communicate(timeout=timeout_s + OVERHEAD_S)
            except subprocess.TimeoutExpired:
                log = f"timed out after {timeout_s + OVERHEAD_S:.0f} s\n" + _stop(proc, folder)
            for path in [folder / "log.txt", *home_logs]:
                if path.exists():
                    log += path.read_text(errors="replace")
        if keep is not None:
            shutil.copytree(folder, keep, dirs_exist_ok=True)
        return _parse(folder, machine.ts_s, log)


def _wait_for_other_linuxcnc(limit_s: float = OVERHEAD_S) -> None:
    """Wait while another LinuxCNC is up (its /tmp/linuxcnc.lock: a run whose caller was killed
    ends itself at its DISPLAY program's deadline); LinuxCNC would otherwise shut it down."""
    deadline = time.time() + limit_s
    while os.path.exists("/tmp/linuxcnc.lock") and time.time() < deadline:
        time.sleep(0.5)
    if os.path.exists("/tmp/linuxcnc.lock"):
        raise SimError("another LinuxCNC has been running for over a minute (/tmp/linuxcnc.lock); "
                       "not starting a second one")


def _stop(proc: subprocess.Popen, folder: Path) -> str:
    """End a run that did not finish: its DISPLAY program first (LinuxCNC then shuts down in order),
    then the whole session it started. Returns what it printed."""
    import signal

    try:
        os.kill(int((folder / "display.pid").read_text()), signal.SIGTERM)
        out, _ = proc.communicate(timeout=60)
        return out or ""
    except (OSError, ValueError, subprocess.TimeoutExpired):
        pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except OSError:
        pass
    out, _ = proc.communicate()
    return out or ""


def _parse(folder: Path, ts_s: float, log: str) -> SimRun:
    status_path = folder / "status.json"
    if not status_path.exists():
        raise SimError(f"LinuxCNC did not run the program; its log ends:\n{log[-2000:]}")
    status = json.loads(status_path.read_text())
    if status["errors"]:
        raise SimError("LinuxCNC: " + " | ".join(status["errors"]))
    if not status["done"]:
        raise SimError(f"LinuxCNC did not finish the program in time; log ends:\n{log[-1000:]}")
    raw = np.loadtxt(folder / "samples.txt", ndmin=2)
    if raw.shape[0] < 2:
        raise SimError("LinuxCNC: no servo period recorded")
    index = raw[:, 0].astype(np.int64)
    if np.any(np.diff(index) != 1):
        gaps = int(np.sum(np.diff(index) - 1))
        raise SimError(f"LinuxCNC: {gaps} servo periods lost (sampler FIFO overrun; the computer too busy "
                       "for halsampler)")
    data = raw[:, 1:]
    delays = log.count("Unexpected realtime delay")
    return SimRun(ts_s=ts_s, joints_mm=data[:, 0:3] / POSITION_SCALE, line=data[:, 3].astype(np.int64),
                  motion_type=data[:, 4].astype(np.int64), speed_mm_s=data[:, 5].copy(),
                  realtime_delays=delays, messages=tuple(status["texts"]), log=log)


def servo_contour_um(run: SimRun, machine, program_file: str | os.PathLike) -> tuple[float, float]:
    """Largest contour error (um) of ``machine``'s servo model on LinuxCNC's commanded joints
    (:func:`fuzzyfeed.machine.servo.following_errors` from rest at the run's first period), against
    the programmed path as fuzzyfeed builds it (the chains of
    :func:`fuzzyfeed.program.run.program_path`, nearest point over the whole path): (in the part,
    in the air). A period is in the part when it is commanded on a feed move (G1/G2/G3) and the tool
    is nearest a feed segment, as :func:`fuzzyfeed.machine.trace.trace_motion` measures; the others
    are in the air. Pass ``run.moving()``."""
    from fuzzyfeed.machine.contour import windowed_distance
    from fuzzyfeed.machine.servo import following_errors
    from fuzzyfeed.program.read import read_program
    from fuzzyfeed.program.run import program_path

    path = program_path(read_program(program_file), machine.chord_tol_mm)
    pts, rapid = [], []
    for chain in path.chains:
        p = chain.motion.points
        if pts and np.linalg.norm(p[0] - pts[-1]) > 0:      # a gap between chains: in the air
            rapid.append(True)
            pts.append(p[0])
        elif not pts:
            pts.append(p[0])
        pts.extend(p[1:])
        rapid.extend(chain.motion.rapid.tolist())
    pts, rapid = np.array(pts), np.array(rapid)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    actual = run.joints_mm - following_errors(machine.servo, run.joints_mm, run.ts_s)
    k = actual.shape[0]
    dist, nearest, _ = windowed_distance(pts, s, actual, np.full(k, -1.0), np.full(k, s[-1] + 1.0))
    # fuzzyfeed's split (machine/trace.py): a tick is in the part when it is commanded on a feed
    # move and the tool is nearest a feed segment; a tool still lagging on a rapid is in the air
    feed = np.isin(run.motion_type, (FEED, ARC))
    part = feed & ~rapid[nearest]
    air = (run.motion_type == TRAVERSE) | (feed & rapid[nearest])
    return (float(dist[part].max() * 1e3) if part.any() else 0.0,
            float(dist[air].max() * 1e3) if air.any() else 0.0)
