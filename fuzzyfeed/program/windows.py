"""A long program read in windows of lines: each window interpreted from the state in force after
the one before, so that memory is bounded by a window, not by the program.

:func:`read_windows` reads the file a block at a time and hands :func:`fuzzyfeed.program.read.
_interpret` ``W`` lines (:data:`WINDOW_LINES`) with the :class:`ReadState` in force before them: the
modal groups' codes, the motion mode, the F in force and the units it was read in, the units of the
line before, the tool selected and loaded, the position and the *epoch* of every axis (known, or
unknown since which line). A window's moves are then the whole read's, with the file's line
numbers and epochs. A window is kept up to the line of its last move where a fresh read gives the
whole read's chain (a move that starts a cut, or one that ends the cut before it: a rapid, a kept
move); the lines from there are read again with the next window, so that every cut lies in one
window, each window's cuts are complete and the stop of every move is decided by the move after it
(:attr:`Program.stops`). A window that holds no such line (a cut longer than a window) ends at its
last line whose moves all go on that cut (:data:`SPLIT_CUTS`): the next window goes on with the
cut as its cut 0 (:attr:`Window.continues`, :attr:`Window.continued`; checked to be one cut there),
and the cut is advised from the file in pieces (:mod:`fuzzyfeed.program.long_cut`), each window read
again from its start state (:attr:`Window.start`). Without :data:`SPLIT_CUTS` such a window is read
again twice as long, up to :data:`MAX_GROWTH` times, else the program is read whole.

Where a join would not be exact the read gives up (:class:`Fallback`) and the caller reads the
program whole, as before: parameters, expressions or O-words (executed rows), G91 axis
increments (positions are cumulative sums whose rounding depends on where they start), frames
followed line by line (G52, G92 and G92.x, G10 L2, coordinate systems other than G54), polar words,
canned cycles in G17, G5/G5.1/G5.2, cutter compensation G41/G42, a file that is not UTF-8, or any
error (the whole read then names it as it always did). Nothing is guessed.
"""

from __future__ import annotations

import codecs
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from fuzzyfeed.program.frames import START_EPOCH
from fuzzyfeed.program.line_store import LineStore
from fuzzyfeed.program.model import Program
from fuzzyfeed.program.read_words import CARRIED_GROUPS

#: Lines in a window (a window that holds no restart line is read again twice as long).
WINDOW_LINES = 100_000
#: A window grows (twice as long, read again) at most to this many times :data:`WINDOW_LINES`
#: to hold a cut; a longer cut: the program is read whole (the same memory, read once). 1: no
#: growth (a single-cut raster then pays one window's read before it is read whole, not three)
MAX_GROWTH = 1
#: A window without a line where a cut starts or ends ends inside its last cut instead (the next
#: window goes on with that cut: :attr:`Window.continues`); False: it grows (:data:`MAX_GROWTH`).
SPLIT_CUTS = True
#: Programs of at least this many lines are read in windows by ``advise`` (smaller ones whole).
MIN_LINES = 200_000
#: Bytes read from the file at a time.
_BLOCK_BYTES = 1 << 22
_PER_LINE = ("inch", "absolute", "ij_absolute", "plane", "feed_mode", "feed_value", "tool", "work_offset",
             "length_offset", "has_f", "feed_reset")
_PER_MOVE = ("move_line", "kind", "start", "end", "feed_mm_min", "cut", "centre", "turns", "arc_plane",
             "no_split", "rotary", "known", "stops", "comp_unknown")


class Fallback(Exception):
    """A window cannot be joined exactly (module docstring): read the program whole."""


@dataclass(frozen=True)
class ReadState:
    """The state in force before line ``line`` (0-based) of a program: what a window of lines
    starting there is read from (module docstring)."""

    line: int
    codes: dict                 # modal group -> code × 10 in force (read_words.CARRIED_GROUPS)
    motion: int                 # motion code × 10 in force (−1: none)
    feed_value: float           # F in force (program units / min)
    feed_scale: float           # mm per unit of that F (the units it was read in)
    scale: float                # mm per unit of the line before (an F on the next line is read in them)
    tool: int
    loaded: int
    pos: tuple                  # (3,) mm, the position after the line before
    epoch: tuple                # (3,) 0 = known, else the line since which the axis is unknown
    units_given: bool           # a G20/G21 was read before
    moved: bool                 # a move was read before (the reader's units notice is given once)

    def __post_init__(self):
        if self.line < 0 or len(self.pos) != 3 or len(self.epoch) != 3:
            raise ValueError(f"ReadState: line {self.line}, pos {self.pos}, epoch {self.epoch}")


def program_start() -> ReadState:
    """The state before a program's first line (the reader's defaults)."""
    return ReadState(line=0, codes=dict(CARRIED_GROUPS), motion=-1, feed_value=0.0, feed_scale=1.0,
                     scale=1.0, tool=-1, loaded=0, pos=(0.0, 0.0, 0.0), epoch=(START_EPOCH,) * 3,
                     units_given=False, moved=False)


@dataclass(frozen=True)
class FileScan:
    """What the whole read decides over the whole text: line count and line breaks."""

    n_lines: int
    newline: str
    strip_cr: bool


