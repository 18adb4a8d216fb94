"""First lines CAM posts and hand-written programs put before the first move (safety lines, modal
set-up), written for the modal-rule test (tests/test_program_modal.py): each line is judged by
LinuxCNC's rs274 and by fuzzyfeed's reader, which must agree. Written for fuzzyfeed from the
forms the posts use (FreeCAD, Fusion, Mastercam, SheetCam, bCNC, pcb2gcode headers), plus every
pairing of a motion code with the codes a safety line combines it with."""

POSTS = [
    "G00 G17 G21 G40 G49 G80 G90",          # issue 28: refused as "G0 and G80" before
    "G90 G94 G17 G21", "G21 G90 G40 G49 G80", "G0 G40 G49 G80 G90", "G17 G90 G80 G40 G49 G21",
    "G20 G90 G40 G80", "G90 G80 G40 G49 G17 G94", "G91 G28 Z0", "G28 G91 Z0", "G90 G53 G0 Z0",
    "G0 G53 Z0", "G0 G90 G54 X0 Y0", "G0 G80 G90 X0 Y0 Z5", "G1 G80 X0 F100", "G80 G0 Z5",
    "G40 G0 X0 Y0", "G49 G1 Z1 F100", "G91 G0 Z5", "G90 G1 X0 F100", "G17 G40 G80 G94",
    "G21 G64 P0.01", "G61 G90", "G0 G49 G40 G17 G80 G50 G90", "G0 G28 X0", "G92 X0 Y0 Z0",
    "G0 G92 X0", "G80 X1", "G0 G1 X1", "G90 G91", "G20 G21", "G17 G18", "G54 G55", "G43 G49",
    "G4 P1 G0 X1", "G4 G10 L20 P1 X0", "G1 G4 P1 F10", "G0 G80 G80", "G80 G80 G0 X1",
    "G0 G0 X1", "G90 G40 G17 G49 G80 G94 G54 G64 P0.01", "G53 G0 Z0 G90", "G21 G17 G90 G0 Z15",
    "G90 G21 G17 G64 P0.001 M3 S10000", "G94 G90 G91.1 G40 G49 G17", "G91.1 G90.1",
    "G0 G80 M3 S100", "G2 G80", "G1 G80 G2 X1", "G80", "G92.1 X1", "G92", "G53", "G2 X1 I1",
    "G0 G10 L2 P1 X0", "G1 F100 G94", "G94 G1 X1 F100", "G95 G1 X1 F0.1 S1000 M3", "G93 G1 X1 F10",
]

MOTION = ["G0", "G1 F100", "G80"]
PARTNERS = ["G40", "G49", "G90", "G91", "G17", "G21", "G54", "G94", "G53", "G28", "G92", "G4 P1",
            "G10 L20 P1", "G43 H1"]
AXES = ["", " X1 Z5"]


def safety_lines() -> list[str]:
    """The corpus: the post lines and every motion code with every partner, with and without axis words."""
    out = list(POSTS)
    for motion in MOTION:
        for partner in PARTNERS:
            for axes in AXES:
                out.append(f"{motion} {partner}{axes}")
                out.append(f"{partner} {motion}{axes}")
    return list(dict.fromkeys(out))
