"""Execute a program's lines as LinuxCNC does — parameters, expressions and O-word control flow —
into the sequence of executed lines (*rows*) and their words with plain values.

Each source line is compiled once (:func:`fuzzyfeed.program.expr.compile_line`) and evaluated
at every execution. O-words: ``sub``/``endsub``/``return`` and ``call [args]`` (``#1`` … ``#30``
and unprefixed names local to the call; ``#<_value>`` holds a returned value), subroutines
defined before or after their call (also after M2/M30, where LinuxCNC looks for them too) or in
``NAME.ngc`` beside the program for ``o<NAME> call``; ``if``/``elseif``/``else``/``endif``,
``while``/``endwhile``, ``do``/``while``, ``repeat [n]``/``endrepeat``, ``break``, ``continue``;
Fanuc-style ``O100`` … ``M99`` subroutines called by ``M98 P100 [L n]``. The program ends at the
first M2/M30 executed (or at the end of the file). Read-only parameters: ``#<_metric>``,
``_imperial``, ``_absolute``, ``_incremental``, ``_feed``, ``_rpm``, ``_motion_mode``,
``_plane``, ``_coord_system``, ``_inverse_time``, ``_units_per_minute``, ``_units_per_rev``,
``_call_level``, ``_vmajor``, ``_vminor``, ``#5220`` (coordinate system 1–9), ``#5400`` (tool)
and the probe results ``#5061``–``#5063``, ``#5070`` (read as the last G38.x's target, with a
notice); the other system parameters (offsets, positions, tool data, I/O) depend on the machine
and are refused when read.

Limits: at most :data:`MAX_ROWS` executed lines with words, and at most :data:`MAX_REPEATS` runs
of lines that already ran (loops and calls; a loop that never ends is refused in one line, naming
the limit, in about a second), calls nested at most :data:`MAX_CALL_DEPTH` deep (LinuxCNC's limit).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.program.expr import LineCode, clean_line, compile_line, evaluate
from fuzzyfeed.program.params import ModalState, Parameters

#: Most executed lines that carry words (rows) and most lines stepped through in all.
MAX_ROWS = 2_000_000
MAX_REPEATS = 250_000
#: Deepest nesting of subroutine calls (LinuxCNC's INTERP_SUB_ROUTINE_LEVELS).
MAX_CALL_DEPTH = 10


@dataclass
class Source:
    """One file's lines (raw), their compiled forms (lazily) and its O-word structure."""

    path: Path
    lines: list[str]
    code: dict = field(default_factory=dict)
    seen: bytearray = field(default_factory=bytearray)       # lines run at least once
    subs: dict = field(default_factory=dict)         # label -> (first line, end line)
    jumps: dict = field(default_factory=dict)        # line -> control data (see _scan)

    def __post_init__(self):
        self.seen = bytearray(len(self.lines))

    def compiled(self, i: int) -> LineCode | None:
        """The compiled line ``i`` (None for a blank, comment-only or '%' line); a line that
        cannot be read raises its one-line error (kept: it is raised again if the line runs)."""
        code = self.code.get(i, _UNREAD)
        if code is _UNREAD:
            try:
                text = clean_line(self.lines[i])
                if not text or text == "%":
                    code = None
                elif "%" in text:
                    raise PathFormatError("'%' must stand alone on its line")
                else:
                    code = compile_line(text)
                    if not code.words and not code.settings and code.oword is None:
                        code = None
            except PathFormatError as exc:
                code = self.error(i, str(exc))
            self.code[i] = code
        if isinstance(code, PathFormatError):
            raise code
        return code

    def error(self, i: int, message: str) -> PathFormatError:
        text = self.lines[i].strip()
        if len(text) > 80:
            text = text[:77] + "..."
        return PathFormatError(f"{self.path}:{i + 1}: {message} in {text!r}")


