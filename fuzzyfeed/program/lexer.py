"""The words of a plain program (no parameters, expressions or O-words) read at once with numpy:
comments and '%' lines removed, every word a (line, letter, value) triple; anything that is not a
letter followed by a number is one error naming the file, the line and the text."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fuzzyfeed.errors import PathFormatError

LETTERS = "ABCDEFGHIJKLMNOPQRSTUVWXYZ"
_NUMBER_CHARS = b"0123456789.+-"
_TO_SPACE = str.maketrans({c: " " for c in LETTERS + "\n"})


def fail_at(path: Path, line: int, message: str) -> None:
    raise PathFormatError(f"{path}:{line}: {message}")


def _strip_comments(raw: str, path: Path, number: int) -> str:
    depth = 0
    out = []
    for ch in raw:
        if ch == ";" and not depth:
            break
        if ch == "(":
            if depth:
                fail_at(path, number, "nested comment '(' inside '(...)'")
            depth = 1
        elif ch == ")":
            if not depth:
                fail_at(path, number, "')' without '('")
            depth = 0
        elif not depth:
            out.append(ch)
    if depth:
        fail_at(path, number, "comment '(' not closed on this line")
    return "".join(out)


def clean_lines(lines: list[str], text: str, path: Path) -> list[str]:
    """Program lines without comments, '%' lines or a leading '/', upper case, no blanks."""
    clean = list(lines)
    if "(" in text or ")" in text or ";" in text:
        for i, raw in enumerate(lines):
            if "(" in raw or ")" in raw or ";" in raw:
                clean[i] = _strip_comments(raw, path, i + 1)
    if "%" in text:
        for i, raw in enumerate(clean):
            if "%" in raw:
                if raw.strip() != "%":
                    fail_at(path, i + 1, f"'%' in {lines[i].strip()!r}: '%' must stand alone on its line")
                clean[i] = ""
    return clean


def _malformed(path: Path, body: str, pos: int, lines: list[str]) -> None:
    line = body.count("\n", 0, pos) + 1
    text = lines[line - 1].strip()
    start = pos   # a parameter name reaches back to its '#<' (the checks may stop inside it)
    while start > 0 and (body[start - 1].isalpha() or body[start - 1] in "_<"):
        start -= 1
    if start > 0 and body[start - 1] == "#":
        pos = start - 1
    frag = body[pos:pos + 12].split("\n")[0]
    if frag[:1] in "#[<" or (frag[:1] == "O"):
        fail_at(path, line, f"'{frag}' in {text!r}: parameters, expressions and O-words are not "
                          "supported (expand the program first)")
    fail_at(path, line, f"malformed word at '{frag}' in {text!r}; expected a letter followed by a number")


def tokenise(body: str, path: Path, lines: list[str]):
    """(line index, letter index 0-25, value) arrays of every word of ``body``."""
    raw = body.encode("ascii", errors="replace")
    b = np.frombuffer(raw, dtype=np.uint8)
    if b.size == 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    is_letter = (b >= 65) & (b <= 90)
    is_nl = b == 10
    is_num = np.isin(b, np.frombuffer(_NUMBER_CHARS, dtype=np.uint8))
    bad = ~(is_letter | is_nl | is_num)
    if bad.any():
        _malformed(path, body, int(np.argmax(bad)), lines)
    letter_pos = np.flatnonzero(is_letter)
    nxt = np.append(b, 10)[letter_pos + 1]
    no_number = ~np.isin(nxt, np.frombuffer(_NUMBER_CHARS, dtype=np.uint8))
    if no_number.any():
        _malformed(path, body, int(letter_pos[np.argmax(no_number)]), lines)
    prev = np.insert(b, 0, 10)[:-1]
    orphan = is_num & ((prev == 10) | ((prev != 10) & ~np.insert(is_letter | is_num, 0, False)[:-1]))
    if orphan.any():
        _malformed(path, body, int(np.argmax(orphan)), lines)
    del is_num, bad, prev, orphan, nxt, no_number
    values = _numbers(body, letter_pos, path, lines)
    # line of each word: the newlines before it (no per-byte count: 8 B a byte of the program)
    line_of = np.searchsorted(np.flatnonzero(is_nl), letter_pos)
    return line_of, b[letter_pos].astype(np.int64) - 65, values


def _numbers(body: str, letter_pos: np.ndarray, path: Path, lines: list[str]) -> np.ndarray:
    """The number after every letter. numpy's C parser reads the whole text at once (no Python
    string per word); where it does not read exactly one float per word (a malformed number such
    as ``1.2.3``), each word is read by ``float`` to name the first bad one."""
    import warnings

    spaced = body.translate(_TO_SPACE)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            values = np.fromstring(spaced, dtype=float, sep=" ")
        except (ValueError, DeprecationWarning):
            values = None
    if values is not None and values.size == letter_pos.size:
        return values
    numbers = spaced.split()
    for k, text in enumerate(numbers):
        try:
            float(text)
        except ValueError:
            _malformed(path, body, int(letter_pos[k]), lines)
    values = np.array(numbers, dtype=float)
    if values.size != letter_pos.size:  # pragma: no cover - guarded by the checks above
        _malformed(path, body, int(letter_pos[0]), lines)
    return values
