"""The catalogue of hostile inputs (issue 10): every entry point, every case one line and exit 2.

A CLI case is ``(id, argv, files)``: ``files`` maps a name to its content (str or bytes) or to a
callable ``make(path)`` that creates something special (a folder, a link, a FIFO). The test runs
``fuzzyfeed.cli.main(argv)`` in a fresh folder holding the files and checks: exit code 2, exactly
one stderr line starting ``fuzzyfeed: error:``, no traceback, no warning, nothing created or
changed. API cases are ``(id, call)``: the call must raise a :class:`FuzzyfeedError`.
"""

from __future__ import annotations

import os
import socket
from pathlib import Path

SHAPE = """\
name = "tiny"
units = "mm"
degree = 2
knotvector = [0, 0, 0, 0.5, 1, 1, 1]
control_points = [[0, 0], [10, 5], [20, -5], [30, 0]]
weights = [1, 1, 1, 1]
"""

JSON_SHAPE = """{"name": "tiny", "units": "mm", "degree": 2, "knotvector": [0, 0, 0, 0.5, 1, 1, 1],
 "control_points": [[0, 0], [10, 5], [20, -5], [30, 0]], "weights": [1, 1, 1, 1]}"""

PROGRAM = "G21 G90 G17\nG0 X0 Y0\nG1 X10 Y0 F600\nG1 X10 Y10\nG1 X20 Y10\nM2\n"
POINTS = "x_mm,y_mm\n0,0\n10,0\n10,10\n20,10\n"
FAST = ["--points", "60"]


def _rules_text() -> str:
    from fuzzyfeed.fuzzy.rule_reader import rules_dir

    return (rules_dir() / "paper.toml").read_text()


def _line(text: str, key: str, value: str) -> str:
    """Replace the TOML line starting with ``key`` (first match) by ``key = value``."""
    out, done = [], False
    for line in text.splitlines():
        if not done and line.split("=")[0].strip() == key and "=" in line:
            out.append(f"{key} = {value}")
            done = True
        else:
            out.append(line)
    assert done, key
    return "\n".join(out) + "\n"


def _drop(text: str, key: str) -> str:
    return "\n".join(l for l in text.splitlines() if l.split("=")[0].strip() != key) + "\n"


def _deep(n: int, json: bool) -> str:
    return ('{"a":' * n + "1" + "}" * n) if json else ("a = " + "[" * n + "]" * n + "\n")


# -------------------------------------------------------------------------------- shape files
SHAPE_FIELD_VALUES = {
    "degree": ["0", "-1", "1.5", '"2"', "true", "7", "[]", "nan", "1e400", "{}"],
    "knotvector": ["[0, 0, 0, 1, 1, 1]", "[0, 0, 0, 0.5, 0.4, 1, 1]", "[0, 0, 0, nan, 1, 1, 1]",
                   "[0, 0, 0, 0.5, 1, 1, inf]", "[0, 0, 0.1, 0.5, 1, 1, 1]", "[1, 1, 1, 1, 1, 1, 1]",
                   "[0, 0, 0, 0.5, 0.9, 1, 1]", '["a", 0, 0, 0.5, 1, 1, 1]', "[[0], 0, 0, 0.5, 1, 1, 1]",
                   "[0, 0, 0, 2e-300, 4e-300, 4e-300, 4e-300]", "[0, 0, 0, 1, 1e300, 1e300, 1e300]",
                   "[0, 0, 0, 0, 1, 1, 1]", "3", '"0 0 0 1 1 1"', "[]",
                   "[1e20, 1e20, 1e20, 1.00000000000001e20, 1.00000000000002e20, 1.00000000000002e20, "
                   "1.00000000000002e20]",
                   "[0, 0, 0, 1e300, 1.7e308, 1.7e308, 1.7e308]",         # issue 28: three lines before
                   "[-1e308, -1e308, -1e308, 0, 1e308, 1e308, 1e308]"],
    "control_points": ["[[0, 0], [10, 5], [20, -5]]", "[[0], [10], [20], [30]]",
                       "[[0, 0, 0, 0], [1, 1, 1, 1], [2, 2, 2, 2], [3, 3, 3, 3]]",
                       "[[0, 0], [10, nan], [20, -5], [30, 0]]", "[[0, 0], [10, inf], [20, -5], [30, 0]]",
                       "[[0, 0], [1e300, 5], [20, -5], [30, 0]]", "[[5, 5], [5, 5], [5, 5], [5, 5]]",
                       '[["a", 0], [10, 5], [20, -5], [30, 0]]', "[0, 10, 20, 30]", "[]",
                       "[[0, 0], [10, 5, 1], [20, -5], [30, 0]]", "[[0, 0], [1e-9, 0], [0, 1e-9], [0, 0]]",
                       "[[0, 0], [2e6, 0], [20, -5], [30, 0]]", "[[0, 0], [10, 5], [20, -5], [30, true]]"],
    "weights": ["[1, 0, 1, 1]", "[1, -1, 1, 1]", "[1, nan, 1, 1]", "[1, inf, 1, 1]", "[1, 1, 1]",
                "[1e-300, 1, 1e300, 1]", "[1, 1e308, 1, 1]", '["1", 1, 1, 1]', "[1, 1, 1, 1, 1]",
                "[1, 1e-7, 1, 1]", "1", "[[1], [1], [1], [1]]"],
    "units": ['"furlong"', "5", '""', '"MM "', "[]"],
    "name": ["5", "[]", "{}"],
}