@dataclass(frozen=True)
class Execution:
    """The executed rows of a program: per row the file and line it comes from (``row_line``:
    the line index in the main file, −1 for a line of another file), and the tokens of every
    row as the vectorised reader takes them (row, letter 0–25, value)."""

    row_line: np.ndarray
    files: tuple                # the files rows come from (the program first)
    row_src: np.ndarray         # per row: index into files
    row_pc: np.ndarray          # per row: 0-based line in its file
    tl: np.ndarray
    tc: np.ndarray
    tv: np.ndarray
    ended: bool                 # an M2/M30 was executed
    in_order: bool              # every main-file line runs at most once, in file order
    #: per row: the main-file line of the outermost subroutine call the row runs in (-1: not in
    #: a call, or a call made from another file)
    row_call: np.ndarray | None = None

    @property
    def n_rows(self) -> int:
        return int(self.row_line.size)

    def where(self, row: int) -> tuple[Path, int]:
        """(file, 1-based line) of ``row``, for messages."""
        return self.files[int(self.row_src[row])], int(self.row_pc[row]) + 1


def needs_execution(body: str) -> bool:
    """True when the (upper-case, comment-free) program text uses anything beyond plain words:
    parameters, expressions, O-words, polar words or M98/M99."""
    return any(ch in body for ch in "#[<O@^$") or "M98" in body or "M99" in body


def _scan(src: Source) -> None:
    """Find the subroutines and match every control O-word of ``src`` (see the module docstring)."""
    stack: list[tuple[str, str, int]] = []     # (scope-qualified label, keyword, line)
    scope = ""
    fanuc_open = None
    for i in range(len(src.lines)):
        try:
            code = src.compiled(i)
        except PathFormatError:
            continue             # raised when (if) the line runs
        if code is None:
            continue
        if code.fanuc_return and fanuc_open is not None:
            src.subs[fanuc_open[0]] = (fanuc_open[1], i)
            fanuc_open = None
            continue
        ow = code.oword
        if ow is None:
            continue
        kw, label = ow.keyword, ow.label
        if kw == "":
            fanuc_open = (label, i)
            continue
        if kw == "sub":
            if scope:
                raise src.error(i, f"subroutine O{label} defined inside subroutine O{scope}")
            if label in src.subs:
                raise src.error(i, f"subroutine O{label} defined twice")
            scope = label
            src.subs[label] = (i, None)
            continue
        if kw == "endsub":
            if scope != label:
                raise src.error(i, f"'O{label} endsub' without 'O{label} sub'")
            if stack:
                raise src.error(stack[-1][2], f"'O{stack[-1][0].split('#')[1]} {stack[-1][1]}' not closed before endsub")
            src.subs[label] = (src.subs[label][0], i)
            scope = ""
            continue
        if kw in ("call", "return"):
            continue
        key = f"{scope}#{label}"
        if kw in ("if", "do", "repeat") or (kw == "while" and not (stack and stack[-1][0] == key and stack[-1][1] == "do")):
            if any(s[0] == key for s in stack):
                raise src.error(i, f"O{label} is already open (line {[s[2] for s in stack if s[0] == key][0] + 1})")
            stack.append((key, kw, i))
            src.jumps[i] = {"kind": kw, "branches": [], "end": None}
            continue
        if not stack or stack[-1][0] != key:
            opener = {"elseif": "if", "else": "if", "endif": "if", "endwhile": "while", "while": "do",
                      "endrepeat": "repeat", "break": "while/do/repeat", "continue": "while/do/repeat"}[kw]
            if kw in ("break", "continue") and any(s[0] == key for s in stack):
                loop = [s for s in stack if s[0] == key][-1]
                src.jumps[i] = {"kind": kw, "loop": loop[2]}
                continue
            raise src.error(i, f"'O{label} {kw}' without a matching open 'O{label} {opener}'")
        head = stack[-1]
        data = src.jumps[head[2]]
        if kw in ("elseif", "else"):
            if head[1] != "if":
                raise src.error(i, f"'O{label} {kw}' inside 'O{label} {head[1]}'")
            data["branches"].append(i)
            src.jumps[i] = {"kind": kw, "if": head[2]}
        elif kw in ("break", "continue"):
            if head[1] == "if":
                loops = [s for s in stack if s[0] == key and s[1] != "if"]
                if not loops:
                    raise src.error(i, f"'O{label} {kw}' outside a loop")
                head = loops[-1]
            src.jumps[i] = {"kind": kw, "loop": head[2]}
        else:
            expected = {"endif": "if", "endwhile": "while", "while": "do", "endrepeat": "repeat"}[kw]
            if head[1] != expected:
                raise src.error(i, f"'O{label} {kw}' closes 'O{label} {head[1]}' (line {head[2] + 1})")
            data["end"] = i
            src.jumps[i] = {"kind": kw, "open": head[2]}
            stack.pop()
    if stack:
        key, kw, i = stack[-1]
        raise src.error(i, f"'O{key.split('#')[1]} {kw}' is never closed")
    if scope:
        raise src.error(src.subs[scope][0], f"'O{scope} sub' has no 'O{scope} endsub'")


