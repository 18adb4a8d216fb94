"""Drawings as CAD programs write them (issue 9): LINE/ARC chains, blocks (INSERT, nested, MINSERT,
mirrored and non-uniformly scaled), bulged polylines, ellipse arcs, fit-point and piecewise-Bézier
splines, in DXF R12, R2000, R2010 and R2018, plus hand-written R12 without a header and a damaged
file. Every drawing loads; its contours' lengths equal ezdxf's own flattening to 1e-6 relative and
their extents equal ezdxf's bounding box. Bad drawings: one line, exit 2, no output."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from fuzzyfeed.cli import main
from fuzzyfeed.errors import FuzzyfeedNotice, PathFormatError
from fuzzyfeed.io.shapes import load_shape, load_shapes, sample_shape

ezdxf = pytest.importorskip("ezdxf")

VERSIONS = ("R12", "R2000", "R2010", "R2018")
SAGITTA = 1e-7   # ezdxf flattening for the reference lengths (relative length error < 1e-7)


# ------------------------------------------------------------------------- drawing builders
def slot(msp, cx=0.0, cy=0.0, length=20.0, r=4.0, layer="0"):
    """An obround as CAD draws it: two lines and two half arcs, lines in opposite directions."""
    a = {"layer": layer}
    msp.add_line((cx, cy - r), (cx + length, cy - r), dxfattribs=a)
    msp.add_arc((cx + length, cy), r, -90, 90, dxfattribs=a)
    msp.add_line((cx, cy + r), (cx + length, cy + r), dxfattribs=a)   # drawn left to right
    msp.add_arc((cx, cy), r, 90, 270, dxfattribs=a)


def rounded_rect(msp, w=60.0, h=40.0, r=5.0, layer="0"):
    a = {"layer": layer}
    msp.add_arc((w - r, h - r), r, 0, 90, dxfattribs=a)           # out of order on purpose
    msp.add_line((r, 0), (w - r, 0), dxfattribs=a)
    msp.add_arc((r, r), r, 180, 270, dxfattribs=a)
    msp.add_line((0, h - r), (0, r), dxfattribs=a)
    msp.add_line((w, r), (w, h - r), dxfattribs=a)
    msp.add_arc((r, h - r), r, 90, 180, dxfattribs=a)
    msp.add_line((w - r, h), (r, h), dxfattribs=a)
    msp.add_arc((w - r, r), r, 270, 360, dxfattribs=a)


def b_rect_lines(doc, msp):
    msp.add_line((0, 0), (30, 0))
    msp.add_line((30, 20), (30, 0))      # reversed
    msp.add_line((30, 20), (0, 20))
    msp.add_line((0, 0), (0, 20))        # reversed
    return 1


def b_slot(doc, msp):
    slot(msp)
    return 1


def b_rounded_rect(doc, msp):
    rounded_rect(msp)
    return 1


def b_plate(doc, msp):
    rounded_rect(msp, layer="OUTLINE")
    msp.add_circle((15, 20), 4, dxfattribs={"layer": "HOLES"})
    msp.add_circle((45, 20), 2.5, dxfattribs={"layer": "HOLES"})
    slot(msp, 20, 8, 20, 2, layer="SLOTS")
    msp.add_text("PLATE 1", dxfattribs={"layer": "TEXT"})
    return 4


def b_polyline2d_bulges(doc, msp):
    # a rounded rectangle as one closed 2-D POLYLINE with bulges (tan(90°/4) for quarter arcs)
    b = math.tan(math.pi / 8)
    pts = [(5, 0, 0), (35, 0, b), (40, 5, 0), (40, 25, b), (35, 30, 0), (5, 30, b), (0, 25, 0), (0, 5, b)]
    pl = msp.add_polyline2d([(x, y) for x, y, _ in pts], close=True)
    for v, (_, _, bulge) in zip(pl.vertices, pts):
        v.dxf.bulge = bulge
    return 1


def b_blocks(doc, msp):
    blk = doc.blocks.new("SLOT")
    slot(blk, 0, 0, 10, 2)
    hole = doc.blocks.new("HOLE")
    hole.add_circle((0, 0), 3)
    msp.add_blockref("SLOT", (10, 10), dxfattribs={"rotation": 30})
    msp.add_blockref("SLOT", (50, 10), dxfattribs={"xscale": 2, "yscale": 2, "rotation": -45})
    msp.add_blockref("HOLE", (30, 40))
    return 3


def b_nested_blocks(doc, msp):
    inner = doc.blocks.new("INNER")
    for a, b in (((0, 0), (8, 0)), ((8, 0), (8, 8)), ((8, 8), (0, 8)), ((0, 8), (0, 0))):
        inner.add_line(a, b)
    outer = doc.blocks.new("OUTER")
    outer.add_blockref("INNER", (2, 2), dxfattribs={"rotation": 15})
    outer.add_circle((20, 6), 3)
    msp.add_blockref("OUTER", (0, 0))
    msp.add_blockref("OUTER", (40, 30), dxfattribs={"rotation": 90, "xscale": 1.5, "yscale": 1.5})
    return 4


def b_minsert(doc, msp):
    hole = doc.blocks.new("PEG")
    hole.add_circle((0, 0), 2)
    ref = msp.add_blockref("PEG", (0, 0))
    ref.grid(size=(2, 3), spacing=(10, 12))
    return 6


def b_mirrored_arc(doc, msp):
    # a D-shape whose arc has extrusion (0, 0, -1): a mirrored arc as CAD writes it after MIRROR
    msp.add_line((0, 0), (20, 0))
    msp.add_line((0, 0), (0, 10))
    msp.add_line((0, 10), (20, 10))
    # OCS with extrusion -Z mirrors x: centre (-20, 5) in OCS is (20, 5) in WCS
    msp.add_arc((-20, 5), 5, 90, 270, dxfattribs={"extrusion": (0, 0, -1)})
    return 1


def b_polyline3d(doc, msp):
    msp.add_polyline3d([(0, 0, 0), (10, 0, -1), (10, 10, -1), (0, 10, -2), (0, 0, 0)])
    return 1


def b_nonuniform_insert(doc, msp):
    blk = doc.blocks.new("ROUND")
    blk.add_circle((0, 0), 5)
    blk.add_arc((0, 0), 8, 0, 180)
    blk.add_line((-8, 0), (8, 0))
    msp.add_blockref("ROUND", (20, 20), dxfattribs={"xscale": 2, "yscale": 1, "rotation": 20})
    return 2


def b_ellipse_arc_d(doc, msp):
    e = msp.add_ellipse((10, 5), major_axis=(8, 3), ratio=0.4, start_param=0, end_param=math.pi)
    s, t = e.start_point, e.end_point
    msp.add_line(t, s)
    return 1


def b_full_ellipse(doc, msp):
    msp.add_ellipse((0, 0), major_axis=(12, 5), ratio=0.3)
    return 1


def b_lwpolyline_bulges(doc, msp):
    b = math.tan(math.pi / 8)
    msp.add_lwpolyline([(5, 0, b), (35, 0, 0), (40, 5, b), (40, 25, 0), (35, 30, b), (5, 30, 0),
                        (0, 25, b), (0, 5, 0)], format="xyb", close=True)
    # bulges are on the vertex *before* an arc: the segments (5,0)->(35,0) etc. are arcs here
    return 1


def b_fit_spline(doc, msp):
    t = np.linspace(0, math.pi, 7)
    fit = [(20 * math.cos(a), 12 * math.sin(a), 0) for a in t]
    msp.add_spline(fit)
    msp.add_line(fit[-1], fit[0])
    return 1


def b_bezier_spline(doc, msp):
    # two cubic Bézier pieces meeting at (10, 0): interior knot of multiplicity p + 1 = 4
    pts = [(0, 0, 0), (2, 6, 0), (8, 6, 0), (10, 0, 0), (10, 0, 0), (12, -6, 0), (18, -6, 0), (20, 0, 0)]
    msp.add_open_spline(pts, degree=3, knots=[0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2])
    return 1


def b_zigzag(doc, msp):
    msp.add_lwpolyline([(0, 0), (5, 3), (10, 0), (15, 3), (20, 0)])
    return 1


R12_BUILDERS = [b_rect_lines, b_slot, b_rounded_rect, b_plate, b_polyline2d_bulges, b_blocks,
                b_nested_blocks, b_minsert, b_mirrored_arc, b_polyline3d]
NEW_BUILDERS = [b_nonuniform_insert, b_ellipse_arc_d, b_full_ellipse, b_lwpolyline_bulges,
                b_fit_spline, b_bezier_spline, b_zigzag]
CASES = [(v, b) for v in VERSIONS for b in R12_BUILDERS] + \
        [(v, b) for v in VERSIONS[1:] for b in NEW_BUILDERS]


# --------------------------------------------------------------------- ezdxf's own reference
def ezdxf_length(e) -> float:
    """Length of an entity by ezdxf alone: INSERTs and polylines through ``virtual_entities``,
    curves through ``flattening``."""
    kind = e.dxftype()
    if kind == "INSERT":
        inserts = list(e.multi_insert()) if e.mcount > 1 else [e]
        return sum(ezdxf_length(c) for i in inserts for c in i.virtual_entities())
    if kind == "LINE":
        return float((e.dxf.end - e.dxf.start).magnitude)
    if kind in ("LWPOLYLINE", "POLYLINE"):
        return sum(ezdxf_length(c) for c in e.virtual_entities())
    if kind in ("ARC", "CIRCLE"):
        pts = np.array([tuple(p) for p in e.flattening(SAGITTA)])
    elif kind in ("ELLIPSE", "SPLINE"):
        pts = np.array([tuple(p) for p in e.flattening(SAGITTA)])
    else:
        return 0.0
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


def shape_points(shape) -> np.ndarray:
    if shape.polyline is not None:
        pts = shape.polyline
    else:
        pts = shape.curve(np.linspace(*shape.curve.domain, 20001))
    return np.column_stack([pts, np.zeros(len(pts))]) if pts.shape[1] == 2 else pts


@pytest.mark.parametrize("version,builder", CASES, ids=[f"{v}-{b.__name__[2:]}" for v, b in CASES])
def test_drawing_loads_with_ezdxf_lengths_and_extents(version, builder, tmp_path):
    doc = ezdxf.new(version)
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    expected = builder(doc, msp)
    path = tmp_path / f"{builder.__name__}_{version}.dxf"
    doc.saveas(path)
    if version == "R12":     # R12 has no $INSUNITS: read as mm, with a notice
        with pytest.warns(FuzzyfeedNotice, match=r"does not set \$INSUNITS"):
            shapes = load_shapes(str(path))
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("error", FuzzyfeedNotice)      # a clean file gives no notice
            shapes = load_shapes(str(path))
    assert len(shapes) == expected
    back = ezdxf.readfile(path).modelspace()
    reference = sum(ezdxf_length(e) for e in back)
    ours = sum(s.curve.length for s in shapes)
    assert ours == pytest.approx(reference, rel=1e-6)
    # the extents of the contours are ezdxf's bounding box of the drawing's curves
    from ezdxf import bbox
    box = bbox.extents([e for e in back if e.dxftype() != "TEXT"], fast=False)
    pts = np.vstack([shape_points(s) for s in shapes])
    size = max(box.size)
    np.testing.assert_allclose(pts.min(axis=0)[:2], tuple(box.extmin)[:2], atol=1e-4 * size)   # ezdxf flattens curves for its box
    np.testing.assert_allclose(pts.max(axis=0)[:2], tuple(box.extmax)[:2], atol=1e-4 * size)   # ezdxf flattens curves for its box
    for s in shapes:   # every contour can be sampled: finite curvature, never NaN
        samples = sample_shape(s, 500)
        assert np.isfinite(samples.curvature).all()


def test_slot_is_one_closed_contour_with_the_closed_form_length(tmp_path):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    slot(doc.modelspace(), 3, 4, 20, 4)
    doc.saveas(tmp_path / "slot.dxf")
    shape = load_shape(str(tmp_path / "slot.dxf"))
    assert shape.curve.length == pytest.approx(2 * 20 + 2 * math.pi * 4, rel=1e-7)
    samples = sample_shape(shape)
    on_arcs = (samples.x < 3 - 1e-9) | (samples.x > 23 + 1e-9)
    np.testing.assert_allclose(samples.curvature[on_arcs], 0.25, rtol=1e-6)   # arcs fitted back: 1/R
    straight = (samples.x > 3 + 1e-6) & (samples.x < 23 - 1e-6)
    assert np.all(samples.curvature[straight] == 0)


def test_single_arc_circle_and_ellipse_stay_exact_rational_nurbs(tmp_path):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_circle((1, 2), 7, dxfattribs={"layer": "C"})
    msp.add_arc((30, 0), 4, 10, 300, dxfattribs={"layer": "A"})
    msp.add_ellipse((0, 40), major_axis=(10, 0), ratio=0.5, dxfattribs={"layer": "E"})
    doc.saveas(tmp_path / "conics.dxf")
    circle = load_shape(f"{tmp_path / 'conics.dxf'}#layer=C")
    assert circle.polyline is None and circle.curve.degree == 2 and np.any(circle.curve.weights != 1)
    s = sample_shape(circle, 777)
    np.testing.assert_allclose(np.linalg.norm(s.xyz[:, :2] - [1, 2], axis=1), 7, atol=1e-12)
    np.testing.assert_allclose(s.curvature, 1 / 7, rtol=1e-9)
    arc = load_shape(f"{tmp_path / 'conics.dxf'}#layer=A")
    assert arc.curve.length == pytest.approx(4 * math.radians(290), rel=1e-12)
    ellipse = load_shape(f"{tmp_path / 'conics.dxf'}#layer=E")
    s = sample_shape(ellipse, 999)
    np.testing.assert_allclose(((s.x / 10) ** 2 + ((s.y - 40) / 5) ** 2), 1, atol=1e-12)
    # κ of an ellipse x = a cos t, y = b sin t: ab / (a² sin² t + b² cos² t)^(3/2)
    t = np.arctan2((s.y - 40) / 5, s.x / 10)
    exact = 50 / (100 * np.sin(t) ** 2 + 25 * np.cos(t) ** 2) ** 1.5
    np.testing.assert_allclose(s.curvature, exact, rtol=1e-9)


# ---------------------------------------------------------------- hand-written raw drawings
def tags(*pairs) -> str:
    return "".join(f"{c:>3}\n{v}\n" for c, v in pairs)


D_SHAPE = ((0, "LINE"), (8, "0"), (10, 0.0), (20, 0.0), (30, 0.0), (11, 10.0), (21, 0.0), (31, 0.0),
           (0, "ARC"), (8, "0"), (10, 10.0), (20, 5.0), (30, 0.0), (40, 5.0), (50, 270.0), (51, 90.0),
           (0, "LINE"), (8, "0"), (10, 10.0), (20, 10.0), (30, 0.0), (11, 0.0), (21, 10.0), (31, 0.0),
           (0, "LINE"), (8, "0"), (10, 0.0), (20, 10.0), (30, 0.0), (11, 0.0), (21, 0.0), (31, 0.0))
D_LENGTH = 30 + 5 * math.pi


def test_r12_without_header_is_mm_with_a_notice(tmp_path):
    """The minimal DXF old CAM/CAD programs write: an ENTITIES section only (ezdxf would fill in
    its default header, $INSUNITS = 6 metres, and scale the part x1000)."""
    path = tmp_path / "noheader.dxf"
    path.write_text(tags((0, "SECTION"), (2, "ENTITIES"), *D_SHAPE, (0, "ENDSEC"), (0, "EOF")))
    with pytest.warns(FuzzyfeedNotice, match=r"does not set \$INSUNITS; coordinates read as mm"):
        shape = load_shape(str(path))
    assert shape.curve.length == pytest.approx(D_LENGTH, rel=1e-7)


def test_r12_header_with_inches_and_the_units_flag(tmp_path, capsys):
    path = tmp_path / "inch.dxf"
    path.write_text(tags((0, "SECTION"), (2, "HEADER"), (9, "$ACADVER"), (1, "AC1009"),
                         (9, "$INSUNITS"), (70, 1), (0, "ENDSEC"),
                         (0, "SECTION"), (2, "ENTITIES"), *D_SHAPE, (0, "ENDSEC"), (0, "EOF")))
    assert load_shape(str(path)).curve.length == pytest.approx(25.4 * D_LENGTH, rel=1e-7)
    out = tmp_path / "a.csv"
    assert main(["advise", str(path), "-o", str(out), "--units", "mm"]) == 0
    assert f"length {D_LENGTH:.3f} mm" in capsys.readouterr().out


def test_damaged_file_is_read_through_recover_with_one_notice(tmp_path, capsys):
    text = tags((0, "SECTION"), (2, "ENTITIES"), *D_SHAPE, (0, "ENDSEC"))   # no EOF
    path = tmp_path / "damaged.dxf"
    path.write_text(text.replace(" 40\n5.0\n", " 40\n5.0x\n"))               # a broken float
    with pytest.raises(Exception):
        ezdxf.readfile(path)
    out = tmp_path / "d.csv"
    assert main(["advise", str(path), "-o", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert any(line.startswith("fuzzyfeed: notice: ") and "ezdxf.recover" in line for line in err)
    assert all(line.startswith("fuzzyfeed: notice: ") for line in err)
    with pytest.warns(FuzzyfeedNotice) as notices:
        assert load_shape(str(path)).curve.length == pytest.approx(D_LENGTH, rel=1e-7)
    assert any("read through ezdxf.recover" in str(n.message) for n in notices)


def test_duplicate_handles_and_selection_by_a_shared_handle(tmp_path):
    path = tmp_path / "dup.dxf"
    path.write_text(tags((0, "SECTION"), (2, "HEADER"), (9, "$ACADVER"), (1, "AC1009"),
                         (9, "$HANDLING"), (70, 1), (9, "$INSUNITS"), (70, 4), (0, "ENDSEC"),
                         (0, "SECTION"), (2, "ENTITIES"),
                         (0, "LINE"), (5, "2A"), (8, "0"), (10, 0.0), (20, 0.0), (30, 0.0),
                         (11, 10.0), (21, 0.0), (31, 0.0),
                         (0, "LINE"), (5, "2A"), (8, "0"), (10, 10.0), (20, 0.0), (30, 0.0),
                         (11, 10.0), (21, 10.0), (31, 0.0),
                         (0, "CIRCLE"), (5, "2A"), (8, "0"), (10, 50.0), (20, 0.0), (30, 0.0), (40, 2.0),
                         (0, "ENDSEC"), (0, "EOF")))
    shapes = load_shapes(str(path))
    assert [s.name for s in shapes] == ["dup#path=1", "dup#path=2"]
    assert shapes[0].curve.length == pytest.approx(20.0) and shapes[1].curve.length == pytest.approx(4 * math.pi)
    with pytest.raises(PathFormatError, match=r"#2A: 2 contours match \(path=1, path=2\); pick one with #path=N"):
        load_shape(f"{path}#2A")


def test_spline_fit_polyline_follows_its_fitted_vertices_not_the_frame(tmp_path):
    doc = ezdxf.new("R2000")
    doc.header["$INSUNITS"] = 4
    pl = doc.modelspace().add_polyline2d([(0, 0), (10, 10), (20, 0)])
    pl.dxf.flags |= 4                                  # spline-fit, as PEDIT Spline leaves it
    for v in pl.vertices:
        v.dxf.flags |= 16                              # the frame control points
    for x in np.linspace(0, 1, 9):
        pl.append_vertex((20 * x, 20 * x * (1 - x)), dxfattribs={"flags": 8})
    doc.saveas(tmp_path / "fit.dxf")
    back = ezdxf.readfile(tmp_path / "fit.dxf").modelspace()[0]
    fitted = np.array([tuple(v.dxf.location)[:2] for v in back.vertices if v.dxf.flags & 8])
    shape = load_shape(str(tmp_path / "fit.dxf"))
    assert shape.curve.length == pytest.approx(np.linalg.norm(np.diff(fitted, axis=0), axis=1).sum(), rel=1e-12)
    assert shape.polyline[:, 1].max() <= 5.0 + 1e-12   # the frame apex (10, 10) is not on the path


# ------------------------------------------------------------------------------ bad input
def run_bad(args, capsys, tmp_path):
    out = tmp_path / "never.csv"
    assert main(args + ["-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("fuzzyfeed: error: ")
    assert not out.exists()
    return err[0]


def test_contour_that_does_not_close_names_the_gap(tmp_path, capsys):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_line((0, 0), (30, 0))
    msp.add_line((30, 0), (30, 20))
    msp.add_line((30, 20), (0, 20))
    msp.add_line((0, 20), (0, 0.02))      # 20 µm short of closing
    doc.saveas(tmp_path / "gap.dxf")
    with pytest.warns(FuzzyfeedNotice, match=r"does not close: gap of 0\.02 mm between "
                                             r"\(0, 0(\.02)?\) and \(0, 0(\.02)?\) .*a new contour starts there"):
        shapes = load_shapes(str(tmp_path / "gap.dxf"))
    assert len(shapes) == 1 and shapes[0].curve.length == pytest.approx(100 - 0.02)   # an open path
    assert main(["advise", str(tmp_path / "gap.dxf"), "-o", str(tmp_path / "a.csv")]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "gap of 0.02 mm" in err and "notice" in err


def test_a_gap_elsewhere_does_not_stop_the_contour_picked(tmp_path, capsys):
    """LibreCAD's tux.dxf has one 0.047 mm gap between two ARCs: the whole drawing was refused,
    even with another contour picked. Every contour is followed, the gap ends one and starts the
    next (a notice names it); a drawing of several contours without a pick is refused for one
    path, naming the gap."""
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    for a, b in [((0, 0), (30, 0)), ((30, 0), (30, 20)), ((30, 20), (0, 20)), ((0, 20), (0, 0))]:
        msp.add_line(a, b)
    msp.add_arc((60, 10), 10, 90, 270)
    msp.add_arc((60.05, 10), 10, 270, 90)    # 0.05 mm off: its ends miss the first arc's
    doc.saveas(tmp_path / "two.dxf")
    shape = load_shapes(str(tmp_path / "two.dxf#path=1"))[0]
    assert shape.curve.length == pytest.approx(100.0)
    assert main(["schedule", str(tmp_path / "two.dxf#path=1"), "-o", str(tmp_path / "s.csv")]) == 0
    capsys.readouterr()
    assert main(["schedule", str(tmp_path / "two.dxf#path=2"), "-o", str(tmp_path / "s.csv")]) == 0
    err = capsys.readouterr().err
    assert "notice" in err and "do not meet: gap of 0.05 mm" in err and "a new contour starts there" in err
    line = run_bad(["schedule", str(tmp_path / "two.dxf")], capsys, tmp_path)
    assert "3 contours" in line and "do not meet: gap of 0.05 mm" in line, line


def test_text_only_and_unreadable_drawings_are_one_line(tmp_path, capsys):
    doc = ezdxf.new("R2000")
    doc.modelspace().add_text("NOTHING TO CUT")
    doc.saveas(tmp_path / "text.dxf")
    assert "no curve to follow" in run_bad(["advise", str(tmp_path / "text.dxf")], capsys, tmp_path)
    (tmp_path / "junk.dxf").write_text("  0\nSECTION\n  2\nENTITIES\n  0\nLINE\n 10\n")
    line = run_bad(["advise", str(tmp_path / "junk.dxf")], capsys, tmp_path)
    assert "junk.dxf" in line
    (tmp_path / "prose.dxf").write_text("Dear customer,\nplease find the part attached.\n")
    assert "not a DXF that ezdxf can read or recover" in run_bad(
        ["advise", str(tmp_path / "prose.dxf")], capsys, tmp_path)
    assert "--units inch: applies to DXF drawings only" in run_bad(
        ["advise", "infinity", "--units", "inch"], capsys, tmp_path)


def test_many_contours_are_listed_short_and_advised_all(tmp_path, capsys):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    for k in range(12):
        msp.add_circle((10 * k, 0), 3)
    rounded_rect(msp, layer="OUT")
    doc.saveas(tmp_path / "many.dxf")
    with pytest.raises(PathFormatError, match=r"13 contours \(1: .*, 5: .*, … and 8 more\); pick one"):
        load_shape(str(tmp_path / "many.dxf"))
    out = tmp_path / "all.csv"
    assert main(["advise", str(tmp_path / "many.dxf"), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.count("\npath ") == 13
    import csv
    rows = list(csv.DictReader(out.open()))
    assert rows[0]["path"] == "1" and rows[-1]["path"] == "13"
    assert {r["path"] for r in rows} == {str(k) for k in range(1, 14)}
    circle = [r for r in rows if r["path"] == "1"]
    np.testing.assert_allclose([float(r["curvature_1_mm"]) for r in circle], 1 / 3, rtol=1e-9)
    one = load_shape(f"{tmp_path / 'many.dxf'}#layer=OUT")
    assert one.curve.length == pytest.approx(2 * (50 + 30) + 2 * math.pi * 5, rel=1e-7)


# --------------------------------------------------------------------- chaining, property
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=40, deadline=None)
@given(st.permutations(range(8)), st.lists(st.booleans(), min_size=8, max_size=8),
       st.floats(-4e-4, 4e-4), st.sampled_from(["0", "CUT"]))
def test_property_chaining_ignores_order_direction_and_tiny_gaps(order, flip, jitter, layer):
    """A rounded rectangle's 8 entities in any order and direction, ends moved by less than the
    chain tolerance, chain into one closed contour of the same length."""
    from pathlib import Path

    from fuzzyfeed.io.contours import chain
    from fuzzyfeed.io.dxf import _pieces_of

    doc = ezdxf.new("R2010")
    msp = doc.modelspace()
    rounded_rect(msp, layer=layer)
    entities = list(msp)
    for e, f in zip(entities, flip):
        if e.dxftype() == "LINE":
            if f:
                e.dxf.start, e.dxf.end = e.dxf.end, e.dxf.start
            e.dxf.start = e.dxf.start + (jitter, 0, 0)
    pieces = [p for k in order for p in _pieces_of(entities[k], 1.0, Path("mem.dxf"), f"#{k}", str(k), layer)]
    contours = chain(pieces, "mem.dxf")
    assert len(contours) == 1 and contours[0].closed and len(contours[0].pieces) == 8
    pts = contours[0].points()
    length = np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()
    assert length == pytest.approx(2 * (50 + 30) + 2 * math.pi * 5, abs=8 * 1e-3)


def test_zero_radius_circle_is_skipped_with_a_notice(tmp_path):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_circle((0, 0), 0)
    msp.add_circle((5, 5), 2)
    doc.saveas(tmp_path / "zero.dxf")
    with pytest.warns(FuzzyfeedNotice, match=r"1 degenerate entity skipped \(no length to follow\): "
                                             r"1 CIRCLE of radius 0 \(first: CIRCLE"):
        shapes = load_shapes(str(tmp_path / "zero.dxf"))
    assert len(shapes) == 1 and shapes[0].curve.length == pytest.approx(4 * math.pi)


def test_spline_with_a_corner_knot_is_cut_there_and_advised(tmp_path, capsys):
    """A degree-2 SPLINE whose interior knot has multiplicity 2 (= degree) with the control
    polygon bending there is an L with a sharp corner: the advisor refused it (a corner has no
    feed). It is cut at the knot into two smooth pieces (the curve unchanged), chained and advised."""
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    doc.modelspace().add_open_spline([(0, 0), (10, 0), (20, 0), (20, 10), (20, 20)], degree=2,
                                     knots=[0, 0, 0, 0.5, 0.5, 1, 1, 1])
    doc.saveas(tmp_path / "corner.dxf")
    shape = load_shape(str(tmp_path / "corner.dxf"))
    assert shape.polyline is not None                          # two pieces: a point sequence
    assert shape.curve.length == pytest.approx(40.0, abs=1e-6)
    corner = np.flatnonzero(np.all(np.isclose(shape.polyline, [20, 0]), axis=1))
    assert corner.size == 1                                    # the corner is a vertex
    assert main(["advise", str(tmp_path / "corner.dxf"), "-o", str(tmp_path / "a.csv")]) == 0
    feed = np.genfromtxt(tmp_path / "a.csv", delimiter=",", names=True)
    at = np.argmin(np.hypot(feed["x_mm"] - 20, feed["y_mm"]))
    assert feed["feed_pct"][at] < 0.5 * feed["feed_pct"].max()   # slow at the corner


def test_open_insert_chains_are_open_paths(tmp_path):
    """A block holding an open chain (three LINEs of a U), inserted twice: two open paths, each
    the U's length, none refused."""
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    block = doc.blocks.new("U")
    for a, b in [((0, 10), (0, 0)), ((0, 0), (10, 0)), ((10, 0), (10, 10))]:
        block.add_line(a, b)
    msp = doc.modelspace()
    msp.add_blockref("U", (0, 0))
    msp.add_blockref("U", (30, 0), dxfattribs={"rotation": 90})
    doc.saveas(tmp_path / "u.dxf")
    shapes = load_shapes(str(tmp_path / "u.dxf"))
    assert len(shapes) == 2
    for shape in shapes:
        pts = shape.polyline
        assert shape.curve.length == pytest.approx(30.0)
        assert np.linalg.norm(pts[0] - pts[-1]) == pytest.approx(10.0)     # open: the U's mouth