def scan_file(path: Path) -> FileScan | None:
    """The file's line count and line breaks, read a block at a time; None where the whole read
    decides otherwise than UTF-8 text (unreadable, binary, Latin-1: the whole read says why)."""
    try:
        handle = open(path, "rb")
    except OSError:
        return None
    dec = codecs.getincrementaldecoder("utf-8-sig")()
    count = crlf = cr = 0
    prev = ""                    # the last character decoded so far
    first = True
    with handle:
        while True:
            block = handle.read(_BLOCK_BYTES)
            if first and b"\x00" in block[:8192]:
                return None
            first = False
            try:
                text = dec.decode(block, final=not block)
            except UnicodeDecodeError:
                return None
            if text:
                count += text.count("\n")
                cr += text.count("\r")
                crlf += text.count("\r\n") + (prev == "\r" and text[0] == "\n")
                prev = text[-1]
            if not block:
                break
    # text.split("\n") without a final empty line, as the whole read splits it
    n = count + 1 - (prev in ("\n", ""))
    return FileScan(n_lines=n, newline="\r\n" if crlf else "\n", strip_cr=bool(crlf or cr))


class _Lines:
    """The file's lines (line breaks and, as the whole read strips them, carriage returns removed)
    from a given line on, a block at a time: only the lines not yet dropped are held."""

    def __init__(self, path: Path, scan: FileScan):
        self._handle = open(path, "rb")
        self._dec = codecs.getincrementaldecoder("utf-8-sig")()
        self._strip = scan.strip_cr
        self._first = 0               # file index of self._buf[0]
        self._buf: list[str] = []
        self._tail = ""               # a partial line
        self._eof = False

    def _more(self) -> None:
        block = self._handle.read(_BLOCK_BYTES)
        text = self._tail + self._dec.decode(block, final=not block)
        if not block:
            self._eof = True
            self._handle.close()
            parts = text.split("\n")
            if parts and parts[-1] == "":
                parts.pop()
            self._tail = ""
        else:
            parts = text.split("\n")
            self._tail = parts.pop()
        if self._strip:
            parts = [ln.rstrip("\r") for ln in parts]
        self._buf.extend(parts)

    def get(self, a: int, b: int) -> list[str]:
        """Lines a..b-1 (fewer at the end of the file)."""
        while not self._eof and self._first + len(self._buf) < b:
            self._more()
        return self._buf[a - self._first:b - self._first]

    def at_end(self, b: int) -> bool:
        while not self._eof and self._first + len(self._buf) <= b:
            self._more()
        return self._eof and self._first + len(self._buf) <= b

    def skip_to(self, a: int) -> None:
        """Lines before ``a`` are read and dropped a block at a time (a read that starts there)."""
        while not self._eof and self._first + len(self._buf) < a:
            self._more()
            self.drop(min(a, self._first + len(self._buf)))
        self.drop(min(a, self._first + len(self._buf)))

    def drop(self, a: int) -> None:
        """Lines before ``a`` are no longer needed."""
        del self._buf[:a - self._first]
        self._first = a

    def close(self) -> None:
        if not self._eof:
            self._handle.close()


@dataclass(frozen=True, eq=False)
class Window:
    """A window of a program: its lines from file line ``line0`` as a :class:`Program` (line and
    cut numbers its own: add ``line0`` and ``cut0``), ``final`` for the last."""

    line0: int
    cut0: int
    program: Program
    final: bool
    continues: bool = False        # its last cut goes on in the next window (split inside the cut)
    continued: bool = False        # its first cut is the window before's last
    start: ReadState | None = None  # the state before its first line (to read it again from there)


def read_windows(path, tools: dict | None = None, window_lines: int = WINDOW_LINES,
                 rest: list | None = None, start: Window | None = None) -> Iterator[Window]:
    """The program at ``path`` in windows (module docstring). Raises :class:`Fallback` where a join
    would not be exact. Lines after the program's end (M2/M30) beyond the last window are appended,
    a block at a time, to ``rest`` when given (as lists of lines, checked as the whole read checks
    them). ``start``: a window read before, read again from its first line on (the same windows)."""
    from fuzzyfeed.errors import FuzzyfeedError

    path = Path(path)
    if isinstance(window_lines, bool) or not isinstance(window_lines, (int, np.integer)) or window_lines < 2:
        raise ValueError(f"window_lines = {window_lines!r}; must be an integer >= 2")
    scan = scan_file(path)
    if scan is None or scan.n_lines == 0:
        raise Fallback("not UTF-8 text, or empty")
    src = _Lines(path, scan)
    try:
        state, cut0, w, continued = program_start(), 0, int(window_lines), False
        if start is not None:
            state, cut0, continued = start.start, start.cut0, start.continued
            src.skip_to(state.line)
        while True:
            a = state.line
            lines = src.get(a, a + w)
            eof = src.at_end(a + len(lines))
            try:
                prog, capture, ended = _read_window(path, lines, scan.newline, state, tools)
            except FuzzyfeedError as exc:
                raise Fallback(str(exc)) from None
            if continued and not (prog.kind.size and prog.move_line[0] == 0 and prog.cut[0] == 0):
                raise Fallback("a cut split between windows does not go on as one cut")
            if ended or eof:
                yield Window(a, cut0, prog, True, continued=continued, start=state)
                if ended and rest is not None:
                    b = a + len(lines)
                    while not src.at_end(b):
                        block = src.get(b, b + w)
                        _check_lines(path, block)
                        rest.append(block)
                        src.drop(b + len(block))
                        b += len(block)
                return
            r = _restart(capture, len(lines))
            inside = False
            if r == 0 and SPLIT_CUTS:
                r = _inside_cut(prog, capture)
                inside = r > 0
            if r == 0:
                if w >= MAX_GROWTH * int(window_lines):       # MAX_GROWTH read when called (tests set it)
                    raise Fallback(f"a cut longer than {w} lines: read whole")
                w *= 2
                continue
            nxt = _state_at(capture, r - 1, a + r, state)
            sliced = _slice(prog, lines, r)
            prog = capture = lines = None
            yield Window(a, cut0, sliced, False, continues=inside, continued=continued, start=state)
            cut0 += sliced.n_cuts - int(inside)
            src.drop(a + r)
            state, w, continued = nxt, int(window_lines), inside
    finally:
        src.close()