def execute(path: Path, lines: list[str]) -> Execution:
    """Run the program (see the module docstring) and return its rows."""
    main = Source(Path(path), lines)
    _scan(main)
    sources = {str(main.path): main}
    state = ModalState(str(main.path))
    params = Parameters()
    params.system = state.system(params)
    row_line: list[int] = []
    row_src: list[int] = []             # index into files
    row_pc: list[int] = []
    row_call: list[int] = []
    site = -1                           # main-file line of the outermost call in progress
    files: list[Path] = [main.path]
    counts: list[int] = []              # words per row
    tc: list[int] = []
    tv: list[float] = []
    calls: list[dict] = []              # frames: return (source, line), entry, Fanuc or not
    repeats: dict = {}
    flags = {"break": False, "continue": False}
    src, pc = main, 0
    steps = 0
    ended = False
    in_order = True
    last_main = -1
    file_index = 0
    while True:
        if pc >= len(src.lines):
            if calls:
                raise src.error(len(src.lines) - 1, "the file ends inside a subroutine call")
            break
        if src.seen[pc]:
            steps += 1
            if steps > MAX_REPEATS:
                raise src.error(pc, f"the program runs lines again more than {MAX_REPEATS:,} times "
                                    "(a loop that never ends?)")
        else:
            src.seen[pc] = 1
        code = src.code.get(pc, _UNREAD)
        if code is _UNREAD or isinstance(code, PathFormatError):
            code = src.compiled(pc)
        if code is None:
            pc += 1
            continue
        ow = code.oword
        if ow is not None:
            before = src
            if not calls:
                site = pc if src is main else -1
            src, pc = _control(src, pc, ow, params, calls, repeats, sources, flags)
            if src is not before:
                file_index = _file_index(files, src.path)
            continue
        if code.fanuc_return:
            if not (calls and calls[-1].get("fanuc")):
                raise src.error(pc, "M99 outside a subroutine (an endless program) is not supported")
            src, pc = _return(params, calls, None, repeats)
            continue
        try:
            values = evaluate(code, params)
        except PathFormatError as exc:
            raise src.error(pc, str(exc)) from None
        if code.fanuc_call:
            if not calls:
                site = pc if src is main else -1
            src, pc = _fanuc_call(src, pc, list(zip(code.letters, values)), params, calls)
            continue
        if not code.letters:          # parameter settings only: no row
            pc += 1
            continue
        if src is main:
            if pc <= last_main:
                in_order = False
            last_main = pc
            row_line.append(pc)
        else:
            in_order = False
            row_line.append(-1)
        if len(row_line) > MAX_ROWS:
            raise src.error(pc, f"the program executes more than {MAX_ROWS:,} lines with words")
        row_src.append(file_index)
        row_pc.append(pc)
        row_call.append(site if calls else -1)
        counts.append(len(values))
        tc.extend(code.letters)
        tv.extend(values)
        if code.modal:
            state.update(code.letters, values)
        stop = code.stops
        if stop is None:
            stop = any(k == 12 and abs(v - round(v)) < 1e-4 and round(v) in (2, 30)
                       for k, v in zip(code.letters, values))
        if stop:
            ended = True
            break
        pc += 1
    n_rows = len(row_line)
    tl = np.repeat(np.arange(n_rows, dtype=np.int64), np.asarray(counts, dtype=np.int64))
    return Execution(row_line=np.asarray(row_line, dtype=np.int64), files=tuple(files),
                     row_src=np.asarray(row_src, dtype=np.int64), row_pc=np.asarray(row_pc, dtype=np.int64),
                     tl=tl, tc=np.asarray(tc, dtype=np.int64), tv=np.asarray(tv, dtype=float),
                     ended=ended, in_order=in_order, row_call=np.asarray(row_call, dtype=np.int64))


