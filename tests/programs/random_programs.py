"""Random LinuxCNC programs for the reader's parity test with rs274 (tests/test_program_parity.py):
modal words, polar words in G90 and G91, loops and subroutines, offsets (G54-G59, G92, G92.1, G52),
planes G17/G18/G19, units G20/G21 (with F and with motion on the line that changes them), feed
modes G93/G94/G95, cutter compensation with the tool table below, spindle-synchronised G33 and
G76. Written for fuzzyfeed; seeded, so a failing program can be printed again from its seed.

Every program starts with a line that sets the units alone and a line of the modal state, so that
programs can be run one after another in one rs274 call (see :func:`batch`)."""

from __future__ import annotations

import math
import random

#: The tool table both readers get (rs274 stand-alone reads it in inches): small diameters, so
#: that most compensated entries are longer than the radius.
TOOL_TABLE = "".join(f"T{t} P{t} D{0.01 * t:.3f} Z0 ;tool {t}\n" for t in range(1, 10))
#: The same tools with other lengths: a tool length is the machine's, not the program's.
TOOL_TABLE_B = "".join(f"T{t} P{t} D{0.01 * t:.3f} Z{0.2 + 0.05 * t:.3f} ;tool {t}\n" for t in range(1, 10))

_PLANES = {17: ("X", "Y", "Z", "I", "J"), 18: ("Z", "X", "Y", "K", "I"), 19: ("Y", "Z", "X", "J", "K")}


