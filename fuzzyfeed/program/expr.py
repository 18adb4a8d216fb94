"""LinuxCNC's expressions and parameters: one program line read into words, parameter settings
and an O-word, with the values computed as LinuxCNC's interpreter computes them.

A line is read in LinuxCNC's form: comments removed, no spaces, lower case (``clean_line``). Its
values are read by :class:`~fuzzyfeed.program.value_reader.ValueReader`: a value is a number
(digits and one ``.``, no exponent: ``1e6`` is the word ``1`` then ``E6``), a parameter ``#n``
(``#1``–``#5601``; the index may itself be ``##2`` or ``#[...]``), a named parameter ``#<name>``
(local to the subroutine; ``#<_name>`` global), an expression ``[...]`` or a function ``abs acos
asin atan[y]/[x] cos exp exists[#<name>] fix fup ln round sin sqrt tan`` (degrees), optionally
signed. Binary operators by precedence, left to right within a level
(``interp_internal.cc``, ``precedence``): ``**``; ``* / mod``; ``+ -``; ``eq ne gt ge lt le``
(EQ within 1e-6); ``and or xor``. ``mod`` is never negative, ``**`` of a negative base needs an
integer exponent, division by zero, ``sqrt``/``ln``/``acos``/``asin`` out of range, NaN and
infinity are errors, as in LinuxCNC. ``^`` inside brackets (LinuxCNC's power is ``**``) is read
as a power, as Mach3 and Fanuc macro dialects write it; outside brackets ``^`` and ``@`` are
LinuxCNC's polar words (angle and radius), letter codes 26 and 27 of a line's words.

Parameter settings on a line (``#1 = 5``, ``#<depth> = [#1 * 2]``) take effect after the whole
line is read ("in parallel": ``#1=10 #2=#1`` gives ``#2`` the old ``#1``). A line is compiled once
(:func:`compile_line`) and evaluated at every execution against a :class:`Parameters` store.
Errors are :class:`~fuzzyfeed.errors.PathFormatError` with the message only; the caller adds the
file and line.
"""

from __future__ import annotations

from dataclasses import dataclass

from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.program.params import SUB_PARAMS, Parameters
from fuzzyfeed.program.value_reader import ValueReader

O_KEYWORDS = ("sub", "endsub", "call", "do", "while", "repeat", "if", "elseif", "else", "endif",
              "break", "continue", "endwhile", "endrepeat", "return")
#: Letters that are words of a line (``o`` only at its start, ``n`` only first).
WORD_LETTERS = set("abcdefghijklmnpqrstuvwxyz")
#: The polar words' letter codes after the 26 letters: ``@`` radius, ``^`` angle.
POLAR_LETTERS = {"@": 26, "^": 27}


def _err(message: str) -> PathFormatError:
    return PathFormatError(message)


def clean_line(raw: str) -> str:
    """``raw`` in LinuxCNC's reading form: comments ``(...)`` and ``; ...`` removed, spaces and
    tabs removed, lower case. A comment not closed on its line is an error."""
    if "(" in raw or ";" in raw or ")" in raw:
        out = []
        depth = False
        for ch in raw:
            if depth:
                if ch == ")":
                    depth = False
                elif ch == "(":
                    raise _err("nested comment '(' inside '(...)'")
                continue
            if ch == "(":
                depth = True
            elif ch == ";":
                break
            elif ch == ")":
                raise _err("')' without '('")
            else:
                out.append(ch)
        if depth:
            raise _err("comment '(' not closed on this line")
        raw = "".join(out)
    return raw.replace(" ", "").replace("\t", "").lower()


@dataclass(frozen=True)
class OWord:
    """The O-word of a line: its label (``100`` or ``<name>``), keyword and argument values."""

    label: str
    keyword: str           # one of O_KEYWORDS, or "" for a bare Fanuc-style O number
    args: tuple            # compiled argument expressions (call, while, if, repeat, return)


@dataclass(frozen=True)
class LineCode:
    """A compiled line: its words (letter, value function) in order without N, its parameter
    settings ((number function | name), value function), its O-word (or None), and what the
    executor needs fast: the letters as indices 0–25, the values when all are constants, whether
    it stops the program (M2/M30; None when an M word is computed) and sets modal state."""

    words: tuple
    settings: tuple
    oword: OWord | None
    fanuc_call: bool = False          # M98 P... [L...]
    fanuc_return: bool = False        # M99
    letters: tuple = ()
    constants: tuple | None = None
    stops: bool | None = False
    modal: bool = False


