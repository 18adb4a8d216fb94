"""Write the round-trip corpus: G-code programs in the dialects real posts and senders produce.

Run ``python tests/programs/make_corpus.py`` to regenerate ``tests/programs/corpus/*.ngc`` (the
files are committed; the test reads them). Written for fuzzyfeed, modelled on what public
programs show (no third-party file is copied):

- ``freecad_*``: FreeCAD Path's LinuxCNC post — comment header, ``G17 G54 G40 G49 G80 G90``,
  ``M6 T1``, ``G43 H1``, every move with X Y Z and F at 3 decimals, ``M05``, ``M2``.
- ``fusion_*``: Fusion 360 / Mastercam-style posts — ``%``, tool comment, ``G90 G94 G17 G91.1``,
  ``T1 M6``, ``S M3``, ``G54``/``G55``, coolant, ``G43 Z H``, modal words, trailing-dot numbers,
  ``G28 G91 Z0.``, ``M1`` between tools, ``N`` numbers, R or I/J arcs, ``M30``.
- ``grbl_*``: sender files — ``G21 G90 G94``, ``G00/G01/G02`` with leading zeros, lower case or
  no spaces, ``;`` comments, F on every line, I/J arcs, ``M3 S``/``M5``.
- ``lcnc_*``: LinuxCNC examples — inch programs, ``G64 P``, ``G10 L2``, ``G18``/``G19`` and
  helical arcs, full circles with P, ``G91`` blocks, drilling cycles ``G81``/``G83`` with
  ``G98``/``G99``, ``G5.2`` NURBS, ``M62``–``M65``, ``G4``, ``G61``, ``G96``/``G97``,
  ``G53 G0``, ``G30``, ``(MSG, …)``.
"""

from __future__ import annotations

import math
from pathlib import Path

OUT = Path(__file__).resolve().parent / "corpus"


# ------------------------------------------------------------------ geometry (moves in mm)
# a move: ("G1", x, y, z) or ("G2"/"G3", x, y, z, i, j) (I, J incremental from the move's start)

def rounded_rect(x0, y0, w, h, r, z):
    """Counter-clockwise rectangle with corner radius r, starting mid-bottom-left."""
    m = [("G1", x0 + w - r, y0, z),
         ("G3", x0 + w, y0 + r, z, 0.0, r),
         ("G1", x0 + w, y0 + h - r, z),
         ("G3", x0 + w - r, y0 + h, z, -r, 0.0),
         ("G1", x0 + r, y0 + h, z),
         ("G3", x0, y0 + h - r, z, 0.0, -r),
         ("G1", x0, y0 + r, z),
         ("G3", x0 + r, y0, z, r, 0.0)]
    return (x0 + r, y0), m


def polygon(cx, cy, radius, n, z, phase=0.0):
    pts = [(cx + radius * math.cos(phase + 2 * math.pi * k / n),
            cy + radius * math.sin(phase + 2 * math.pi * k / n)) for k in range(n + 1)]
    return pts[0], [("G1", x, y, z) for x, y in pts[1:]]


def star(cx, cy, r1, r2, n, z):
    pts = []
    for k in range(2 * n + 1):
        r = r1 if k % 2 == 0 else r2
        a = math.pi * k / n
        pts.append((cx + r * math.cos(a), cy + r * math.sin(a)))
    return pts[0], [("G1", x, y, z) for x, y in pts[1:]]


def ellipse_polyline(cx, cy, a, b, n, z):
    """A CAM polyline: many short G1 moves on an ellipse (tight at the ends of the major axis)."""
    pts = [(cx + a * math.cos(2 * math.pi * k / n), cy + b * math.sin(2 * math.pi * k / n))
           for k in range(n + 1)]
    return pts[0], [("G1", x, y, z) for x, y in pts[1:]]


def slot(x0, y0, length, r, z):
    """A slot outline: line, half circle, line, half circle (counter-clockwise)."""
    m = [("G1", x0 + length, y0, z),
         ("G3", x0 + length, y0 + 2 * r, z, 0.0, r),
         ("G1", x0, y0 + 2 * r, z),
         ("G3", x0, y0, z, 0.0, -r)]
    return (x0, y0), m


def zigzag(x0, y0, w, h, step, z):
    """Raster pocket: back and forth lines with sharp reversals."""
    m = []
    y, right = y0, True
    while y + step <= y0 + h + 1e-9:
        m.append(("G1", x0 + w if right else x0, y, z))
        y += step
        m.append(("G1", x0 + w if right else x0, y, z))
        right = not right
    return (x0, y0), m