def shape_cases() -> list:
    cases = []
    for key, values in SHAPE_FIELD_VALUES.items():
        for n, value in enumerate(values):
            cases.append((f"toml-{key}-{n}", ["advise", "s.toml", "-o", "o.csv", *FAST],
                          {"s.toml": _line(SHAPE, key, value)}))
    for key in ("degree", "knotvector", "control_points"):
        cases.append((f"toml-missing-{key}", ["advise", "s.toml", "-o", "o.csv", *FAST],
                      {"s.toml": _drop(SHAPE, key)}))
    raw = {
        "syntax": "degree = = 2\n", "empty": "", "unclosed": SHAPE + "[x\n", "dup-key": SHAPE + "degree = 3\n",
        "binary": b"\x00\x01\x02" * 100, "latin1": SHAPE.encode() + "# caf\xe9\n".encode("latin-1"),
        "deep": _deep(3000, False), "deep-table": "a" + ".a" * 3000 + " = 1\n",
        "bom-garbage": "\ufeff}}}\n", "huge-int": SHAPE.replace("degree = 2", "degree = 99999999999999999999"),
        "nul-in-text": SHAPE + "\x00", "only-comment": "# nothing\n",
    }
    for n, text in raw.items():
        cases.append((f"toml-file-{n}", ["advise", "s.toml", "-o", "o.csv", *FAST], {"s.toml": text}))
    corner = "degree = 2\nknotvector = [0, 0, 0, 0.5, 1, 1, 1]\ncontrol_points = [[0, 0], [10, 0], [10, 0], [10, 10]]\n"
    for n in ("2000", "2001", "60"):  # a 90 deg corner between straight pieces: never at full feed
        cases.append((f"toml-corner-{n}-points", ["advise", "s.toml", "-o", "o.csv", "--points", n], {"s.toml": corner}))
    cases.append(("toml-degree1-corner", ["advise", "s.toml", "-o", "o.csv"],
                  {"s.toml": "degree = 1\nknotvector = [0, 0, 0.5, 1, 1]\ncontrol_points = [[0, 0], [10, 0], [10, 10]]\n"}))
    # JSON in both layouts
    js = {
        "syntax": "{degree: 2}", "trailing": JSON_SHAPE + ",", "list": "[1, 2, 3]", "null": "null",
        "deep": _deep(3000, True), "deep-list": "[" * 5000 + "]" * 5000, "nan": JSON_SHAPE.replace("[10, 5]", "[NaN, 5]"),
        "infinity": JSON_SHAPE.replace("[10, 5]", "[Infinity, 5]"), "huge": JSON_SHAPE.replace("[10, 5]", "[1e999, 5]"),
        "null-points": JSON_SHAPE.replace("[[0, 0], [10, 5], [20, -5], [30, 0]]", "null"),
        "string-degree": JSON_SHAPE.replace('"degree": 2', '"degree": "two"'),
        "bool-degree": JSON_SHAPE.replace('"degree": 2', '"degree": true'),
        "weights-ratio": JSON_SHAPE.replace("[1, 1, 1, 1]", "[1e-300, 1, 1, 1]"),
        "geomdl-empty": '{"shape": {"data": []}}', "geomdl-bad": '{"shape": {"data": [{"degree": 2}]}}',
        "geomdl-type": '{"shape": {"data": "x"}}', "geomdl-points": '{"shape": {"data": [{"degree": 1, '
        '"knotvector": [0, 0, 1, 1], "control_points": {"points": [[0, 0], [0, 0]]}}]}}',
        "empty": "", "binary": b"\xff\xfe\x00\x00", "number": "42", "string": '"shape"',
        "dup-keys": JSON_SHAPE.replace('"degree": 2', '"degree": 2, "degree": 0'),
    }
    for n, text in js.items():
        cases.append((f"json-{n}", ["advise", "s.json", "-o", "o.csv", *FAST], {"s.json": text}))
    # names and kinds of file
    cases += [
        ("shape-missing-file", ["advise", "nope.toml", "-o", "o.csv"], {}),
        ("shape-unknown-name", ["advise", "nosuchshape", "-o", "o.csv"], {}),
        ("shape-folder", ["advise", "d.toml", "-o", "o.csv"], {"d.toml": lambda p: p.mkdir()}),
        ("shape-unknown-suffix", ["advise", "s.xyz", "-o", "o.csv"], {"s.xyz": SHAPE}),
        ("shape-empty-arg", ["advise", "", "-o", "o.csv"], {}),
        ("shape-fifo", ["advise", "f.toml", "-o", "o.csv"], {"f.toml": lambda p: os.mkfifo(p)}),
        ("shape-dangling-link", ["advise", "l.toml", "-o", "o.csv"],
         {"l.toml": lambda p: os.symlink("missing.toml", p)}),
        ("shape-unreadable-dev", ["advise", "/dev/null", "-o", "o.csv"], {}),
    ]
    for cmd in (["plot", "s.toml", "-o", "o.png"], ["schedule", "s.toml", "-o", "o.csv"],
                ["compare", "s.toml", "-o", "o.csv", "--points", "60"]):
        for n, value in (("degree", "0"), ("weights", "[1e-300, 1, 1e300, 1]"),
                         ("control_points", "[[5, 5], [5, 5], [5, 5], [5, 5]]"),
                         ("knotvector", "[0, 0, 0, 2e-300, 4e-300, 4e-300, 4e-300]")):
            cases.append((f"{cmd[0]}-shape-{n}", cmd, {"s.toml": _line(SHAPE, n, value)}))
    return cases


