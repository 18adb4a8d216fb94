"""What the program results share for their outputs (:mod:`fuzzyfeed.advice.program`,
:mod:`fuzzyfeed.advice.machine_program`, :mod:`fuzzyfeed.advice.program_windows`): the checks of the
output flags, the sidecar's F note, the rewrite's text written atomically, the rs274-checked rewrite."""

from __future__ import annotations

from fuzzyfeed.advice.options import AdviceOptions
from fuzzyfeed.errors import ExportError, MachineLimitsError

G52_REFUSAL = "--gcode-g52 writes a NURBS shape; a G-code program is written back with --gcode OUT.ngc"


def feed_note(cap) -> str:
    return "the program's own F" + (f", capped at {cap:g} mm/min" if cap else "")


def verifier(options: AdviceOptions, tools):
    """With ``verify_rs274``: a rewrite ``(program, move, end, feed) -> (text, Verification)``
    checked by rs274 with the tool table ``tools`` (:mod:`fuzzyfeed.program.verify`); else None."""
    if not options.verify_rs274:
        return None
    from fuzzyfeed.program.rewrite import rewrite_program
    from fuzzyfeed.program.verify import rs274_path, verified_rewrite

    if rs274_path() is None:
        raise ExportError("--verify-rs274: rs274 not found on PATH (LinuxCNC's interpreter, Debian "
                          "package linuxcnc-uspace); leave the flag out to write the rewrite unchecked")
    return lambda program, *pieces: verified_rewrite(program, *pieces, rewrite=rewrite_program, tools_mm=tools)


def refuse_report(report) -> None:
    if report is not None:
        raise MachineLimitsError("--report: the value report needs a machine (--machine FILE, or a "
                                 "machine flag such as --contour-tol-um)")


def check_outputs(csv, gcode, gcode_g52, plot) -> None:
    if gcode_g52:
        raise ExportError(G52_REFUSAL)
    outputs = [p for p in (csv, gcode, plot) if p]
    if len(set(outputs)) != len(outputs):
        raise ExportError(f"output files must differ: {', '.join(outputs)}")


def write_text(path: str, text: str) -> None:
    from fuzzyfeed.base.atomic import atomic_write

    with atomic_write(path, "w", newline="") as handle:
        handle.write(text)