def spiral_arcs(cx, cy, r0, dr, n, z):
    """Half circles of growing radius (an open spiral), alternately above and below."""
    m = []
    x, y = cx + r0, cy
    r = r0
    for k in range(n):
        # half circle about a centre on the x axis, radius growing by dr/2 each half
        c = cx if k % 2 == 0 else cx + dr / 2
        r_new = abs(x - c)
        nx = c - r_new if k % 2 == 0 else c + r_new
        m.append(("G3", nx, y, z, c - x, 0.0))
        x = nx
        r = r_new
    del r
    return (cx + r0, cy), m


def helix_circle(cx, cy, r, z_top, z_bottom, turns):
    """Helical entry down to z_bottom (G2, P turns), then a full circle at the bottom."""
    return (cx + r, cy), [("G1", cx + r, cy, z_top), ("G2", cx + r, cy, z_bottom, -r, 0.0, turns),
                          ("G2", cx + r, cy, z_bottom, -r, 0.0)]


GEOMETRIES = [
    lambda s: rounded_rect(5 * s, 5 * s, 60 * s, 40 * s, 3 * s, -1.0),
    lambda s: polygon(40 * s, 30 * s, 25 * s, 6, -0.8),
    lambda s: star(40 * s, 30 * s, 25 * s, 10 * s, 5, -0.5),
    lambda s: ellipse_polyline(40 * s, 30 * s, 30 * s, 8 * s, 120, -0.6),
    lambda s: slot(10 * s, 10 * s, 50 * s, 6 * s, -1.2),
    lambda s: zigzag(10 * s, 10 * s, 40 * s, 20 * s, 4 * s, -0.7),
    lambda s: spiral_arcs(40 * s, 30 * s, 2 * s, 3 * s, 8, -0.5),
]


# ------------------------------------------------------------------ number styles

def f3(v):
    return f"{v:.3f}"


def fusion_num(v):
    """Fusion/Mastercam style: no trailing zeros, keep the dot ('15.', '-1.25', '.5')."""
    text = f"{v:.4f}".rstrip("0")
    if text.startswith("0."):
        text = text[1:]
    elif text.startswith("-0."):
        text = "-" + text[2:]
    return "0." if text in (".", "-.") else text


def plain(v, d=3):
    text = f"{v:.{d}f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0") else text


# ------------------------------------------------------------------ dialects

def freecad(ops, title):
    out = ["(Exported by FreeCAD)", "(Post Processor: linuxcnc_post)", f"(Output Time: {title})",
           "(begin preamble)", "G17 G54 G40 G49 G80 G90", "G21"]
    pos = [0.0, 0.0, 0.0]
    for k, (tool, feed, plunge, geo) in enumerate(ops):
        (sx, sy), moves = geo
        out += [f"(begin operation: TC: Endmill {tool})", "(machine units: mm/min)",
                f"M6 T{tool}", f"G43 H{tool}", f"M3 S{8000 + 1000 * k}",
                f"(finish operation: TC: Endmill {tool})", f"(begin operation: Profile{k})",
                "(machine units: mm/min)", f"G0 Z{f3(15)}", f"G0 X{f3(sx)} Y{f3(sy)}", f"G0 Z{f3(3)}"]
        z = moves[0][3]
        out.append(f"G1 X{f3(sx)} Y{f3(sy)} Z{f3(z)} F{f3(plunge)}")
        for mv in moves:
            if mv[0] == "G1":
                out.append(f"G1 X{f3(mv[1])} Y{f3(mv[2])} Z{f3(mv[3])} F{f3(feed)}")
            else:
                out.append(f"{mv[0]} X{f3(mv[1])} Y{f3(mv[2])} Z{f3(mv[3])} I{f3(mv[4])} J{f3(mv[5])} F{f3(feed)}")
        out += [f"G0 Z{f3(15)}", f"(finish operation: Profile{k})"]
        pos = [moves[-1][1], moves[-1][2], 15.0]
    del pos
    out += ["(begin postamble)", "M05", "G17 G54 G90 G80 G40", "M2"]
    return out