# -------------------------------------------------------------------------------- rule tables
def rule_cases() -> list:
    base = _rules_text()
    edits = {
        "window-0": ("window_points", "0"), "window-neg": ("window_points", "-3"),
        "window-float": ("window_points", "2.5"), "window-str": ("window_points", '"30"'),
        "clip-0": ("dk_clip_1_mm", "0.0"), "clip-nan": ("dk_clip_1_mm", "nan"), "clip-inf": ("dk_clip_1_mm", "inf"),
        "filter-0": ("filter_points", "0"), "filter-neg": ("filter_points", "-1"),
        "filter-float": ("filter_points", "3.5"), "filter-even": ("filter_points", "20"), "filter-huge": ("filter_points", "1e300"),
        "floor-neg": ("feed_floor_pct", "-5.0"), "floor-over": ("feed_floor_pct", "150.0"),
        "floor-nan": ("feed_floor_pct", "nan"),
        "universe-rev": ("universe", "[1.0, 0.0]"), "universe-nan": ("universe", "[0.0, nan]"),
        "universe-short": ("universe", "[0.0]"), "universe-str": ("universe", '"0..1"'),
        "term-decreasing": ("VS", "[0.05, 0.02, 0.0]"), "term-nan": ("VS", "[0.0, nan, 0.05]"),
        "term-len": ("VS", "[0.0, 0.02]"), "term-len5": ("VS", "[0, 0.1, 0.2, 0.3, 0.4]"),
        "term-str": ("VS", '"small"'), "term-inf": ("VS", "[0.0, 0.02, inf]"),
        "rules-label": ("ZO", '["TF", "TF", "VVHF", "VVHF", "NOPE"]'),
        "rules-short": ("VB", '["VLF", "VLF"]'), "rules-columns": ("columns", '["ZO", "L", "M", "H", "XX"]'),
        "rules-columns-dup": ("columns", '["ZO", "ZO", "M", "H", "VH"]'), "rules-num": ("VB", "[1, 2, 3, 4, 5]"),
    }
    cases = []
    for n, (key, value) in edits.items():
        cases.append((f"rules-{n}", ["advise", "s.toml", "--rules", "r.toml", "-o", "o.csv", *FAST],
                      {"s.toml": SHAPE, "r.toml": _line(base, key, value)}))
    for section in ("[features]", "[curvature]", "[rules]", "[feed]"):
        text = base.replace(section, "[ignored_" + section.strip("[]") + "]")
        cases.append((f"rules-missing-{section.strip('[]')}", ["rules", "check", "r.toml"], {"r.toml": text}))
    raw = {"empty": "", "syntax": "[features\n", "binary": b"\x00" * 64, "deep": _deep(3000, False),
           "dup-section": base + "[features]\nwindow_points = 3\n", "latin1": base.encode() + b"# \xe9\n"}
    for n, text in raw.items():
        cases.append((f"rules-file-{n}", ["rules", "check", "r.toml"], {"r.toml": text}))
    cases += [
        ("rules-check-missing", ["rules", "check", "nope.toml"], {}),
        ("rules-check-unknown-name", ["rules", "check", "nosuchtable"], {}),
        ("rules-show-missing", ["rules", "show", "nope.toml"], {}),
        ("rules-show-format", ["rules", "show", "--format", "xml"], {}),
        ("rules-show-toml-bad", ["rules", "show", "r.toml", "--format", "toml"], {"r.toml": "x = = 1"}),
        ("rules-set-missing", ["rules", "set", "nope.toml", "VS", "M", "HF"], {}),
        ("rules-set-row", ["rules", "set", "r.toml", "XX", "M", "HF"], {"r.toml": base}),
        ("rules-set-col", ["rules", "set", "r.toml", "VS", "XX", "HF"], {"r.toml": base}),
        ("rules-set-label", ["rules", "set", "r.toml", "VS", "M", "XX"], {"r.toml": base}),
        ("rules-set-invalid-file", ["rules", "set", "r.toml", "VS", "M", "HF"],
         {"r.toml": _line(base, "window_points", "0")}),
        ("rules-set-shipped-name", ["rules", "set", "paper", "VS", "M", "HF"], {}),
        ("rules-set-folder", ["rules", "set", "d", "VS", "M", "HF"], {"d": lambda p: p.mkdir()}),
        ("rules-set-few-args", ["rules", "set", "r.toml", "VS"], {"r.toml": base}),
        ("rules-surface-bad", ["rules", "surface", "r.toml", "-o", "o.png"], {"r.toml": "[rules]\n"}),
        ("rules-surface-nodir", ["rules", "surface", "-o", "nodir/o.png"], {}),
        ("rules-no-action", ["rules"], {}),
        ("rules-unknown-action", ["rules", "explode"], {}),
        ("advise-rules-is-shape", ["advise", "s.toml", "--rules", "s.toml", "-o", "o.csv"], {"s.toml": SHAPE}),
        ("advise-rules-missing", ["advise", "s.toml", "--rules", "nope.toml", "-o", "o.csv"], {"s.toml": SHAPE}),
        ("compare-rules-bad", ["compare", "s.toml", "--rules", "r.toml", "-o", "o.csv"],
         {"s.toml": SHAPE, "r.toml": "x = 1\n"}),
    ]
    return cases


# -------------------------------------------------------------------------------- flags
def flag_cases() -> list:
    cases = []
    adv = ["advise", "s.toml", "-o", "o.csv"]
    for n, value in enumerate(["0", "2", "-1", "x", "1e9", "1.5", "nan", "", "1000000001", "0x10"]):
        cases.append((f"flag-points-{n}", [*adv, "--points", value], {"s.toml": SHAPE}))
    for n, value in enumerate(["0", "-1", "nan", "inf", "1e308", "abc", "", "-inf", "1e10"]):
        cases.append((f"flag-advise-feed-{n}", [*adv, *FAST, "--feed-mm-min", value], {"s.toml": SHAPE}))
    sched = ["schedule", "s.toml", "-o", "o.csv"]
    for flag in ("--feed-mm-min", "--jerk-mm-s3", "--chord-tol-mm", "--ts-s", "--axis-vel-mm-s", "--axis-acc-mm-s2"):
        for n, value in enumerate(["0", "-1", "nan", "inf", "1e308", "x"]):
            cases.append((f"flag-schedule{flag}-{n}", [*sched, flag, value], {"s.toml": SHAPE}))
    for n, value in enumerate(["1,2", "1,2,3,4", "a,b,c", "1,,2", "1,0,1"]):
        cases.append((f"flag-axis-list-{n}", [*sched, "--axis-vel-mm-s", value], {"s.toml": SHAPE}))
    cases += [
        ("flag-ts-2s", [*sched, "--ts-s", "2"], {"s.toml": SHAPE}),
        ("flag-ts-tiny", [*sched, "--ts-s", "1e-9"], {"s.toml": SHAPE}),
        ("flag-feed-tiny", [*sched, "--feed-mm-min", "1e-9"], {"s.toml": SHAPE}),
        ("flag-approach-3", [*sched, "--approach", "3"], {"s.toml": SHAPE}),
        ("flag-approach-x", [*sched, "--approach", "x"], {"s.toml": SHAPE}),
        ("flag-unknown", [*adv, "--fast"], {"s.toml": SHAPE}),
        ("flag-missing-o", ["advise", "s.toml"], {"s.toml": SHAPE}),
        ("flag-o-no-value", ["advise", "s.toml", "-o"], {"s.toml": SHAPE}),
        ("flag-no-shape", ["advise", "-o", "o.csv"], {}),
        ("flag-two-shapes", ["advise", "s.toml", "s.toml", "-o", "o.csv"], {"s.toml": SHAPE}),
        ("flag-no-command", [], {}),
        ("flag-unknown-command", ["explode"], {}),
        ("flag-shapes-extra", ["shapes", "--x"], {}),
        ("flag-plot-points-0", ["plot", "s.toml", "-o", "o.png", "--points", "0"], {"s.toml": SHAPE}),
        ("flag-compare-points", ["compare", "s.toml", "-o", "o.csv", "--points", "x"], {"s.toml": SHAPE}),
        ("flag-decimals-2", [*adv, *FAST, "--gcode", "o.ngc", "--gcode-decimals", "2"], {"s.toml": SHAPE}),
        ("flag-decimals-10", [*adv, *FAST, "--gcode", "o.ngc", "--gcode-decimals", "10"], {"s.toml": SHAPE}),
        ("flag-decimals-x", [*adv, *FAST, "--gcode", "o.ngc", "--gcode-decimals", "x"], {"s.toml": SHAPE}),
        ("flag-step-0", [*adv, *FAST, "--gcode", "o.ngc", "--feed-step-mm-min", "0"], {"s.toml": SHAPE}),
        ("flag-step-no-gcode", [*adv, *FAST, "--feed-step-mm-min", "100"], {"s.toml": SHAPE}),
        ("flag-linenumbers-no-gcode", [*adv, *FAST, "--line-numbers"], {"s.toml": SHAPE}),
        ("flag-g52whole-no-g52", [*adv, *FAST, "--gcode", "o.ngc", "--g52-whole"], {"s.toml": SHAPE}),
        ("flag-g52-polyline", ["advise", "p.ngc", "-o", "o.csv", "--gcode-g52", "o2.ngc"], {"p.ngc": PROGRAM}),
        ("flag-g52-csv-polyline", ["advise", "p.csv", "-o", "o.csv", "--gcode-g52", "o2.ngc"], {"p.csv": POINTS}),
        ("flag-jerk-tiny", [*sched, "--jerk-mm-s3", "1e-12"], {"s.toml": SHAPE}),
        ("flag-jerk-tiny-compare", ["compare", "s.toml", "-o", "o.csv", "--jerk-mm-s3", "1e-12"], {"s.toml": SHAPE}),
        ("flag-acc-tiny", [*sched, "--axis-acc-mm-s2", "1e-12"], {"s.toml": SHAPE}),
        ("flag-g52-degree1", [*adv, *FAST, "--gcode-g52", "o.ngc"],
         {"s.toml": _line(_line(SHAPE, "degree", "1"), "knotvector", "[0, 0, 0.3, 0.6, 1, 1]")}),
    ]
    return cases


