"""Expressions, parameters and O-word control flow, checked against LinuxCNC's interpreter: random
expressions (every operator and function, nested, with parameters) are evaluated by rs274 and by
fuzzyfeed's reader, and programs with subroutines, loops and branches give the same moves."""

from __future__ import annotations

import random
import re
import subprocess

import numpy as np
import pytest

from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.program.expr import Parameters, clean_line, compile_line, evaluate
from fuzzyfeed.program.model import ARC, LINE, RAPID
from fuzzyfeed.program.read import read_program
from test_gcode_export import rs274_binary

_CALL = re.compile(r"^\s*\d+\s+N\S*\s+(STRAIGHT_TRAVERSE|STRAIGHT_FEED|ARC_FEED)\((.*)\)\s*$")


def rs274_moves(path, tmp_path) -> list[tuple[str, np.ndarray]]:
    """(call, numbers) of every traverse, feed and arc rs274 prints for ``path`` (exit 0 asserted)."""
    out = tmp_path / (path.name + ".canon")
    done = subprocess.run([rs274_binary(), "-g", str(path), str(out)], capture_output=True, text=True,
                          stdin=subprocess.DEVNULL, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stdout[-300:]
    moves = []
    for line in out.read_text().splitlines():
        m = _CALL.match(line)
        if m:
            moves.append((m.group(1), np.array([float(v) for v in m.group(2).split(",")])))
    return moves


def _value(text: str, params: Parameters | None = None) -> float:
    return evaluate(compile_line(clean_line("X" + text)), params or Parameters())[0]


class _Expressions:
    """Random expressions that stay within every function's domain (checked by evaluating)."""

    def __init__(self, seed: int):
        self.rng = random.Random(seed)

    def number(self) -> str:
        r = self.rng
        return r.choice([f"{r.uniform(-20, 20):.3f}", str(r.randint(-9, 9)), f"{r.uniform(0, 3):.4f}",
                         "#1", "#2", "#<a>", "#<_g>", "#[#3 + 1]", "##5"])

    def expr(self, depth: int) -> str:
        r = self.rng
        if depth <= 0 or r.random() < 0.25:
            return self.number()
        kind = r.random()
        if kind < 0.45:
            ops = ["+", "-", "*", "/", "mod", "**", "eq", "ne", "gt", "ge", "lt", "le", "and", "or", "xor"]
            terms = [self.expr(depth - 1) for _ in range(r.randint(2, 4))]
            out = terms[0]
            for t in terms[1:]:
                out += f" {r.choice(ops)} {t}"
            return f"[{out}]"
        if kind < 0.85:
            fn = r.choice(["abs", "cos", "sin", "tan", "fix", "fup", "round", "sqrt", "exp", "ln",
                           "asin", "acos"])
            inner = self.expr(depth - 1)
            if fn in ("sqrt", "ln"):
                inner = f"[abs[{inner}] + 0.5]"
            elif fn in ("asin", "acos"):
                inner = f"[sin[{inner}]]"
            elif fn == "exp":
                inner = f"[sin[{inner}] * 3]"
            return f"{fn}[{inner}]"
        if kind < 0.93:
            return f"atan[{self.expr(depth - 1)}]/[{self.expr(depth - 1)}]"
        return f"-{self.expr(depth - 1)}"


def _params() -> Parameters:
    p = Parameters()
    p.set(1, 2.5)
    p.set(2, -3.0)
    p.set(3, 6.0)
    p.set(5, 8.0)
    p.set(7, 1.25)
    p.set(8, 0.75)
    p.set_named("a", 4.0)
    p.set_named("_g", 0.5)
    return p


PRELUDE = "#1 = 2.5\n#2 = -3\n#3 = 6\n#5 = 8\n#7 = 1.25\n#8 = 0.75\n#<a> = 4\n#<_g> = 0.5\n"


def test_random_expressions_equal_rs274(tmp_path):
    gen = _Expressions(seed=28)
    chosen = []
    while len(chosen) < 400:
        text = gen.expr(4)
        if len(text) > 240:      # LinuxCNC reads at most 255 characters a line
            continue
        try:
            value = _value(text, _params())
        except PathFormatError:
            continue
        if abs(value) < 1e5:
            chosen.append((text, value))
    program = tmp_path / "expr.ngc"
    program.write_text("G21 G90 G0 X0 Y0\n" + PRELUDE + "".join(f"G0 X{t} Y{k}\n" for k, (t, _) in
                                                                 enumerate(chosen)) + "M2\n")
    moves = rs274_moves(program, tmp_path)[1:]
    assert len(moves) == len(chosen)
    ours = read_program(program)
    for (text, value), (_, nums), end in zip(chosen, moves, ours.end[1:]):
        assert abs(nums[0] - value) <= 5.01e-5 + 1e-9 * abs(value), f"{text}: rs274 {nums[0]}, fuzzyfeed {value}"
        assert abs(end[0] - value) < 1e-12 * max(1.0, abs(value))


@pytest.mark.parametrize("text, value", [
    ("[1 + 2 * 3 ** 2]", 19.0), ("[2 ** 3 ** 2]", 64.0), ("[7 mod -3]", 1.0), ("[-7 mod 3]", 2.0),
    ("[1 - 2 - 3]", -4.0), ("[12 / 2 / 3]", 2.0), ("[1 lt 2 and 3 gt 4]", 0.0),
    ("[1 eq 1.0000001]", 1.0), ("atan[1]/[-1]", 135.0), ("round[-2.5]", -3.0), ("fix[-2.5]", -3.0),
    ("fup[-2.5]", -2.0), ("-[2]", -2.0), ("[1 or 0 xor 1]", 0.0), ("exists[#<nope>]", 0.0),
    ("[2^3]", 8.0),
])
def test_precedence_and_functions_closed_form(text, value):
    assert _value(text) == pytest.approx(value, abs=1e-12)


@pytest.mark.parametrize("text, rule", [
    ("[1 / 0]", "divide by zero"), ("sqrt[-1]", "negative argument to SQRT"),
    ("ln[0]", "zero or negative argument to LN"), ("acos[2]", "ACOS out of range"),
    ("[[-8] ** 0.5]", "negative number to a non-integer power"), ("#<undefined>", "not defined"),
    ("[1 + 2", "not closed"), ("sin 30", "'\\[' missing after the function SIN"), ("#9999", "out of range"),
    ("[1 ! 2]", "unknown operation"), ("1..2", "bad number"), ("exp[1000]", "infinity"),
])
def test_expression_errors_name_the_rule(text, rule):
    with pytest.raises(PathFormatError, match=rule):
        _value(text)


FLOW = """G21 G90 G17 F500
G0 X0 Y0 Z5
#1 = 7 #2 = #1          (parallel: #2 gets the old #1 = 0)
G0 X#2 Y#1
o<square> sub
  #<half> = [#1 / 2]
  G0 X[#2 - #<half>] Y[#3 - #<half>]
  G1 Z-1
  G91 G1 X#1
  G1 Y#1
  G1 X-#1
  G1 Y-#1
  G90 G0 Z5
  o1 if [#1 gt 8]
    o<square> return [#1 * 2]
  o1 elseif [#1 gt 4]
    G0 X100
  o1 else
    G0 X200
  o1 endif
o<square> endsub [-1]
#<i> = 0
o10 while [#<i> lt 3]
  o<square> call [4 + #<i> * 3] [#<i> * 20] [0]
  #<i> = [#<i> + 1]
  o11 if [#<_value> eq 20]
    o10 break
  o11 endif
o10 endwhile
o20 do
  #<i> = [#<i> - 1]
  o21 if [#<i> eq 1]
    o20 continue
  o21 endif
  G1 X[#<i> * 5] Y-10
o20 while [#<i> gt 0]
G0 X#<i> Y-10          (the do loop ran once: the while loop's break left LinuxCNC's flag set)
o30 repeat [3]
  G2 X[#<i> + 10] Y-10 I5 J0
  #<i> = [#<i> + 10]
o30 endrepeat
G0 X0 Y0 Z5
M2
"""


def test_flow_program_moves_equal_rs274(tmp_path):
    program = tmp_path / "flow.ngc"
    program.write_text(FLOW)
    moves = rs274_moves(program, tmp_path)
    ours = read_program(program)
    assert ours.rows is not None                       # lines ran more than once
    assert len(moves) == ours.kind.size
    kinds = {"STRAIGHT_TRAVERSE": RAPID, "STRAIGHT_FEED": LINE, "ARC_FEED": ARC}
    for k, (call, nums) in enumerate(moves):
        assert ours.kind[k] == kinds[call], (k, call)
        end = nums[:3] if call != "ARC_FEED" else np.array([nums[0], nums[1], nums[5]])
        np.testing.assert_allclose(ours.end[k], end, atol=6e-5, err_msg=f"move {k} ({call})")


@pytest.mark.parametrize("body, rule", [
    ("o1 while [1]\no1 endwhile\n", "more than"),
    ("o1 if [1]\nG0 X1\n", "never closed"),
    ("o2 endif\n", "without a matching open"),
    ("o<nosuch> call\n", "not defined"),
    ("o1 sub\no1 call\no1 endsub\no1 call\n", "nested more than 10"),
])
def test_flow_errors_one_line(tmp_path, body, rule):
    path = tmp_path / "bad.ngc"
    path.write_text("G21 G0 X0 Y0\n" + body + "M2\n")
    with pytest.raises(PathFormatError, match=rule) as info:
        read_program(path)
    assert "\n" not in str(info.value) and "bad.ngc:" in str(info.value)


def test_subroutine_in_a_file_beside_the_program(tmp_path):
    (tmp_path / "slot.ngc").write_text("o<slot> sub\nG1 X[#1] F200\nG1 Y[#1]\no<slot> endsub\nM2\n")
    main = tmp_path / "main.ngc"
    main.write_text("G21 G90\nG0 X0 Y0\no<slot> call [5]\nG1 X0 Y0\nM2\n")
    program = read_program(main)
    np.testing.assert_allclose(program.end[:, :2], [[0, 0], [5, 0], [5, 5], [0, 0]])
    assert list(program.move_line) == [1, -1, -1, 3]      # the called lines are another file's
    assert program.cut[1] == -1 and program.cut[2] == -1   # kept: that file is not rewritten


QUIRKS = """G21 G90 F300
G0 X0 Y0
#<i> = 3
o1 do
  #<i> = [#<i> - 1]
  o2 if [#<i> eq 1]
    o1 continue
  o2 endif
  G1 X[#<i> * 5]
o1 while [#<i> gt 0]
#<j> = 0
o3 while [#<j> lt 4]
  #<j> = [#<j> + 1]
  G1 Y#<j>
  o4 if [#<j> eq 2]
    o3 break
  o4 endif
o3 endwhile
G1 X50 Y50
M2
"""


def test_loop_flags_outlive_their_loop_as_in_rs274(tmp_path):
    """A continue in a do/while loop leaves LinuxCNC's doing_continue set: the next break of a
    while loop goes back to its test once instead of leaving it (rs274 decides)."""
    program = tmp_path / "quirks.ngc"
    program.write_text(QUIRKS)
    moves = rs274_moves(program, tmp_path)
    ours = read_program(program)
    ends = [nums[:3] for _, nums in moves]
    np.testing.assert_allclose(ours.end, ends, atol=6e-5)
    assert [e[1] for e in ends[3:7]] == [1, 2, 3, 4]    # the break at j = 2 did not leave the loop


def test_advised_program_keeps_the_users_expressions(tmp_path, capsys):
    """The program written back keeps every expression on lines that are not split; a split
    line gets plain numbers; rs274 makes the same moves from both (only feeds change)."""
    from canon import canon, compare
    from fuzzyfeed.cli import main

    program = tmp_path / "expr.ngc"
    program.write_text("G21 G90 G17\n#<r> = 12\n#2 = [360 / 17]\nG0 X0 Y0 Z5\nG1 Z-1 F[#<r> * 50]\n"
                       "G1 X[#<r> * 10] Y0\nG3 X[#<r> * 10] Y[#<r> * 2] I0 J#<r>\nG1 X[cos[#2] * 3] Y[sin[#2] * 3]\n"
                       "G0 Z5\nM2\n")
    out = tmp_path / "out.ngc"
    assert main(["advise", str(program), "-o", str(tmp_path / "a.csv"), "--gcode", str(out)]) == 0
    old, new = program.read_text().splitlines(), out.read_text().splitlines()
    kept = [ln for ln in old if "[" in ln and any(n.startswith(ln.split(" F")[0]) for n in new)]
    assert len(kept) >= 3                                           # expression lines kept as written
    split = [ln for ln in new if ln not in old and "[" not in ln]
    assert split and all(re.fullmatch(r"G[123] [XYZIJ0-9. -]+F[0-9.]+", ln) for ln in split), split
    result = compare(canon(program, tmp_path), canon(out, tmp_path))
    assert result.min_ratio < 0.5


def test_polar_words_are_placed_as_linuxcnc_places_them(tmp_path):
    """``@``/``^`` move the tool about the origin of the frame (``find_ends``): in G90 to radius
    @ at angle ^, in G91 adding @ to the radius and ^ to the angle of the point before. Those moves
    are read and advised like any other (their line stays one move: X or Y cannot join a polar
    word), and rs274 makes the same moves from the program written back."""
    from canon import canon, compare
    from fuzzyfeed.cli import main
    from fuzzyfeed.program.model import LINE

    program = tmp_path / "polar.ngc"
    program.write_text("G21 G90 G17 F300\nG0 X10 Y0 Z0\nG1 @10 ^30\nG1 X5 Y5\nG91 G1 @2 ^15\nG1 ^15\n"
                       "G90 G1 @4\nG0 X0 Y0\nG1 X10\nG1 Y10\nG1 X0\nM2\n")
    ours = read_program(program)
    assert ours.kind[1] == LINE and ours.known[1:].all() and (ours.cut[1:6] >= 0).all()
    r0, t0 = np.hypot(5, 5), np.arctan2(5, 5)
    want = [(10 * np.cos(np.pi / 6), 10 * np.sin(np.pi / 6)), (5, 5),
            ((r0 + 2) * np.cos(t0 + np.pi / 12), (r0 + 2) * np.sin(t0 + np.pi / 12)),
            ((r0 + 2) * np.cos(t0 + np.pi / 6), (r0 + 2) * np.sin(t0 + np.pi / 6)),
            (4 * np.cos(t0 + np.pi / 6), 4 * np.sin(t0 + np.pi / 6))]
    np.testing.assert_allclose(ours.end[1:6, :2], want, atol=1e-12)
    out = tmp_path / "out.ngc"
    assert main(["advise", str(program), "-o", str(tmp_path / "a.csv"), "--gcode", str(out)]) == 0
    assert all(" X" not in ln and " Y" not in ln for ln in out.read_text().splitlines() if "@" in ln or "^" in ln)
    assert compare(canon(program, tmp_path), canon(out, tmp_path)).min_ratio < 0.5
