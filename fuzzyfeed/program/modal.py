"""LinuxCNC's modal groups and the block checks that go with them (``interp_array.cc`` gees[],
``interp_read.cc`` read_g, ``interp_internal.cc`` enhance_block, ``interp_check.cc``), as the
program reader applies them to the G words of every line at once.

Two codes of one group on a line are an error, except G80 beside another motion code (the other
wins); group 0 holds G4, G10, G28, G28.1, G30, G30.1, G52, G53, G92 (G92.1–G92.3 are a group of
their own); a motion code beside G10/G28/G30/G52/G92 is an error (both use the axis words).
"""

from __future__ import annotations

import numpy as np

# G codes by modal group (code × 10 as an integer)
GROUPS = {
    "motion": [0, 10, 20, 30, 50, 51, 52, 53, 330, 331, 382, 383, 384, 385, 800, 730, 740, 810, 820,
               830, 840, 850, 860, 870, 880, 890],
    "plane": [170, 180, 190],
    "distance": [900, 910],
    "arc_distance": [901, 911],
    "feed_mode": [930, 940, 950],
    "units": [200, 210],
    "comp": [400, 410, 411, 420, 421],
    "length": [430, 431, 432, 490],
    "coord": [540, 550, 560, 570, 580, 590, 591, 592, 593],
    "control": [610, 611, 640],
    "spindle": [960, 970],
    "retract": [980, 990],
    "nonmodal": [40, 100, 280, 281, 300, 301, 530, 920, 520],
    "g92_offsets": [921, 922, 923],
    "lathe": [80],
}
REFUSED_G = {
    760: "threading cycle", 70: "lathe diameter mode",
    171: "UV plane", 181: "WU plane", 191: "VW plane",
}
GROUP_ID = {name: k for k, name in enumerate(GROUPS)}
G_LUT = np.full(1000, -1, dtype=np.int16)
for _name, _codes in GROUPS.items():
    G_LUT[_codes] = GROUP_ID[_name]
CYCLES = {730, 740, 810, 820, 830, 840, 850, 860, 870, 880, 890}
M_ACCEPTED = set(range(0, 10)) | {30, 48, 49, 50, 51, 52, 53, 60, 61, 62, 63, 64, 65, 66,
                                   67, 68, 70, 71, 72, 73} | set(range(100, 200))
M_STOP = {0, 1, 2, 30, 60}          # executed after the motion of their line
M_BREAK = {0, 1, 2, 6, 30, 60}      # the tool stops: a cut ends there


def g_columns(fail, n: int, g_line: np.ndarray, g_val: np.ndarray):
    """The G words of a program (line, value) checked and sorted by modal group: (line of every
    kept G word, its code × 10, and per group an (n,) column of the code given on each line, −1
    where none; None for a group no line uses). ``fail(line, message)`` raises."""
    g10 = np.rint(g_val * 10).astype(np.int64)
    odd = (np.abs(g_val * 10 - g10) > 1e-6) | (g10 < 0) | (g10 >= 1000)
    if odd.any():
        k = int(np.argmax(odd))
        fail(g_line[k], f"G{g_val[k]:g}: unsupported G code")
    for k in np.flatnonzero(np.isin(g10, list(REFUSED_G))):
        code = int(g10[k])
        what = REFUSED_G[code]
        hint = " (cutter compensation: post the program with compensation done by the CAM)" \
            if what == "cutter compensation" else ""
        fail(g_line[k], f"G{code / 10:g} ({what}) is not supported; the path would be read "
                        f"wrong{hint}")
    grp = G_LUT[g10]
    if (grp < 0).any():
        k = int(np.argmax(grp < 0))
        fail(g_line[k], f"G{g_val[k]:g}: unsupported G code")
    # G80 beside another motion code on a line gives way to it (LinuxCNC's read_g)
    motion_gid = GROUP_ID["motion"]
    is_g80 = (grp == motion_gid) & (g10 == 800)
    if is_g80.any():
        motion_lines = g_line[(grp == motion_gid) & ~is_g80]
        drop = is_g80 & np.isin(g_line, motion_lines)
        first80 = np.ones(g_line.size, bool)       # G80 G80: one G80
        idx80 = np.flatnonzero(is_g80)
        first80[idx80[1:][g_line[idx80[1:]] == g_line[idx80[:-1]]]] = False
        keep = ~drop & first80
        g_line, g_val, g10, grp = g_line[keep], g_val[keep], g10[keep], grp[keep]
    gcol = {}
    for name, gid in GROUP_ID.items():
        sel = grp == gid
        if not sel.any():
            gcol[name] = None
            continue
        li = g_line[sel]
        dup = np.flatnonzero(np.diff(li) == 0)
        if dup.size:
            codes = g_val[sel]
            fail(li[dup[0]], f"two G codes of one modal group on one line: G{codes[dup[0]]:g} "
                             f"and G{codes[dup[0] + 1]:g}")
        c = np.full(n, -1, dtype=np.int32)      # G code × 10 (4 bytes a line: 16 groups of a 10⁶-line program)
        c[li] = g10[sel]
        gcol[name] = c
    return g_line, g10, gcol


def modal_checks(fail, n, gcol, motion, motion_here, moving, axis_words, has, g53, absolute, g92_g52,
                  feed_value) -> None:
    """LinuxCNC's block checks that need the modal state (``enhance_block``, ``check_g_codes``,
    the arc and feed checks of ``convert_arc``/``convert_straight``)."""
    no_axes = g92_g52 & ~axis_words
    if no_axes.any():
        fail(int(np.argmax(no_axes)), "G92/G52 without axis words (LinuxCNC refuses it)")
    to_be = np.where(motion_here | axis_words, motion, -1)
    bad53 = g53 & ~np.isin(to_be, [0, 10])
    if bad53.any():
        fail(int(np.argmax(bad53)), "G53 needs G0 or G1 on its line or in force with axis words")
    inc53 = g53 & ~absolute
    if inc53.any():
        fail(int(np.argmax(inc53)), "G53 in incremental distance mode (G91): LinuxCNC refuses it")
    code = gcol["motion"] if gcol["motion"] is not None else np.full(n, -1)
    centre = has("I") | has("J") | has("K") | has("R")
    bare_arc = np.isin(code, [20, 30]) & ~axis_words & ~centre
    if bare_arc.any():
        i = int(np.argmax(bare_arc))
        fail(i, f"G{code[i] // 10} with neither axis nor centre words (LinuxCNC refuses it)")
    no_feed = np.isin(code, [10, 20, 30]) & ~(feed_value > 0)
    if no_feed.any():
        i = int(np.argmax(no_feed))
        fail(i, f"G{code[i] // 10} with no F in force (F = 0): LinuxCNC refuses a feed move at F 0, "
                "even with no axis words")