# -------------------------------------------------------------------------------- G-code, DXF, CSV
GCODE_PROGRAMS = {
    "empty": "", "comments-only": "(nothing)\n; at all\n%\n",
    "unknown-g": "G21 G90\nG0 X0 Y0\nG12 X1\nM2\n", "nan": "G21 G90\nG0 X0 Y0\nG1 Xnan Y0 F100\nM2\n",
    "overflow": "G21 G90\nG0 X0 Y0\nG1 X1e400 Y0 F100\nM2\n", "garbage": "G21\n@@@@\n",
    "letter-only": "G21 G90\nG0 X0 Y0\nG1 X Y1 F100\nM2\n", "double-word": "G21 G90\nG0 X0 Y0\nG1 X1 X2 F100\nM2\n",
    "unclosed-comment": "G21 G90\nG0 X0 Y0 (oops\nG1 X1 F100\nM2\n",
    "arc-p0": "G21 G90\nG0 X0 Y0\nG2 X10 Y0 I5 J0 P0 F100\nM2\n",
    "arc-p-frac": "G21 G90\nG0 X0 Y0\nG2 X10 Y0 I5 J0 P1.5 F100\nM2\n",
    "arc-p-huge": "G21 G90\nG0 X0 Y0\nG2 X10 Y0 I5 J0 P1000000000 F100\nM2\n",
    "arc-radius-mismatch": "G21 G90\nG0 X0 Y0\nG2 X10 Y0 I3 J0 F100\nM2\n",
    "arc-no-center": "G21 G90\nG0 X0 Y0\nG2 X10 Y0 F100\nM2\n",
    "arc-r-too-small": "G21 G90\nG0 X0 Y0\nG2 X10 Y0 R1 F100\nM2\n",
    "arc-zero-radius": "G21 G90\nG0 X0 Y0\nG2 X0 Y0 I0 J0 F100\nM2\n",
    "g52-bad-weight": "G21 G90\nG0 X0 Y0\nG5.2 X1 Y1 P0 L3 F100\nX2 Y0 P1\nG5.3\nM2\n",
    "g52-unterminated": "G21 G90\nG0 X0 Y0\nG5.2 X1 Y1 P1 L3 F100\nX2 Y0 P1\nM2\n",
    "binary": b"\x00G1 X1\x00",
    "inch-units": "G20 G90\nG0 X0 Y0\nG1 X1e6 Y0 F10\nG1 X1e6 Y1 F10\nM2\n",
    "huge-coordinates": "G21 G90\nG0 X0 Y0\nG1 X1e300 Y0 F100\nG1 X1e300 Y1e300\nM2\n",
    # issue 28's tail: a traceback with exit 1 before
    "million-digit-number": "G21 G90\nG0 X0 Y0\nG1 X1" + "1" * 1_000_000 + " Y0 F100\nM2\n",
    "coordinate-1e300-digits": "G21 G90\nG0 X0 Y0\nG1 X1" + "0" * 300 + " Y0 F100\nM2\n",
    "incremental-past-1km": "G21 G91\nG0 X0 Y0\nG1 X900000 F100\nG1 X900000\nM2\n",
    "cut-past-sample-budget": "G21 G90\nG0 X0 Y0\nG1 X900000 F100\nG1 Y900000\nM2\n",
    # expressions, parameters, O-words
    "divide-by-zero": "G21\nG0 X0 Y0\n#1 = [1 / 0]\nM2\n",
    "undefined-name": "G21\nG0 X[#<nope>] Y0\nM2\n",
    "unclosed-bracket": "G21\nG0 X[1 + [2 * 3] Y0\nM2\n",
    "deep-brackets": "G21\nG0 X" + "[" * 200 + "1" + "]" * 200 + "\nM2\n",
    "long-sum": "G21\nG0 X[" + "+".join(["#1"] * 100000) + "]\nM2\n",
    "param-out-of-range": "G21\n#99999 = 1\nG0 X0\nM2\n",
    "system-param": "G21\nG0 X#5420 Y0\nM2\n",
    "if-not-closed": "G21\nG0 X0 Y0\no1 if [1]\nG1 X1 F100\nM2\n",
    "endwhile-alone": "G21\nG0 X0 Y0\no2 endwhile\nM2\n",
    "unknown-sub": "G21\nG0 X0 Y0\no<nowhere> call\nM2\n",
    "recursion": "G21\no1 sub\no1 call\no1 endsub\nG0 X0\no1 call\nM2\n",
    "sub-twice": "G21\no1 sub\no1 endsub\no1 sub\no1 endsub\nM2\n",
    "m98-no-sub": "G21\nM98 P7\nM2\n",
    "m99-main": "G21\nG0 X0\nM99\n",
    "polar-beside-x": "G21\nG0 X1 @10 ^30\nM2\n",
    # cutter compensation
    "comp-entry-short": "G21 F100\nG0 X0 Y0\nG41.1 D4\nG1 X1 Y0\nM2\n",
    "comp-no-d": "G21 F100\nG0 X0 Y0\nG42.1\nG1 X10\nM2\n",
    "comp-gouge": "G21 F100\nG0 X-10 Y0\nG41.1 D6\nG1 X0 Y0\nG1 X10 Y0\nG1 X10 Y2\nG1 X20 Y2\nM2\n",
    "comp-twice": "G21 F100\nG0 X0 Y0\nG41.1 D1\nG1 X10\nG42.1 D1\nG1 Y10\nM2\n",
    "comp-cycle": "G21 F100\nG0 X-10 Y-10\nG41.1 D2\nG1 X0 Y0\nG81 X5 Y5 Z-1 R1\nM2\n",
    "comp-yz": "G21 F100 G19\nG0 Y0 Z0\nG41.1 D1\nG1 Y10\nM2\n",
    # modal rules
    "two-motion-codes": "G21\nG0 G1 X1 F100\nM2\n",
    "g80-axis-words": "G21\nG80 X1\nM2\n",
    "motion-with-g28": "G21\nG0 G28 X0\nM2\n",
    "g53-incremental": "G21 G91\nG0 G53 X0\nM2\n",
}