_UNREAD = object()


def _file_index(files: list, path: Path) -> int:
    if path not in files:
        files.append(path)
    return files.index(path)


def _eval_arg(src: Source, pc: int, fn, params: Parameters) -> float:
    try:
        return fn(params)
    except PathFormatError as exc:
        raise src.error(pc, str(exc)) from None


def _control(src, pc, ow, params, calls, repeats, sources, flags):
    """Execute O-word line ``pc``: the next (source, line) to run. ``flags`` carries LinuxCNC's
    ``doing_break``/``doing_continue``, which outlive their loop: a ``break`` out of a while or
    repeat loop leaves ``doing_break`` set, so the next do/while loop ends after one pass; a
    ``continue`` in a do/while loop leaves ``doing_continue`` set, so the next ``break`` out of a
    while or repeat loop goes back to its test (``interp_o_word.cc``, as rs274 runs it)."""
    kw = ow.keyword
    jump = src.jumps.get(pc)
    if kw == "sub":
        if calls and calls[-1]["entry"] == (id(src), pc):
            return src, pc + 1
        end = src.subs[ow.label][1]
        return src, end + 1                       # a definition met in passing is skipped
    if kw == "":                                   # Fanuc 'O100' met in passing: skip to M99
        end = src.subs.get(ow.label, (pc, None))[1]
        if end is None:
            raise src.error(pc, f"O{ow.label} (Fanuc-style subroutine) has no M99")
        if calls and calls[-1]["entry"] == (id(src), pc):
            return src, pc + 1
        return src, end + 1
    if kw in ("endsub", "return"):
        if not calls:
            raise src.error(pc, f"'O{ow.label} {kw}' outside a subroutine call")
        value = _eval_arg(src, pc, ow.args[0], params) if ow.args else None
        return _return(params, calls, value, repeats)
    if kw == "call":
        args = [_eval_arg(src, pc, fn, params) for fn in ow.args]
        target = _find_sub(src, pc, ow.label, sources)
        if len(calls) >= MAX_CALL_DEPTH:
            raise src.error(pc, f"subroutine calls nested more than {MAX_CALL_DEPTH} deep")
        params.enter(args)
        params.return_value, params.value_returned = 0.0, 0.0
        calls.append({"ret": (src, pc + 1), "entry": (id(target[0]), target[1]), "fanuc": False})
        return target[0], target[1] + 1
    if kw == "if":
        if _eval_arg(src, pc, ow.args[0], params) != 0.0:
            return src, pc + 1
        for b in jump["branches"]:
            bow = src.compiled(b).oword
            if bow.keyword == "else" or _eval_arg(src, b, bow.args[0], params) != 0.0:
                return src, b + 1
        return src, jump["end"] + 1
    if kw in ("elseif", "else"):                   # reached after a branch ran: to endif
        return src, src.jumps[jump["if"]]["end"] + 1
    if kw == "endif":
        return src, pc + 1
    if kw == "do":
        return src, pc + 1
    if kw == "while" and jump.get("kind") == "while" and "open" in jump:     # closes a do
        again = _eval_arg(src, pc, ow.args[0], params) != 0.0
        if again and not flags["break"]:
            return src, jump["open"] + 1
        flags["break"] = False
        return src, pc + 1
    if kw == "while":
        if _eval_arg(src, pc, ow.args[0], params) != 0.0:
            return src, pc + 1
        return src, jump["end"] + 1
    if kw == "endwhile":
        return src, jump["open"]
    if kw == "repeat":
        key = (len(calls), id(src), pc)
        if key not in repeats:
            count = _eval_arg(src, pc, ow.args[0], params)
            repeats[key] = int(count + (0.5 if count >= 0 else -0.5))
        if repeats[key] > 0:
            repeats[key] -= 1
            return src, pc + 1
        del repeats[key]
        return src, jump["end"] + 1
    if kw == "endrepeat":
        return src, jump["open"]
    if kw in ("break", "continue"):
        loop = jump["loop"]
        data = src.jumps[loop]
        if kw == "break":
            flags["break"] = True
            if data["kind"] == "do":
                return src, data["end"]            # the closing 'while' ends the loop
            if flags["continue"]:                  # LinuxCNC: a continue flag left by a do loop
                flags["continue"] = False          # makes this break loop back instead
                return src, loop
            repeats.pop((len(calls), id(src), loop), None)
            return src, data["end"] + 1
        flags["continue"] = True
        if data["kind"] == "do":
            return src, data["end"]                # the closing 'while' tests again
        flags["continue"] = False
        return src, loop
    raise src.error(pc, f"O-word '{kw}' is not supported")  # pragma: no cover - all keywords above