def fusion(ops, title, use_r=False, numbers=True, wcs=("G54", "G55")):
    body = [f"({title})", "(T1 D=6. CR=0. - ZMIN=-1.2 - FLAT END MILL)", "G90 G94 G17 G91.1", "G21"]
    for k, (tool, feed, plunge, geo) in enumerate(ops):
        (sx, sy), moves = geo
        n = fusion_num
        if k:
            body += ["M1"]
        body += [f"(2D CONTOUR{k + 1})", f"T{tool} M6", f"S{9000 + 500 * k} M3", wcs[k % len(wcs)],
                 "M8" if k % 2 == 0 else "M7", f"G0 X{n(sx)} Y{n(sy)}", f"G43 Z15. H{tool}",
                 "G0 Z5.", f"G1 Z1. F{n(plunge * 3)}", f"Z{n(moves[0][3])} F{n(plunge)}"]
        last = [sx, sy, moves[0][3]]
        last_f = None
        last_g = "G1"
        for mv in moves:
            words = []
            g = mv[0]
            if g != last_g or g != "G1":
                words.append(g)
            for i, c in enumerate("XYZ"):
                if abs(mv[1 + i] - last[i]) > 1e-9 or (g != "G1" and c in "XY"):
                    words.append(c + n(mv[1 + i]))
            if g != "G1":
                if use_r and abs(mv[4]) + abs(mv[5]) > 0 and len(mv) == 6:
                    r = math.hypot(mv[4], mv[5])
                    words.append("R" + n(r))
                else:
                    words += ["I" + n(mv[4]), "J" + n(mv[5])]
            if feed != last_f:
                words.append("F" + n(feed))
                last_f = feed
            if len(words) == (1 if g != "G1" else 0):
                continue
            body.append(" ".join(words))
            last = [mv[1], mv[2], mv[3]]
            last_g = g
        body += ["G0 Z15.", "M9", "M5", "G28 G91 Z0.", "G90"]
    body += ["G28 G91 X0. Y0.", "G90", "M30"]
    if numbers:
        body = [f"N{10 * (i + 1)} {line}" if not line.startswith("(") else line
                for i, line in enumerate(body)]
    return ["%"] + body + ["%"]


def grbl(ops, title, style="lower"):
    out = [f"; {title}", "; generated for a GRBL-style sender", "G21", "G90", "G94"]
    z_safe = 5.0
    for k, (tool, feed, plunge, geo) in enumerate(ops):
        (sx, sy), moves = geo
        out += [f"M3 S{12000 - 1000 * k}", f"G00 Z{plain(z_safe)}", f"G00 X{plain(sx)} Y{plain(sy)}",
                f"G01 Z{plain(moves[0][3])} F{plain(plunge)}"]
        for mv in moves:
            if mv[0] == "G1":
                line = f"G01 X{plain(mv[1])} Y{plain(mv[2])} F{plain(feed)}"
            else:
                g = "G02" if mv[0] == "G2" else "G03"
                line = f"{g} X{plain(mv[1])} Y{plain(mv[2])} I{plain(mv[4], 4)} J{plain(mv[5], 4)} F{plain(feed)}"
            if style == "lower":
                line = line.lower()
            elif style == "packed":
                line = line.replace(" ", "")
            out.append(line)
        out += [f"G00 Z{plain(z_safe)}  ; retract"]
    out += ["M5", "G00 X0 Y0", "M30"]
    return out