def program_cases() -> list:
    cases = [(f"gcode-{n}", ["advise", "p.ngc", "-o", "o.csv"], {"p.ngc": t}) for n, t in GCODE_PROGRAMS.items()]
    two = "G21 G90\nG0 X0 Y0\nG1 X10 Y0 F600\nG1 X10 Y10\nG0 X50 Y50\nG1 X60 Y50\nG1 X60 Y60\nM2\n"
    infinite = "G21\nG0 X0 Y0\no1 while [1]\n#1 = [#1 + 1]\no1 endwhile\nM2\n"
    table = "T1 P1 D6 Z0\n"
    cases += [
        ("gcode-endless-loop", ["advise", "p.ngc", "-o", "o.csv"], {"p.ngc": infinite}),
        ("gcode-tool-table-missing", ["advise", "p.ngc", "-o", "o.csv", "--tool-table", "nope.tbl"],
         {"p.ngc": two}),
        ("gcode-tool-table-garbage", ["advise", "p.ngc", "-o", "o.csv", "--tool-table", "t.tbl"],
         {"p.ngc": two, "t.tbl": "T1 P1 D6\nwhat is this\n"}),
        ("gcode-tool-table-binary", ["advise", "p.ngc", "-o", "o.csv", "--tool-table", "t.tbl"],
         {"p.ngc": two, "t.tbl": b"\x00\x01T1"}),
        ("gcode-tool-table-twice", ["advise", "p.ngc", "-o", "o.csv", "--tool-table", "t.tbl"],
         {"p.ngc": two, "t.tbl": "T1 D6\nT1 D5\n"}),
        ("gcode-tool-table-nan", ["advise", "p.ngc", "-o", "o.csv", "--tool-table", "t.tbl"],
         {"p.ngc": two, "t.tbl": "T1 D1e999\n"}),
        ("gcode-tool-not-in-table", ["advise", "p.ngc", "-o", "o.csv", "--tool-table", "t.tbl"],
         {"p.ngc": "G21 F100\nG0 X-10 Y-10\nG41 D5\nG1 X0 Y0\nG1 X10\nM2\n", "t.tbl": table}),
        ("gcode-tool-table-is-output", ["advise", "p.ngc", "-o", "t.tbl", "--tool-table", "t.tbl"],
         {"p.ngc": two, "t.tbl": table}),
        ("gcode-tool-units-bad", ["advise", "p.ngc", "-o", "o.csv", "--tool-table", "t.tbl",
                                  "--tool-units", "furlong"], {"p.ngc": two, "t.tbl": table}),
        ("shape-tool-table", ["advise", "s.toml", "-o", "o.csv", "--tool-table", "t.tbl"],
         {"s.toml": SHAPE, "t.tbl": table}),
        ("gcode-selector-range", ["advise", "p.ngc#9", "-o", "o.csv"], {"p.ngc": two}),
        ("gcode-selector-word", ["advise", "p.ngc#abc", "-o", "o.csv"], {"p.ngc": two}),
        ("gcode-selector-zero", ["advise", "p.ngc#0", "-o", "o.csv"], {"p.ngc": two}),
        ("gcode-schedule-bad", ["schedule", "p.ngc", "-o", "o.csv"], {"p.ngc": GCODE_PROGRAMS["nan"]}),
    ]
    return cases


def _dxf_polyline(points_bulges: list[tuple[float, float, float]]) -> str:
    body = ["0", "SECTION", "2", "ENTITIES", "0", "LWPOLYLINE", "5", "A1", "8", "0", "90",
            str(len(points_bulges)), "70", "0"]
    for x, y, b in points_bulges:
        body += ["10", repr(x), "20", repr(y)] + (["42", repr(b)] if b else [])
    body += ["0", "ENDSEC", "0", "EOF"]
    return "\n".join(body) + "\n"


def _dxf_lines(segments: list[tuple[float, float, float, float]]) -> str:
    """An R12-style DXF of LINE entities (x1, y1, x2, y2)."""
    body = ["0", "SECTION", "2", "ENTITIES"]
    for x1, y1, x2, y2 in segments:
        body += ["0", "LINE", "8", "0", "10", repr(x1), "20", repr(y1), "11", repr(x2), "21", repr(y2)]
    return "\n".join(body + ["0", "ENDSEC", "0", "EOF"]) + "\n"


def dxf_cases() -> list:
    texts = {
        "empty": "", "garbage": "this is not a drawing\n", "binary": b"\x00\x01" * 50,
        "no-entities": "0\nSECTION\n2\nENTITIES\n0\nENDSEC\n0\nEOF\n",
        "one-vertex": _dxf_polyline([(0, 0, 0)]),
        "same-vertices": _dxf_polyline([(1, 1, 0), (1, 1, 0), (1, 1, 0)]),
        "bulge-huge": _dxf_polyline([(0, 0, 1e10), (10, 0, 0), (10, 10, 0)]),
        "bulge-nan": _dxf_polyline([(0, 0, float("nan")), (10, 0, 0), (10, 10, 0)]),
        "coord-inf": _dxf_polyline([(0, 0, 0), (float("inf"), 0, 0), (10, 10, 0)]),
        "coord-huge": _dxf_polyline([(0, 0, 0), (1e300, 0, 0), (10, 10, 0)]),
        "truncated": _dxf_polyline([(0, 0, 0), (10, 0, 0), (10, 10, 0)])[:60],
        "only-degenerate": _dxf_lines([(1, 1, 1, 1), (5, 5, 5, 5)]),
    }
    cases = [(f"dxf-{n}", ["advise", "d.dxf", "-o", "o.csv"], {"d.dxf": t}) for n, t in texts.items()]
    good = _dxf_polyline([(0, 0, 0), (10, 0, 0), (10, 10, 0)])
    cases += [
        ("dxf-selector-handle", ["advise", "d.dxf#FFFF", "-o", "o.csv"], {"d.dxf": good}),
        ("dxf-selector-layer", ["advise", "d.dxf#layer=nope", "-o", "o.csv"], {"d.dxf": good}),
        ("dxf-selector-path", ["advise", "d.dxf#path=9", "-o", "o.csv"], {"d.dxf": good}),
        ("dxf-selector-junk", ["advise", "d.dxf#what=1", "-o", "o.csv"], {"d.dxf": good}),
        ("dxf-output-is-input", ["advise", "d.dxf", "-o", "d.dxf"], {"d.dxf": good}),
    ]
    return cases