class _Gen:
    def __init__(self, rng: random.Random, tag: int):
        self.rng, self.tag = rng, tag
        self.out: list[str] = []
        self.inch = rng.random() < 0.3
        self.absolute = True
        self.plane = 17
        self.mode = 94

    def num(self, lo, hi, d=3):
        v = self.rng.uniform(lo, hi) * (1 / 25.4 if self.inch else 1)
        return f"{v:.{d + (1 if self.inch else 0)}f}"

    def feed(self):
        return f"F{self.rng.choice([50, 120, 300, 800, 1500]) / (25.4 if self.inch else 1):.3f}"

    def header(self):
        r = self.rng
        self.out.append("G20" if self.inch else "G21")
        self.out.append(f"G90 G17 G94 G40 G49 G80 G54 G64 {self.feed()} S1000 M3")

    def move(self):
        r = self.rng
        g = r.choice(["G0", "G1", "G1", "G1"])
        axes = r.sample("XYZ", r.randint(1, 3))
        words = " ".join(f"{a}{self.num(-30, 30)}" for a in sorted(axes))
        extra = f" {self.feed()}" if g == "G1" and r.random() < 0.3 else ""
        self.out.append(f"{g} {words}{extra}".strip())

    def arc(self):
        r = self.rng
        a, b, n, i, j = _PLANES[self.plane]
        px, py = float(self.num(-20, 20)), float(self.num(-20, 20))
        rad = float(self.num(2, 15))
        t0, sweep = r.uniform(0, 2 * math.pi), r.uniform(0.2, 5.5)
        cx, cy = px - rad * math.cos(t0), py - rad * math.sin(t0)
        g = r.choice(["G2", "G3"])
        t1 = t0 + (sweep if g == "G3" else -sweep)
        ex, ey = cx + rad * math.cos(t1), cy + rad * math.sin(t1)
        d = 5 if self.inch else 4
        self.out.append(f"G90 G0 {a}{px:.{d}f} {b}{py:.{d}f}")
        helix = f" {n}{self.num(-5, 5)}" if r.random() < 0.2 else ""
        if r.random() < 0.25 and sweep < math.pi:
            word = f"R{rad:.{d}f}"
            ex, ey = cx + rad * math.cos(t1), cy + rad * math.sin(t1)
        else:
            word = f"{i}{cx - px:.{d}f} {j}{cy - py:.{d}f}"
        self.out.append(f"{g} {a}{ex:.{d}f} {b}{ey:.{d}f}{helix} {word}")
        if not self.absolute:
            self.out.append("G91")

    def polar(self):
        r = self.rng
        if self.plane != 17:
            self.out.append("G17")
            self.plane = 17
        self.out.append(f"G90 G0 X{self.num(3, 20)} Y{self.num(3, 20)}")
        for _ in range(r.randint(1, 4)):
            if r.random() < 0.5:
                self.out.append(f"G91 G1 @{self.num(-0.5, 0.5)} ^{r.uniform(-20, 20):.2f}")
            else:
                which = r.choice(["@", "^", "@^"])
                words = []
                if "@" in which:
                    words.append(f"@{self.num(3, 20)}")
                if "^" in which:
                    words.append(f"^{r.uniform(-180, 180):.2f}")
                self.out.append("G90 G1 " + " ".join(words))
        self.out.append("G90" if self.absolute else "G91")

    def units(self):
        r = self.rng
        self.inch = not self.inch
        code = "G20" if self.inch else "G21"
        form = r.choice(["alone", "feed", "move", "feedmove"])
        if form == "alone":
            self.out.append(code)
        elif form == "feed":     # issue 37: the F is read in the units before the line
            self.out.append(f"{code} F{r.choice([6, 20, 100, 400])}")
        elif form == "move":
            self.out.append(f"{code} G1 X{self.num(-10, 10)}")
        else:
            self.out.append(f"{code} G1 Y{self.num(-10, 10)} F{r.choice([6, 20, 100, 400])}")

    def distance(self):
        self.absolute = not self.absolute
        self.out.append("G90" if self.absolute else "G91")

    def plane_change(self):
        self.plane = self.rng.choice([17, 18, 19])
        self.out.append(f"G{self.plane}")

    def offsets(self):
        r = self.rng
        if r.random() < 0.2:
            self.out.append(f"G10 L2 P{r.choice([0, 1, 2])} X{self.num(-9, 9)} Y{self.num(-9, 9)} Z{self.num(-9, 9)}")
        self.out.append(r.choice(["G55", "G54", "G59", "G92 X0 Y0", f"G92 Z{self.num(-5, 5)}", "G92.1",
                                  f"G52 X{self.num(-5, 5)} Y{self.num(-5, 5)}", "G52 X0 Y0 Z0",
                                  "G92 X1 Y2 Z3", "G92.2", "G92.3"]))
        self.out.append(f"G90 G0 X{self.num(-5, 5)} Y{self.num(-5, 5)} Z{self.num(1, 5)}")
        if not self.absolute:
            self.out.append("G91")

    def feed_modes(self):
        r = self.rng
        if r.random() < 0.5:
            self.out.append(f"G93 G1 X{self.num(-10, 10)} F{r.uniform(1, 50):.2f}")
            self.out.append(f"G1 Y{self.num(-10, 10)} F{r.uniform(1, 50):.2f}")
        else:
            self.out.append(f"G95 G1 X{self.num(-10, 10)} F{r.uniform(0.01, 0.2):.3f}")
        self.out.append(f"G94 {self.feed()}")

    def synced(self):
        r = self.rng
        if r.random() < 0.96:
            self.out.append(f"M3 S1000 G33 Z{self.num(-10, 10)} K{self.num(0.5, 2)}")
        else:
            self.out.append("M3 S1000 G18 G90 G0 X5 Z1" if not self.inch else "M3 S1000 G18 G90 G0 X0.2 Z0.04")
            self.out.append("G76 P0.05 Z-2 I-0.05 J0.02 K0.1 Q29 H1" if self.inch else
                            "G76 P1 Z-5 I-1 J0.5 K2 Q29 H1")
            self.out.append(f"G{self.plane} G{90 if self.absolute else 91}")

    def comp(self):
        r = self.rng
        self.out.append(f"G17 G90 T{r.randint(1, 9)} M6")
        cx, cy = float(self.num(-5, 5)), float(self.num(-5, 5))
        d = 5 if self.inch else 4
        scale = 1 / 25.4 if self.inch else 1
        self.out.append(f"G0 X{cx - 40 * scale:.{d}f} Y{cy - 40 * scale:.{d}f}")
        self.out.append(r.choice(["G41", "G42"]))
        n = r.randint(3, 6)
        pts = [(cx + 20 * scale * math.cos(2 * math.pi * k / n), cy + 20 * scale * math.sin(2 * math.pi * k / n))
               for k in range(n)]
        for x, y in pts + pts[:1]:
            self.out.append(f"G1 X{x:.{d}f} Y{y:.{d}f}")
        self.out.append("G40")
        self.out.append(f"G0 X{cx - 40 * scale:.{d}f} Y{cy - 40 * scale:.{d}f}")
        self.out.append(f"G{self.plane} G{90 if self.absolute else 91}")

    def loop(self, depth):
        r = self.rng
        label = f"o{self.tag}{len(self.out):03d}"
        self.out.append(f"{label} repeat [{r.randint(1, 3)}]")
        self.body(depth + 1, r.randint(1, 4))
        self.out.append(f"{label} endrepeat")

    def body(self, depth, count):
        r = self.rng
        pieces = [(self.move, 10), (self.arc, 4), (self.polar, 2), (self.units, 2), (self.distance, 2),
                  (self.plane_change, 2), (self.offsets, 2), (self.feed_modes, 1), (self.synced, 1),
                  (self.comp, 1)]
        if depth < 2:
            pieces.append((lambda: self.loop(depth), 1))
        funcs, weights = zip(*pieces)
        for _ in range(count):
            r.choices(funcs, weights)[0]()


def random_program(seed: int, tag: int = 1) -> str:
    """One program (text with M2); ``tag`` makes its O-word labels its own."""
    rng = random.Random(seed)
    g = _Gen(rng, tag)
    g.header()
    sub = rng.random() < 0.3
    if sub:
        start = len(g.out)
        label = f"o{tag}9"
        g.out.append(f"{label} sub")
        g.out.append(f"G91 G1 X#1 Y[#2 * 2] F#3")
        g.out.append(f"G1 Z[-#1]")
        g.out.append("G90")
        g.out.append(f"{label} endsub")
    g.body(0, rng.randint(6, 25))
    if sub:
        d = 0.04 if g.inch else 1
        for _ in range(rng.randint(1, 3)):
            g.out.append(f"o{tag}9 call [{rng.uniform(-5, 5) * d:.3f}] [{rng.uniform(-5, 5) * d:.3f}] "
                         f"[{rng.choice([20, 100, 300]) / (25.4 if g.inch else 1):.3f}]")
        if not g.absolute:
            g.out.append("G91")
    g.out.append("G40 G49 G80 G90 G94")
    return "\n".join(g.out) + "\nM2\n"