def test_degenerate_entities_are_counted_in_one_notice(tmp_path):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (10, 0), (10, 10)])
    for k in range(3):
        msp.add_line((k, k), (k, k))                      # zero length
    msp.add_arc((5, 5), 0, 0, 90)                         # zero radius
    msp.add_lwpolyline([(7, 7), (7, 7)])                  # one point
    doc.saveas(tmp_path / "degenerate.dxf")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        shapes = load_shapes(str(tmp_path / "degenerate.dxf"))
    said = [str(w.message) for w in caught if issubclass(w.category, FuzzyfeedNotice)]
    assert len(shapes) == 1 and shapes[0].curve.length == pytest.approx(20.0)
    assert len(said) == 1 and "5 degenerate entities skipped" in said[0], said
    assert "3 LINE of zero length" in said[0] and "1 ARC of radius 0" in said[0] and "1 LWPOLYLINE of one point" in said[0]


def test_spline_with_a_wrong_degree_is_read_with_the_degree_its_knots_make(tmp_path):
    """dxf-parser's arcs-as-splines.dxf states degree 3 for circles written as rational quadratic
    B-splines (9 control points, 12 knots): read as degree 2, with a notice, they are the circles."""
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    w = math.sqrt(0.5)
    r = 5.0
    pts = [(r, 0), (r, r), (0, r), (-r, r), (-r, 0), (-r, -r), (0, -r), (r, -r), (r, 0)]
    spline = doc.modelspace().add_spline()
    spline.dxf.degree = 3
    spline.control_points = [(x, y, 0) for x, y in pts]
    spline.knots = [0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4]
    spline.weights = [1, w, 1, w, 1, w, 1, w, 1]
    doc.saveas(tmp_path / "circle.dxf")
    with pytest.warns(FuzzyfeedNotice, match=r"degree 3 stated, but its 12 knots and 9 control points "
                                             r"make a clamped curve of degree 2"):
        shape = load_shape(str(tmp_path / "circle.dxf"))
    assert shape.curve.degree == 2
    assert shape.curve.length == pytest.approx(2 * math.pi * r, rel=1e-9)