def csv_cases() -> list:
    texts = {
        "header-only": "x_mm,y_mm\n", "text": "x_mm,y_mm\na,b\n1,1\n2,2\n",
        "nan": "x_mm,y_mm\n0,0\nnan,1\n2,2\n3,3\n", "inf": "x_mm,y_mm\n0,0\ninf,1\n2,2\n3,3\n",
        "repeat": "x_mm,y_mm\n0,0\n0,0\n0,0\n", "huge": "x_mm,y_mm\n0,0\n1e300,0\n1e300,1e300\n",
        "ragged": "x_mm,y_mm\n0,0\n1\n2,2,2,2\n", "empty": "", "binary": b"\x00\x00,\x01\n",
        "no-header": "0,0\n1,1\n2,0\n", "one-column": "x_mm\n1\n2\n3\n", "four-columns": "a,b,c,d\n1,2,3,4\n5,6,7,8\n9,1,2,3\n",
        "semicolon": "x_mm;y_mm\n0;0\n1;1\n2;0\n", "latin1": "x_mm,y_mm\n0,0\n1,1\n2,0\n\xe9\n".encode("latin-1"),
        "unknown-header": "lon,lat\n0,0\n1,1\n2,0\n", "1e400": "x_mm,y_mm\n0,0\n1e400,1\n2,0\n",
        "near-equal-1e-300": "x_mm,y_mm\n0,0\n1e-300,0\n2e-300,0\n",     # issue 28: 3 lines, no file
        "near-equal-1e-9": "x_mm,y_mm\n0,0\n1e-9,0\n0,1e-9\n",
    }
    cases = [(f"csv-{n}", ["advise", "p.csv", "-o", "o.csv"], {"p.csv": t}) for n, t in texts.items()]
    cases.append(("csv-selector", ["advise", "p.csv#2", "-o", "o.csv"], {"p.csv": POINTS}))
    cases.append(("csv-output-is-input", ["advise", "p.csv", "-o", "p.csv"], {"p.csv": POINTS}))
    return cases


# -------------------------------------------------------------------------------- output paths
def _socket(p: Path) -> None:
    s = socket.socket(socket.AF_UNIX)
    s.bind(str(p))
    s.close()


def output_cases() -> list:
    commands = {
        "advise": ["advise", "s.toml", *FAST], "plot": ["plot", "s.toml", "--points", "50"],
        "schedule": ["schedule", "s.toml"], "compare": ["compare", "s.toml", "--points", "60"],
        "surface": ["rules", "surface"],
    }
    places = {
        "folder": ("d", {"d": lambda p: p.mkdir()}), "missing-folder": ("nodir/o.out", {}),
        "file-as-folder": ("f.txt/o.out", {"f.txt": "x"}), "trailing-slash": ("o.out/", {}),
        "empty": ("", {}), "socket": ("sock", {"sock": _socket}),
        "loop": ("l1", {"l1": lambda p: os.symlink("l2", p), "l2": lambda p: os.symlink("l1", p)}),
        "link-to-folder": ("ld", {"dd": lambda p: p.mkdir(), "ld": lambda p: os.symlink("dd", p)}),
        "readonly": ("ro.out", {"ro.out": lambda p: (p.write_text("keep"), p.chmod(0o444))}),
    }
    cases = []
    for cname, argv in commands.items():
        for pname, (target, files) in places.items():
            cases.append((f"out-{cname}-{pname}", [*argv, "-o", target], {"s.toml": SHAPE, **files}))
        if cname != "surface":
            cases.append((f"out-{cname}-is-shape", [*argv, "-o", "s.toml"], {"s.toml": SHAPE}))
            cases.append((f"out-{cname}-is-shape-link", [*argv, "-o", "ls.toml"],
                          {"s.toml": SHAPE, "ls.toml": lambda p: os.symlink("s.toml", p)}))
    for cname in ("advise", "schedule", "compare"):
        argv = commands[cname]
        cases += [
            (f"out-{cname}-plot-equals-o", [*argv, "-o", "o.csv", "--plot", "o.csv"], {"s.toml": SHAPE}),
            (f"out-{cname}-plot-missing-folder", [*argv, "-o", "o.csv", "--plot", "nodir/o.png"],
             {"s.toml": SHAPE, "o.csv": "keep\n"}),
            (f"out-{cname}-plot-is-shape", [*argv, "-o", "o.csv", "--plot", "s.toml"], {"s.toml": SHAPE}),
        ]
    for cname in ("advise", "schedule"):
        argv = commands[cname]
        cases += [
            (f"out-{cname}-gcode-equals-o", [*argv, "-o", "o.csv", "--gcode", "o.csv"], {"s.toml": SHAPE}),
            (f"out-{cname}-gcode-folder", [*argv, "-o", "o.csv", "--gcode", "d"],
             {"s.toml": SHAPE, "o.csv": "keep\n", "d": lambda p: p.mkdir()}),
            (f"out-{cname}-g52-missing-folder", [*argv, "-o", "o.csv", "--gcode-g52", "nodir/o.ngc"],
             {"s.toml": SHAPE}),
            (f"out-{cname}-gcode-equals-g52", [*argv, "-o", "o.csv", "--gcode", "a.ngc", "--gcode-g52", "./a.ngc"],
             {"s.toml": SHAPE}),
            (f"out-{cname}-two-stdout", [*argv, "-o", "-", "--gcode", "-"], {"s.toml": SHAPE}),
            (f"out-{cname}-rules-is-output", ["advise", "s.toml", "--rules", "r.toml", "-o", "r.toml"],
             {"s.toml": SHAPE, "r.toml": _rules_text()}),
        ]
    return cases


