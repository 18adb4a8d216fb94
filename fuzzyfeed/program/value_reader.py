"""LinuxCNC's real values read from a cleaned program line (:mod:`fuzzyfeed.program.expr`) and
compiled into functions of the parameters, computed as LinuxCNC's interpreter computes them.

A value is a number, a parameter ``#n`` / ``#<name>``, an expression ``[...]`` or a function
``name[...]``, optionally signed (``interp_read.cc``, ``read_real_value``). Expressions are read by
LinuxCNC's operator-precedence rule, left to right within a level (``interp_internal.cc``,
``precedence``); each operator and function raises LinuxCNC's error where LinuxCNC does (division
by zero, ``sqrt``/``ln``/``acos``/``asin`` out of range, NaN, infinity). A value known when the line
is read is folded into a constant (its function carries ``.const``); one whose computation fails
stays a function, since the error belongs to the line's execution.
"""

from __future__ import annotations

import math
import re

from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.program.params import MAX_PARAMETER

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


def _err(message: str) -> PathFormatError:
    return PathFormatError(message)


class ValueReader:
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
