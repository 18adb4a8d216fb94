"""Which feed moves of a program fuzzyfeed judges, and why the others are not (issue 40, "claim
only what was judged").

A feed move (any move but a rapid or a homing move) is *judged* when it belongs to a cut: its
path is the one the controller runs, at the F the program gives, so the advice and the contour
error measured on it say something about the part. The others keep their words as written and
nothing is claimed about them; each gets the first reason of :data:`REASONS` that applies, read
from the :class:`~fuzzyfeed.program.model.Program`'s fields (kind, feed mode, rotary, known,
comp_unknown, move_line, cut). Moves of zero length on a known path are left out of the counts
(there is nothing to judge).

Shares: of the moves; of the length (Σ |move| over the moves whose both ends are known); of the
time at the programmed feed (t = L / F in G94, 1 / F minutes in G93 inverse time; unknown for
G95 feed per revolution, spindle-synchronised motion, canned cycles and moves of unknown
position, which are left out of that sum and counted).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzyfeed.program.model import ADVISED_KINDS, CYCLE, HOME, KEPT, RAPID, SYNCED, Program

#: (key, text) of every reason a feed move is not judged, in the order they are tried.
REASONS = (
    ("synced", "spindle-synchronised motion (G33/G33.1/G76): its speed is the spindle's, not an F"),
    ("cycle", "canned cycle (G73, G76, G81-G89)"),
    ("per_rev", "feed per revolution (G95)"),
    ("inverse_time", "inverse time feed (G93)"),
    ("rotary", "rotary axis (A/B/C) motion"),
    ("comp_no_tool", "cutter compensation without a tool diameter (give --tool-table): the programmed "
                     "contour, not the tool centre's path"),
    ("other_file", "lines of a called file"),
    ("unknown", "kept as written: a position fuzzyfeed does not place (offsets, G28/G30/G53, polar "
                "words, ...)"),
    ("no_cut", "in no cut"),
)
#: How many first lines of each reason are named.
FIRST_LINES = 3


@dataclass(frozen=True)
class NotJudged:
    """The feed moves not judged for one reason: how many, their length (mm, those of known
    length) and the first lines (1-based) they come from."""

    key: str
    text: str
    moves: int
    length_mm: float
    first_lines: tuple[int, ...]

    def describe(self) -> str:
        where = ", ".join(str(v) for v in self.first_lines)
        more = ", ..." if self.moves > len(self.first_lines) else ""
        return f"{self.moves} move(s) {self.text} (line {where}{more})" if where else \
            f"{self.moves} move(s) {self.text}"


@dataclass(frozen=True)
class Coverage:
    """The judged part of a program (module docstring). Shares are percentages; ``time`` is at the
    programmed feed, no acceleration."""

    moves: int
    judged_moves: int
    length_mm: float
    judged_length_mm: float
    unknown_length_moves: int
    time_s: float
    judged_time_s: float
    unknown_time_moves: int
    not_judged: tuple[NotJudged, ...]

    def __post_init__(self):
        if not (0 <= self.judged_moves <= self.moves):
            raise ValueError(f"judged_moves = {self.judged_moves}; must lie in [0, {self.moves}]")

    @property
    def complete(self) -> bool:
        """Every feed move is judged."""
        return self.judged_moves == self.moves

    @staticmethod
    def _pct(part: float, whole: float) -> float:
        return 100.0 * part / whole if whole > 0 else 100.0

    @property
    def moves_pct(self) -> float:
        return self._pct(self.judged_moves, self.moves)

    @property
    def length_pct(self) -> float:
        return self._pct(self.judged_length_mm, self.length_mm)

    @property
    def time_pct(self) -> float:
        return self._pct(self.judged_time_s, self.time_s)

    def not_judged_text(self) -> str:
        """"" when complete, else the reasons with counts and first lines, ``; `` between."""
        return "; ".join(n.describe() for n in self.not_judged)

    def summary(self) -> str:
        """One line: what share is judged and what is not."""
        if self.moves == 0:
            return "judged: no feed move"
        text = (f"judged: {self.judged_moves} of {self.moves} feed moves, {self.length_share()}, "
                f"{self.time_share()} at the programmed F")
        return text + ("" if self.complete else f"; not judged: {self.not_judged_text()}")

    def length_share(self) -> str:
        """The judged share of the length as text: "at most" when some moves' length is unknown
        (they are left out of the whole, so the share is an upper bound)."""
        if self.unknown_length_moves:
            return (f"at most {self.length_pct:.1f} % of the length ({self.unknown_length_moves} move(s) "
                    "of unknown length)")
        return f"{self.length_pct:.1f} % of the length"

    def time_share(self) -> str:
        """The judged share of the time as text, "at most" as :meth:`length_share`."""
        if self.unknown_time_moves:
            return (f"at most {self.time_pct:.1f} % of the time ({self.unknown_time_moves} move(s) of "
                    "unknown time)")
        return f"{self.time_pct:.1f} % of the time"

    def figures(self) -> dict[str, object]:
        """The columns a CSV row or a batch summary carries; a share is NaN (an empty cell) when some
        moves' length or time is unknown (the text's "at most" bound is not a figure)."""
        nan = float("nan")
        return {"judged_moves_pct": round(self.moves_pct, 3),
                "judged_length_pct": nan if self.unknown_length_moves else round(self.length_pct, 3),
                "judged_time_pct": nan if self.unknown_time_moves else round(self.time_pct, 3),
                "not_judged": self.not_judged_text()}


def move_reasons(program: Program) -> np.ndarray:
    """Per move: −2 for a rapid or homing move or a feed move of zero length on a known path (not
    counted), −1 for a judged move, else the index in :data:`REASONS` of why it is not judged."""
    kind = program.kind
    n = kind.size
    out = np.full(n, -1, dtype=np.int64)
    if n == 0:
        return out
    rows = program.rows
    if rows is not None:
        mode = rows.feed_mode[rows.move_row]
    else:
        mode = program.feed_mode[np.maximum(program.move_line, 0)]
    no = np.zeros(n, bool)
    rotary = program.rotary if program.rotary is not None else no
    known = program.known if program.known is not None else ~no
    comp = program.comp_unknown if program.comp_unknown is not None else no
    judged = program.cut >= 0
    tests = {"synced": kind == SYNCED, "cycle": kind == CYCLE, "per_rev": mode == 95,
             "inverse_time": mode == 93, "rotary": rotary, "comp_no_tool": comp,
             "other_file": program.move_line < 0, "unknown": (kind == KEPT) | ~known,
             "no_cut": ~judged}
    undecided = ~np.isin(kind, (RAPID, HOME))
    # a judged move on the tool-centre path stays judged unless compensation's radius is unknown
    for k, (key, _) in enumerate(REASONS):
        hit = undecided & tests[key] & (~judged | (key == "comp_no_tool"))
        out[hit] = k
        undecided &= ~hit
    out[np.isin(kind, (RAPID, HOME))] = -2
    moved = np.any(program.end != program.start, axis=1) | (program.turns != 0) | np.isin(
        np.arange(n), list(program.nurbs))
    zero = (out >= 0) & ~moved & known & np.isin(kind, ADVISED_KINDS) & (out == len(REASONS) - 1)
    out[zero] = -2
    return out


def program_coverage(program: Program) -> Coverage:
    """The :class:`Coverage` of ``program`` (module docstring)."""
    reason = move_reasons(program)
    counted = reason >= -1
    lengths = program.move_lengths() if reason.size else np.zeros(0)
    known = program.known if program.known is not None else np.ones(reason.size, bool)
    kind = program.kind
    length_known = counted & known & (kind != KEPT) & np.isfinite(lengths)
    rows = program.rows
    if rows is not None:
        mode, f_value = rows.feed_mode[rows.move_row], rows.feed_value[rows.move_row]
    else:
        line = np.maximum(program.move_line, 0)
        mode, f_value = program.feed_mode[line], program.feed_value[line]
    feed = program.feed_mm_min
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(mode == 93, 60.0 / f_value, 60.0 * lengths / feed)
    time_known = length_known & (mode != 95) & ~np.isin(kind, (SYNCED, CYCLE)) & np.isfinite(t) & (t >= 0)
    judged = reason == -1
    groups = []
    for k, (key, text) in enumerate(REASONS):
        sel = reason == k
        if not sel.any():
            continue
        first = program.move_line[sel]
        first = [int(v) + 1 for v in first[first >= 0]]
        seen = list(dict.fromkeys(first))[:FIRST_LINES]
        groups.append(NotJudged(key=key, text=text, moves=int(sel.sum()),
                                length_mm=float(lengths[sel & length_known].sum()), first_lines=tuple(seen)))
    return Coverage(moves=int(counted.sum()), judged_moves=int(judged.sum()),
                    length_mm=float(lengths[length_known].sum()),
                    judged_length_mm=float(lengths[judged & length_known].sum()),
                    unknown_length_moves=int((counted & ~length_known).sum()),
                    time_s=float(t[time_known].sum()), judged_time_s=float(t[judged & time_known].sum()),
                    unknown_time_moves=int((counted & ~time_known).sum()), not_judged=tuple(groups))