#: Words the one error line of these cases must hold (the flag, the limit or the rule it names).
MESSAGES = {
    "flag-g52-csv-polyline": "--gcode-g52", "flag-jerk-tiny": "--jerk-mm-s3",
    "flag-jerk-tiny-compare": "--jerk-mm-s3", "flag-acc-tiny": "--axis-acc-mm-s2",
    "csv-near-equal-1e-300": "p.csv", "gcode-million-digit-number": "p.ngc:3",
    "gcode-coordinate-1e300-digits": "1 km", "gcode-incremental-past-1km": "1 km",
    "gcode-cut-past-sample-budget": "--step-mm", "gcode-endless-loop": "250,000 times",
    "toml-knotvector-16": "knots must lie within", "toml-knotvector-17": "knots must lie within",
    "gcode-divide-by-zero": "divide by zero", "gcode-long-sum": "characters", "gcode-comp-gouge": "gouging",
    "gcode-tool-not-in-table": "not in the tool table", "gcode-tool-table-garbage": "t.tbl:2",
    "dxf-only-degenerate": "no curve to follow",
}


def correct_cases() -> list:
    """Hostile-looking inputs that have a correct result (issue 28): ``(id, argv, files, made)``;
    the command exits 0 with no traceback or warning (at most notices) and writes ``made``."""
    huge_weights = _line(SHAPE, "weights", "[1e305, 1e305, 1e305, 1e305]")
    cusp = _line(SHAPE, "control_points", "[[0, 0], [10, 0], [10, 0], [20, 5]]")
    long_name = "a" * 246 + ".csv"
    return [
        ("equal-huge-weights", ["advise", "s.toml", "-o", "o.csv", *FAST], {"s.toml": huge_weights}, ["o.csv"]),
        ("equal-huge-weights-schedule", ["schedule", "s.toml", "-o", "o.csv"], {"s.toml": huge_weights}, ["o.csv"]),
        ("cusp-plot", ["plot", "s.toml", "-o", "o.png", "--points", "200"], {"s.toml": cusp}, ["o.png"]),
        ("name-of-250-characters", ["advise", "s.toml", "-o", long_name, *FAST], {"s.toml": SHAPE}, [long_name]),
        ("schedule-name-of-250", ["schedule", "s.toml", "-o", long_name], {"s.toml": SHAPE}, [long_name]),
        ("csv-near-duplicate", ["advise", "p.csv", "-o", "o.csv"],
         {"p.csv": "x_mm,y_mm\n0,0\n10,0\n10,1e-300\n10,10\n"}, ["o.csv"]),
        ("gcode-only-rapids", ["advise", "p.ngc", "-o", "o.csv", "--gcode", "o.ngc"],
         {"p.ngc": "G21 G90\nG0 X0 Y0\nG0 X10 Y0\nM2\n"}, ["o.csv", "o.ngc"]),
        ("gcode-no-moves", ["advise", "p.ngc", "-o", "o.csv", "--gcode", "o.ngc"],
         {"p.ngc": "G21 G90\nM2\n"}, ["o.csv", "o.ngc"]),
        ("gcode-one-point", ["advise", "p.ngc", "-o", "o.csv", "--gcode", "o.ngc"],
         {"p.ngc": "G21 G90\nG0 X0 Y0\nG1 X0 Y0 F100\nM2\n"}, ["o.csv", "o.ngc"]),
        ("gcode-safety-line", ["advise", "p.ngc", "-o", "o.csv", "--gcode", "o.ngc"],
         {"p.ngc": "N1 G00 G17 G21 G40 G49 G80 G90\n" + PROGRAM}, ["o.csv", "o.ngc"]),
        ("gcode-expressions", ["advise", "p.ngc", "-o", "o.csv", "--gcode", "o.ngc"],
         {"p.ngc": "G21 G90\n#1 = 5\nG0 X0 Y0\nG1 X[#1 * 2] Y[sin[30]] F600\nG1 X[360 / 17] Y10\nM2\n"},
         ["o.csv", "o.ngc"]),
        ("gcode-comp-without-table", ["advise", "p.ngc", "-o", "o.csv"],
         {"p.ngc": "G21 F300\nT1 M6\nG0 X-10 Y-10\nG41\nG1 X0 Y0\nG1 X10\nG1 Y10\nG40 G0 X0 Y0\nM2\n"},
         ["o.csv"]),
        ("dxf-degenerate-and-gap", ["advise", "d.dxf", "-o", "o.csv"], {"d.dxf": _dxf_lines(
            [(0, 0, 10, 0), (10, 0, 10, 10), (10.05, 10, 20, 10), (3, 3, 3, 3)])}, ["o.csv"]),
    ]


def cli_cases() -> list:
    return shape_cases() + rule_cases() + flag_cases() + program_cases() + dxf_cases() + csv_cases() + \
        output_cases()