def lcnc(ops, title, variant):
    inch = variant % 3 == 1
    s = 1 / 25.4 if inch else 1.0
    u = (lambda v: f"{v * s:.5f}".rstrip("0").rstrip(".")) if inch else (lambda v: f"{v:.4f}".rstrip("0").rstrip("."))
    out = ["%", f"(LinuxCNC example: {title})", f"(MSG, {title} starts)",
           ("G20" if inch else "G21") + " G17 G40 G49 G90 G94", f"G64 P{u(0.01)}",
           "G10 L2 P1 X0 Y0 Z0", "G54"]
    for k, (tool, feed, plunge, geo) in enumerate(ops):
        (sx, sy), moves = geo
        fs = (lambda f: f"{f * s:.2f}") if inch else (lambda f: f"{f:g}")
        out += [f"T{tool} M6", f"G43 H{tool}", f"S{6000 + 1000 * k} M3", "M8", "M62 P0",
                f"G0 Z{u(10)}", f"G0 X{u(sx)} Y{u(sy)}", f"G0 Z{u(2)}",
                f"G1 Z{u(moves[0][3])} F{fs(plunge)}", f"F{fs(feed)}"]
        if variant % 4 == 2 and k == 0:
            out.append("G61")
        if variant % 5 == 3 and k == 0:
            out.append(f"G96 D8000 S{120 + k}")
        for mv in moves:
            if mv[0] == "G1":
                out.append(f"G1 X{u(mv[1])} Y{u(mv[2])}")
            else:
                extra = f" P{mv[6]}" if len(mv) > 6 else ""
                out.append(f"{mv[0]} X{u(mv[1])} Y{u(mv[2])} Z{u(mv[3])} I{u(mv[4])} J{u(mv[5])}{extra}")
        out += ["M63 P0", "G4 P0.5" if k == 0 else "G4 P0.2", f"G0 Z{u(10)}"]
        if variant % 4 == 2 and k == 0:
            out.append(f"G64 P{u(0.005)}")
        if variant % 5 == 3 and k == 0:
            out.append("G97 S7000")
    # extra sections LinuxCNC examples show
    last_tool = ops[-1][0]
    del last_tool
    zt = -0.5
    if variant % 2 == 0:
        # G18 / G19 arcs (a ball-nose profile across X and across Y)
        out += [f"G0 X{u(10)} Y{u(70)} Z{u(2)}", f"G1 Z{u(zt)} F{100 * s if inch else 100:g}",
                "G18", f"G2 X{u(20)} Z{u(zt)} I{u(5)} K{u(0)}", f"G3 X{u(30)} Z{u(zt)} I{u(5)} K{u(0)}",
                "G19", f"G2 Y{u(80)} Z{u(zt)} J{u(5)} K{u(0)}", "G17", f"G1 X{u(40)}",
                f"G0 Z{u(10)}"]
    else:
        # an incremental (G91) square with a sharp corner, then back to G90
        out += [f"G0 X{u(70)} Y{u(70)} Z{u(2)}", f"G1 Z{u(zt)} F{120 * s if inch else 120:g}",
                "G91", f"G1 X{u(10)}", f"Y{u(10)}", f"X{u(-10)}", f"Y{u(-10)}", "G90",
                f"G0 Z{u(10)}"]
    if variant % 3 == 0:
        # drilling cycles
        out += ["G98", f"G81 X{u(10)} Y{u(90)} Z{u(-3)} R{u(2)} F{50 * s if inch else 50:g}",
                f"X{u(20)}", "G99", f"G83 X{u(30)} Y{u(90)} Z{u(-5)} R{u(2)} Q{u(1)}", "G80"]
    if variant % 3 == 2 and not inch:
        # a G5.2 NURBS block
        out += [f"G0 X{u(0)} Y{u(100)} Z{u(2)}", f"G1 Z{u(zt)} F80", "G5.2 P1 L3",
                f"X{u(10)} Y{u(115)} P1", f"X{u(20)} Y{u(100)} P2", f"X{u(30)} Y{u(110)} P1", "G5.3",
                f"G1 X{u(35)} Y{u(100)}", f"G0 Z{u(10)}"]
    out += ["M64 P1", "M65 P1", "M9", "M5", "G53 G0 Z0", "G30", "(MSG, done)", "M2", "%"]
    return out


def corpus():
    programs = {}
    for v in range(11):
        s = 1.0 + 0.15 * v
        geo = GEOMETRIES[v % len(GEOMETRIES)]
        geo2 = GEOMETRIES[(v + 3) % len(GEOMETRIES)]
        ops = [(1 + v % 3, 600 + 100 * v, 150 + 10 * v, geo(s)), (2 + v % 4, 900 + 50 * v, 200, geo2(s * 0.8))]
        programs[f"freecad_{v:02d}"] = freecad(ops[: 1 + v % 2], f"freecad {v}")
        programs[f"fusion_{v:02d}"] = fusion(ops, f"fusion {v}", use_r=v % 2 == 1, numbers=v % 3 != 2)
        programs[f"grbl_{v:02d}"] = grbl(ops[: 1 + (v + 1) % 2], f"grbl {v}",
                                         style=("lower", "packed", "plain")[v % 3])
        ops_l = [(1 + v % 3, 500 + 50 * v, 120, geo(s * 0.9))]
        if v % 2:
            ops_l.append((3, 700, 150, helix_circle(40 * s, 40 * s, 6, -0.2, -1.5, 2)))
        programs[f"lcnc_{v:02d}"] = lcnc(ops_l, f"lcnc {v}", v)
    return programs


def main() -> None:
    OUT.mkdir(exist_ok=True)
    for name, lines in corpus().items():
        (OUT / f"{name}.ngc").write_text("\n".join(lines) + "\n")
    print(f"wrote {len(corpus())} programs to {OUT}")


if __name__ == "__main__":
    main()