#: Longest line (without comments and spaces) read with expressions: LinuxCNC reads 255
#: characters; a longer one is refused before it is compiled.
MAX_LINE = 4096


def compile_line(text: str) -> LineCode:
    """Compile a cleaned line (see :func:`clean_line`); raises PathFormatError on bad syntax."""
    if len(text) > MAX_LINE:
        raise _err(f"a line of {len(text):,} characters (without comments and spaces); LinuxCNC reads "
                   f"at most 255, fuzzyfeed at most {MAX_LINE:,} in a program with expressions")
    r = ValueReader(text)
    if r.peek() == "/":
        r.i += 1
    words: list = []
    settings: list = []
    if r.peek() == "n":
        r.i += 1
        r.value()                            # the line number: no effect
    if r.peek() == "o":
        return LineCode((), (), _oword(r))
    fanuc_call = fanuc_return = False
    while r.i < len(text):
        c = r.peek()
        if c == "#":
            r.i += 1
            if r.peek() == "<":
                target = r.name()
            else:
                target = r.integer()
            if r.peek() != "=":
                raise r.fail("'=' missing in a parameter setting (#... = value)")
            r.i += 1
            settings.append((target, r.value()))
        elif c in WORD_LETTERS and c != "n":
            r.i += 1
            words.append((c, r.value()))
        elif c in "@^":                      # polar radius and angle: words of their own
            r.i += 1
            words.append((c, r.value()))
        elif c == "$":
            r.i += 1
            r.value()                        # spindle selection: no effect on the path
        elif c == "n":
            raise r.fail("N (line number) must come first on its line")
        elif c == "o":
            raise r.fail("an O-word must come first on its line")
        else:
            raise r.fail(f"bad character '{c}' used")
    stops: bool | None = False
    for letter, fn in words:
        if letter == "m":
            if not hasattr(fn, "const"):
                stops = None
                continue
            value = fn.const
            if value == 98:
                fanuc_call = True
            elif value == 99:
                fanuc_return = True
            elif stops is not None and value in (2.0, 30.0):
                stops = True
    constants = tuple(fn.const for _, fn in words) if all(hasattr(fn, "const") for _, fn in words) else None
    return LineCode(tuple(words), tuple(settings), None, fanuc_call, fanuc_return,
                    letters=tuple(POLAR_LETTERS.get(c, ord(c) - 97) for c, _ in words),
                    constants=constants, stops=stops,
                    modal=any(c in "gfstm" for c, _ in words))


def _oword(r: ValueReader) -> OWord:
    r.i += 1
    if r.peek() == "<":
        label = "<" + r.name() + ">"
    else:
        number = r.integer()
        try:
            label = str(number(None))
        except (AttributeError, TypeError):
            raise r.fail("an O-word number must be a plain number or <name>") from None
    keyword = ""
    for kw in ("sub", "endsub", "call", "do", "while", "repeat", "if", "elseif", "else", "endif",
               "break", "continue", "endwhile", "endrepeat", "return"):
        if r.text.startswith(kw, r.i):
            keyword = kw
            r.i += len(kw)
            break
    args: list = []
    if keyword in ("while", "if", "elseif", "repeat"):
        if r.peek() != "[":
            raise r.fail(f"'[' missing after '{keyword}'")
        args.append(r.expression())
    elif keyword in ("call",):
        while r.peek() == "[":
            if len(args) >= SUB_PARAMS:
                raise r.fail(f"more than {SUB_PARAMS} subroutine arguments")
            args.append(r.expression())
    elif keyword in ("return", "endsub") and r.peek() == "[":
        args.append(r.expression())
    elif not keyword and r.i < len(r.text):
        raise r.fail(f"unknown O-word keyword at '{r.text[r.i:r.i + 10]}'")
    if r.i < len(r.text):
        raise r.fail("unexpected characters after the O-word")
    return OWord(label, keyword, tuple(args))


def evaluate(code: LineCode, params: Parameters) -> list[float]:
    """The values of ``code``'s words now (in the order of ``code.letters``), then its parameter
    settings applied."""
    words = list(code.constants) if code.constants is not None else [fn(params) for _, fn in code.words]
    if code.settings:
        done = [(target if isinstance(target, str) else target(params), fn(params))
                for target, fn in code.settings]
        for target, value in done:
            if isinstance(target, str):
                params.set_named(target, value)
            else:
                params.set(target, value)
    return words
