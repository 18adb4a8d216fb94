"""LinuxCNC's expressions and parameters: one program line read into words, parameter settings
and an O-word, with the values computed as LinuxCNC's interpreter computes them.

A line is read in LinuxCNC's form: comments removed, no spaces, lower case (``clean_line``). A
value is a number (digits and one ``.``, no exponent: ``1e6`` is the word ``1`` then ``E6``), a
parameter ``#n`` (``#1``–``#5601``; the index may itself be ``##2`` or ``#[...]``), a named
parameter ``#<name>`` (local to the subroutine; ``#<_name>`` global), an expression ``[...]`` or
a function ``abs acos asin atan[y]/[x] cos exp exists[#<name>] fix fup ln round sin sqrt tan``
(degrees), optionally signed. Binary operators by precedence, left to right within a level
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

import math
import re
from dataclasses import dataclass

from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.program.params import MAX_PARAMETER, SUB_PARAMS, Parameters

#: EQ/NE/LE/GE compare within this (TOLERANCE_EQUAL).
TOLERANCE_EQUAL = 1e-6
#: Longest expression nesting read (LinuxCNC's stack is 7 operators deep per level; this bounds
#: the recursion of brackets inside brackets).
MAX_DEPTH = 64

_UNARY = {
    "abs": abs, "acos": None, "asin": None, "atan": None, "cos": None, "exp": math.exp,
    "exists": None, "fix": math.floor, "fup": math.ceil, "ln": None, "round": None, "sin": None,
    "sqrt": None, "tan": None,
}
# longest names first, as LinuxCNC's reader tries them
_UNARY_NAMES = sorted(_UNARY, key=len, reverse=True)
_BINARY = [("**", 6, "**"), ("*", 5, "*"), ("/", 5, "/"), ("mod", 5, "mod"), ("+", 4, "+"),
           ("-", 4, "-"), ("eq", 3, "eq"), ("ne", 3, "ne"), ("gt", 3, "gt"), ("ge", 3, "ge"),
           ("lt", 3, "lt"), ("le", 3, "le"), ("and", 2, "and"), ("or", 2, "or"), ("xor", 2, "xor"),
           ("^", 6, "**")]
_NUMBER = re.compile(r"[+-]*[0-9.]*")
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


# ------------------------------------------------------------------------------ compiling
class _Reader:
    """Recursive-descent reader of one cleaned line (LinuxCNC's read_real_value & co)."""

    def __init__(self, text: str):
        self.text = text
        self.i = 0
        self.depth = 0

    def peek(self, k: int = 0) -> str:
        j = self.i + k
        return self.text[j] if j < len(self.text) else ""

    def fail(self, message: str) -> PathFormatError:
        return _err(message)

    def value(self):
        """A real value: number, parameter, expression, function, or a sign before one."""
        c, c1 = self.peek(), self.peek(1)
        if not c:
            raise self.fail("a value is missing at the end of the line")
        if c == "[":
            return self.expression()
        if c == "#":
            return self.parameter()
        if c in "+-" and c1 and not c1.isdigit() and c1 != ".":
            self.i += 1
            inner = self.value()
            if c == "+":
                return inner
            if hasattr(inner, "const"):
                return _const(-inner.const)
            return lambda p: -inner(p)
        if "a" <= c <= "z":
            return self.unary()
        m = _NUMBER.match(self.text, self.i)
        raw = m.group(0)
        self.i = m.end()
        return _const(_parse_number(raw))

    def integer(self):
        """A value that must be within 0.0001 of an integer (LinuxCNC's read_integer_value)."""
        fn = self.value()
        if hasattr(fn, "const"):
            return _const(_as_integer(fn.const))

        def get(p):
            return _as_integer(fn(p))
        return get

    def expression(self):
        """``[ ... ]`` with LinuxCNC's precedence, left to right within a level."""
        assert self.peek() == "["
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise self.fail(f"expressions nested more than {MAX_DEPTH} deep")
        self.i += 1
        operands = [self.value()]
        ops = []
        while True:
            op = self.operation()
            if op is None:
                break
            ops.append(op)
            operands.append(self.value())
        self.depth -= 1
        return _build(operands, ops)

    def operation(self):
        """The next binary operator (name, precedence), or None at ``]``."""
        c = self.peek()
        if c == "]":
            self.i += 1
            return None
        if not c:
            raise self.fail("expression not closed: ']' missing")
        for text, prec, name in _BINARY:
            if self.text.startswith(text, self.i):
                self.i += len(text)
                return name, prec
        raise self.fail(f"unknown operation at '{self.text[self.i:self.i + 8]}' in an expression")

    def name(self) -> str:
        assert self.peek() == "<"
        end = self.text.find(">", self.i)
        if end < 0:
            raise self.fail("named parameter '#<' not closed with '>'")
        name = self.text[self.i + 1:end]
        self.i = end + 1
        if not name:
            raise self.fail("named parameter '#<>' has no name")
        return name

    def parameter(self):
        assert self.peek() == "#"
        self.i += 1
        if self.peek() == "<":
            name = self.name()
            return lambda p: p.get_named(name)
        index = self.integer()
        if hasattr(index, "const"):
            k = index.const
            return lambda p: p.get(k)
        return lambda p: p.get(index(p))

    def unary(self):
        for name in _UNARY_NAMES:
            if self.text.startswith(name, self.i):
                self.i += len(name)
                break
        else:
            raise self.fail(f"unknown word '{self.text[self.i:self.i + 8]}' where a value or a "
                            "function (sin, cos, sqrt, ...) should be")
        if self.peek() != "[":
            raise self.fail(f"'[' missing after the function {name.upper()}")
        if name == "exists":
            self.i += 1
            if self.peek() != "#":
                raise self.fail("EXISTS needs a parameter: EXISTS[#<name>]")
            self.i += 1
            if self.peek() == "<":
                pname = self.name()
                test = lambda p: 1.0 if p.exists(pname) else 0.0
            else:
                index = self.integer()
                test = lambda p: 1.0 if 1 <= index(p) <= MAX_PARAMETER else 0.0
            if self.peek() != "]":
                raise self.fail("']' missing after EXISTS[#...")
            self.i += 1
            return test
        arg = self.expression()
        if name == "atan":
            if self.peek() != "/":
                raise self.fail("ATAN needs two arguments: ATAN[y]/[x]")
            self.i += 1
            if self.peek() != "[":
                raise self.fail("'[' missing after the '/' of ATAN[y]/[x]")
            arg2 = self.expression()
            return _fold(lambda p: math.degrees(math.atan2(arg(p), arg2(p))), arg, arg2)
        fn = _function(name)
        return _fold(lambda p: _finite(fn(arg(p))), arg)


def _parse_number(raw: str) -> float:
    """A LinuxCNC number: signs then digits and at most one '.'."""
    body = raw.lstrip("+-")
    signs = raw[:len(raw) - len(body)]
    if len(signs) > 1 or not body or body == "." or body.count(".") > 1 or not re.fullmatch(r"[0-9.]+", body):
        raise _err(f"bad number format '{raw}'" if raw else "a number is missing")
    value = float(body)
    if not math.isfinite(value):
        raise _err(f"number {raw[:24]}{'...' if len(raw) > 24 else ''} is too large")
    return -value if signs == "-" else value


def _as_integer(value: float) -> int:
    k = math.floor(value)
    if value - k > 0.9999:
        return k + 1
    if value - k > 0.0001:
        raise _err(f"{value:g} is not an integer (a parameter number, M, T, H, D, L and O need one)")
    return int(k)


def _finite(value: float) -> float:
    if math.isnan(value):
        raise _err("calculation resulted in 'not a number'")
    if math.isinf(value):
        raise _err("calculation resulted in 'infinity'")
    return value


def _function(name: str):
    def acos(x):
        if not -1.0 <= x <= 1.0:
            raise _err(f"argument to ACOS out of range: {x:g}")
        return math.degrees(math.acos(x))

    def asin(x):
        if not -1.0 <= x <= 1.0:
            raise _err(f"argument to ASIN out of range: {x:g}")
        return math.degrees(math.asin(x))

    def ln(x):
        if x <= 0.0:
            raise _err(f"zero or negative argument to LN: {x:g}")
        return math.log(x)

    def sqrt(x):
        if x < 0.0:
            raise _err(f"negative argument to SQRT: {x:g}")
        return math.sqrt(x)

    def exp(x):
        try:
            return math.exp(x)
        except OverflowError:
            raise _err("calculation resulted in 'infinity'") from None

    table = {"abs": abs, "acos": acos, "asin": asin, "cos": lambda x: math.cos(math.radians(x)),
             "exp": exp, "fix": lambda x: float(math.floor(x)), "fup": lambda x: float(math.ceil(x)),
             "ln": ln, "round": lambda x: float(int(x + (-0.5 if x < 0.0 else 0.5))),
             "sin": lambda x: math.sin(math.radians(x)), "sqrt": sqrt,
             "tan": lambda x: math.tan(math.radians(x))}
    return table[name]


def _binary(name: str, a: float, b: float) -> float:
    if name == "+":
        r = a + b
    elif name == "-":
        r = a - b
    elif name == "*":
        r = a * b
    elif name == "/":
        if b == 0.0:
            raise _err("attempt to divide by zero")
        r = a / b
    elif name == "mod":
        if b == 0.0:
            raise _err("attempt to divide by zero (MOD 0)")
        r = math.fmod(a, b)
        if r < 0.0:
            r += abs(b)
    elif name == "**":
        if a < 0.0 and math.floor(b) != b:
            raise _err("attempt to raise a negative number to a non-integer power")
        try:
            r = math.pow(a, b)
        except (OverflowError, ValueError):
            raise _err("calculation resulted in 'infinity'") from None
    elif name == "and":
        r = 0.0 if a == 0.0 or b == 0.0 else 1.0
    elif name == "or":
        r = 1.0 if a != 0.0 or b != 0.0 else 0.0
    elif name == "xor":
        r = 1.0 if (a == 0.0) != (b == 0.0) else 0.0
    elif name == "eq":
        r = 1.0 if abs(a - b) < TOLERANCE_EQUAL else 0.0
    elif name == "ne":
        r = 1.0 if abs(a - b) >= TOLERANCE_EQUAL else 0.0
    elif name == "le":
        r = 1.0 if abs(a - b) < TOLERANCE_EQUAL or a <= b else 0.0
    elif name == "ge":
        r = 1.0 if abs(a - b) < TOLERANCE_EQUAL or a >= b else 0.0
    elif name == "gt":
        r = 1.0 if a > b else 0.0
    else:  # lt
        r = 1.0 if a < b else 0.0
    return _finite(r)


def _build(operands: list, ops: list):
    """The expression tree of LinuxCNC's operator-precedence reader (left to right within a
    precedence level), as one function of the parameters."""
    if not ops:
        return operands[0]
    values = [operands[0]]
    stack: list = []
    for (name, prec), right in zip(ops, operands[1:]):
        while stack and stack[-1][1] >= prec:
            top, _ = stack.pop()
            b, a = values.pop(), values.pop()
            values.append(_combine(top, a, b))
        stack.append((name, prec))
        values.append(right)
    while stack:
        top, _ = stack.pop()
        b, a = values.pop(), values.pop()
        values.append(_combine(top, a, b))
    return values[0]


def _combine(name, a, b):
    return _fold(lambda p: _binary(name, a(p), b(p)), a, b)


def _const(value: float):
    """A value known when the line is read (its function carries it as ``.const``)."""
    fn = lambda p: value      # noqa: E731 - a function object that can carry the attribute
    fn.const = value
    return fn


def _fold(fn, *args):
    """``fn`` computed once when every argument is a constant and it raises no error (an error
    belongs to the line's execution, which may never come)."""
    if all(hasattr(a, "const") for a in args):
        try:
            return _const(fn(None))
        except PathFormatError:
            return fn
    return fn


# ------------------------------------------------------------------------------ a whole line
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
    r = _Reader(text)
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


def _oword(r: _Reader) -> OWord:
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