def _return(params, calls, value, repeats):
    frame = calls.pop()
    for key in [k for k in repeats if k[0] > len(calls)]:    # loops left by the return
        del repeats[key]
    params.leave()
    if value is not None:
        params.return_value, params.value_returned = value, 1.0
    return frame["ret"]


def _find_sub(src: Source, pc: int, label: str, sources: dict):
    """(source, first line) of subroutine ``label``: in this file, or ``NAME.ngc`` beside it."""
    for candidate in [src] + [s for s in sources.values() if s is not src]:
        if label in candidate.subs:
            return candidate, candidate.subs[label][0]
    if label.startswith("<"):
        name = label[1:-1]
        folder = src.path.parent
        for entry in (os.listdir(folder) if folder.is_dir() else []):
            if entry.lower() == name + ".ngc":
                path = folder / entry
                from fuzzyfeed.base.files import read_text

                text = read_text(path, "G-code", PathFormatError, latin1=True)
                other = Source(path, text.splitlines())
                _scan(other)
                sources[str(path)] = other
                if label in other.subs:
                    return other, other.subs[label][0]
                raise src.error(pc, f"{path.name} does not define 'O{label} sub'")
    raise src.error(pc, f"subroutine O{label} is not defined in this file"
                        + (f" nor in {label[1:-1]}.ngc beside it" if label.startswith("<") else ""))


def _fanuc_call(src, pc, words, params, calls):
    """M98 P<n> [L<k>]: call the Fanuc-style subroutine O<n> k times."""
    values = {chr(97 + k): v for k, v in words}
    if "p" not in values:
        raise src.error(pc, "M98 without a P word (the subroutine number)")
    label = str(int(round(values["p"])))
    times = int(round(values.get("l", 1.0)))
    if label not in src.subs:
        raise src.error(pc, f"M98 P{label}: no 'O{label}' subroutine in this file")
    if len(calls) + times > MAX_CALL_DEPTH * 1000:
        raise src.error(pc, f"M98 L{times}: too many repeats")
    start = src.subs[label][0]
    ret = (src, pc + 1)
    # k calls in a row: each return goes to the next call, the last back after the M98 line
    for _ in range(times):
        params.enter([])
        calls.append({"ret": ret, "entry": (id(src), start), "fanuc": True})
        ret = (src, start)
    if times < 1:
        return src, pc + 1
    return src, start + 1