def _check_lines(path: Path, lines: list[str]) -> None:
    """Lines after the program's end: the whole read still checks their comments and '%'."""
    from fuzzyfeed.errors import FuzzyfeedError
    from fuzzyfeed.program.lexer import clean_lines

    try:
        clean_lines(lines, "\n".join(lines), path)
    except FuzzyfeedError as exc:
        raise Fallback(str(exc)) from None


def _read_window(path: Path, lines: list[str], newline: str, state: ReadState, tools):
    """One window's Program (lines numbered from 0), what was captured of it, and whether the
    program ends in it (M2/M30), as :func:`fuzzyfeed.program.read.parse_program` reads a text."""
    from fuzzyfeed.program.flow import needs_execution
    from fuzzyfeed.program.lexer import clean_lines, tokenise
    from fuzzyfeed.program.read import _interpret, program_body

    clean = clean_lines(lines, "\n".join(lines), path)
    body, end_line, n = program_body(clean, len(lines))
    ended = end_line < len(lines)      # an M2/M30 in the window
    del clean
    if needs_execution(body):
        raise Fallback("parameters, expressions or O-words: executed whole")
    if not body.replace("\n", ""):
        raise Fallback("a window without words")
    tokens = list(tokenise(body, path, lines))
    del body
    capture: dict = {}
    prog = _interpret(path, lines, newline, end_line, n, tokens, tools=tools, read_state=state, capture=capture)
    if capture.get("increments") or capture.get("sequential") or (capture["comp_side"] != 0).any():
        raise Fallback("G91 increments, frames followed line by line, polar words, cycles, splines or "
                       "cutter compensation")
    return prog, capture, ended


def _restart(capture: dict, n: int) -> int:
    """The window's line where the next window starts (0: none; the window must grow)."""
    rows = capture["move_rows"]
    if rows.size == 0:
        return n
    cand = rows[capture["restart"]]
    cand = cand[cand > 0]
    return int(cand.max()) if cand.size else 0


def _inside_cut(prog: Program, capture: dict) -> int:
    """The window's last line whose moves all go on a cut (not a chain's first move, not a stopper):
    the next window may start there, its first cut the same cut (0: none)."""
    rows = capture["move_rows"]
    if rows.size == 0:
        return 0
    ok = (prog.cut >= 0) & ~capture["restart"] & (rows > 0)
    cand = np.setdiff1d(rows[ok], rows[~ok])
    return int(cand.max()) if cand.size else 0


def _state_at(capture: dict, i: int, line: int, before: ReadState) -> ReadState:
    """The state after the window's line ``i``: the next window's start (at file line ``line``)."""
    codes = {name: int(arr[i]) for name, arr in capture["codes"].items()}
    pos, epoch = capture["pos_after"][i], capture["epoch_after"][i]
    return ReadState(line=line, codes=codes, motion=int(capture["motion"][i]),
                     feed_value=float(capture["feed_value"][i]), feed_scale=float(capture["feed_scale"][i]),
                     scale=float(capture["scale"][i]), tool=int(capture["tool"][i]),
                     loaded=int(capture["loaded"][i]), pos=tuple(float(v) for v in pos),
                     epoch=tuple(int(v) for v in epoch),
                     units_given=before.units_given or bool(capture["units_given"][:i + 1].any()),
                     moved=before.moved or bool((capture["move_rows"] <= i).any()))


def _slice(prog: Program, lines: list[str], r: int) -> Program:
    """``prog``'s lines 0..r-1 and their moves (a window's part that no later line changes)."""
    m = int(np.searchsorted(prog.move_line, r))
    fields = {name: getattr(prog, name)[:r] for name in _PER_LINE}
    fields.update({name: getattr(prog, name)[:m] for name in _PER_MOVE if getattr(prog, name) is not None})
    return replace(prog, lines=LineStore(lines[:r]), end_line=r, **fields)