# -------------------------------------------------------------------------------- the Python API
def api_cases() -> list:
    """Public calls with wrong types or values: each must raise a FuzzyfeedError (one line)."""
    import numpy as np

    from fuzzyfeed import Nurbs, sample_by_arc_length, sample_uniform_u
    from fuzzyfeed.report.compare import compare
    from fuzzyfeed.fuzzy.advisor import advise, advise_details, average_filter
    from fuzzyfeed.fuzzy.engine import feed_pct
    from fuzzyfeed.fuzzy.features import features
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table, parse_rule_table
    from fuzzyfeed.fuzzy.rule_writer import set_cell_text
    from fuzzyfeed.io.csv import write_columns
    from fuzzyfeed.io.shapes import load_shape, sample_shape, shape_from_mapping
    from fuzzyfeed.machine.limits import MachineLimits, feed_limits
    from fuzzyfeed.machine.profile import FeedProfile
    from fuzzyfeed.geometry.sampling import PathSamples, samples_from_points, three_point_curvature
    from fuzzyfeed.slw import schedule

    good = dict(degree=2, knots=[0, 0, 0, 0.5, 1, 1, 1], control_points=[[0, 0], [10, 5], [20, -5], [30, 0]])

    def nurbs(**kw):
        return lambda: Nurbs(**{**good, **kw})

    def curve():
        return Nurbs(**good)

    def samples(n=50):
        return sample_uniform_u(curve(), n)

    nan_s = lambda: PathSamples(u=np.linspace(0, 1, 5), xyz=np.zeros((5, 3)), s=np.array([0, 1, np.nan, 3, 4.0]),
                                tangent=np.zeros((5, 3)), curvature=np.zeros(5),
                                d1=np.zeros((5, 3)), d2=np.zeros((5, 3)))
    cases = [
        ("nurbs-degree-str", nurbs(degree="2")), ("nurbs-degree-none", nurbs(degree=None)),
        ("nurbs-degree-float", nurbs(degree=2.5)), ("nurbs-degree-bool", nurbs(degree=True)),
        ("nurbs-knots-none", nurbs(knots=None)), ("nurbs-knots-str", nurbs(knots="0 0 0 1 1 1")),
        ("nurbs-knots-dict", nurbs(knots={"a": 1})), ("nurbs-knots-ragged", nurbs(knots=[[0, 0], [1]])),
        ("nurbs-points-none", nurbs(control_points=None)), ("nurbs-points-str", nurbs(control_points="abc")),
        ("nurbs-points-ragged", nurbs(control_points=[[0, 0], [1]])),
        ("nurbs-points-complex", nurbs(control_points=[[0j, 0], [1, 1], [2, 0], [3, 1]])),
        ("nurbs-weights-str", nurbs(weights="1111")), ("nurbs-weights-ratio", nurbs(weights=[1, 1e9, 1, 1])),
        ("nurbs-points-object", nurbs(control_points=object())),
        ("sample-u-str", lambda: sample_uniform_u(curve(), "10")),
        ("sample-u-float", lambda: sample_uniform_u(curve(), 10.0)),
        ("sample-u-huge", lambda: sample_uniform_u(curve(), 10**12)),
        ("sample-u-not-curve", lambda: sample_uniform_u("circle", 10)),
        ("sample-u-none", lambda: sample_uniform_u(None)),
        ("sample-s-not-curve", lambda: sample_by_arc_length([1, 2], n=10)),
        ("sample-s-step-str", lambda: sample_by_arc_length(curve(), step_mm="1")),
        ("sample-s-step-tiny", lambda: sample_by_arc_length(curve(), step_mm=1e-12)),
        ("sample-s-n-str", lambda: sample_by_arc_length(curve(), n="5")),
        ("points-str", lambda: samples_from_points("0,0 1,1 2,0")),
        ("points-none", lambda: samples_from_points(None)),
        ("points-nan", lambda: samples_from_points([[0, 0], [np.nan, 1], [2, 0]])),
        ("three-point-str", lambda: three_point_curvature("abc")),
        ("limits-feed-str", lambda: MachineLimits(feed_mm_s="fast")),
        ("limits-feed-none", lambda: MachineLimits(feed_mm_s=None)),
        ("limits-feed-huge", lambda: MachineLimits(feed_mm_s=1e300)),
        ("limits-axis-str", lambda: MachineLimits(axis_vel_mm_s="1,2,3")),
        ("limits-axis-dict", lambda: MachineLimits(axis_acc_mm_s2={"x": 1})),
        ("limits-ts-list", lambda: MachineLimits(ts_s=[0.001])),
        ("limits-ts-long", lambda: MachineLimits(ts_s=5.0)),
        ("feed-limits-not-samples", lambda: feed_limits("samples", MachineLimits())),
        ("feed-limits-not-limits", lambda: feed_limits(samples(), {"feed": 1})),
        ("filter-str", lambda: average_filter("abc", 3)), ("filter-nan", lambda: average_filter([1.0, np.nan, 2.0], 3)),
        ("filter-inf", lambda: average_filter([1.0, np.inf, 2.0], 3)), ("filter-points-str", lambda: average_filter([1.0, 2.0], "3")),
        ("filter-points-0", lambda: average_filter([1.0, 2.0], 0)),
        ("filter-points-even", lambda: average_filter([1.0, 2.0, 3.0], 4)), ("filter-2d", lambda: average_filter([[1.0], [2.0]], 1)),
        ("filter-none", lambda: average_filter(None, 3)),
        ("features-str", lambda: features("abc")), ("features-nan", lambda: features(np.array([0.1, np.nan, 0.2]))),
        ("features-window-str", lambda: features(np.ones(10), window_points="3")),
        ("features-clip-neg", lambda: features(np.ones(10), clip_1_mm=-1.0)),
        ("engine-table-str", lambda: feed_pct("paper", np.ones(3), np.ones(3))),
        ("engine-nan", lambda: feed_pct(load_rule_table(), np.array([np.nan]), np.array([0.1]))),
        ("advise-none", lambda: advise(None)), ("advise-str", lambda: advise("circle")),
        ("advise-table-str", lambda: advise(samples(), table=5)),
        ("advise-feed-str", lambda: advise(samples(), None, "fast")),
        ("advise-feed-nan", lambda: advise(samples(), None, float("nan"))),
        ("advise-feed-huge", lambda: advise(samples(), None, 1e300)),
        ("advise-details-list", lambda: advise_details([1, 2, 3])),
        ("profile-feed-str", lambda: FeedProfile(samples(5), "fast", "x", 1.0)),
        ("profile-samples-none", lambda: FeedProfile(None, np.ones(5), "x", 1.0)),
        ("profile-max-str", lambda: FeedProfile(samples(5), np.ones(5), "x", "1")),
        ("profile-nan-lengths", lambda: FeedProfile(nan_s(), np.ones(5), "x", 1.0).travel_time_s()),
        ("schedule-str", lambda: schedule("curve")), ("schedule-none", lambda: schedule(None)),
        ("schedule-limits-dict", lambda: schedule(curve(), {"feed_mm_s": 1})),
        ("schedule-approach", lambda: schedule(curve(), MachineLimits(), approach=3)),
        ("compare-str", lambda: compare("samples", MachineLimits())),
        ("compare-limits-none", lambda: compare(samples(), None)),
        ("load-shape-int", lambda: load_shape(123)), ("load-shape-none", lambda: load_shape(None)),
        ("load-shape-missing", lambda: load_shape("no/such/file.toml")),
        ("sample-shape-str", lambda: sample_shape("circle")),
        ("shape-mapping-list", lambda: shape_from_mapping([1, 2])),
        ("shape-mapping-empty", lambda: shape_from_mapping({})),
        ("rules-int", lambda: load_rule_table(5)), ("rules-missing", lambda: load_rule_table("no/such.toml")),
        ("rules-parse-bytes", lambda: parse_rule_table(b"[rules]")), ("rules-parse-garbage", lambda: parse_rule_table("x = = 1")),
        ("rules-set-cell-bad", lambda: set_cell_text("x = 1", "VS", "M", "HF")),
        ("csv-columns-none", lambda: write_columns("/tmp/never-written.csv", None)),
        ("csv-columns-ragged", lambda: write_columns("/tmp/never-written.csv", {"a": np.ones(2), "b": np.ones(3)})),
        ("csv-columns-nan", lambda: write_columns("/tmp/never-written.csv", {"a": np.array([np.nan])})),
        ("csv-path-folder", lambda: write_columns("/tmp", {"a": np.ones(2)})),
        ("samples-nan-rows", lambda: PathSamples(u=np.zeros(3), xyz=np.zeros((2, 3)), s=np.zeros(3),
                                                 tangent=np.zeros((3, 3)), curvature=np.zeros(3),
                                                 d1=np.zeros((3, 3)), d2=np.zeros((3, 3)))),
    ]
    return cases
