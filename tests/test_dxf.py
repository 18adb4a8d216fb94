"""DXF import: every shipped shape written by ezdxf loads back to the same curve, fit-point splines,
polylines, units, entity selection and one clear line for bad files."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzyfeed.errors import PathFormatError
from fuzzyfeed.io.shapes import load_shape, load_shapes, sample_shape, shape_names

ezdxf = pytest.importorskip("ezdxf")


def new_doc(insunits: int = 4):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = insunits
    return doc, doc.modelspace()


def add_curve(msp, curve, layer="0"):
    """The curve as a DXF SPLINE, written through ezdxf's own API (rational where weighted)."""
    points = [tuple(p) + (0.0,) * (3 - len(p)) for p in curve.control_points.tolist()]
    attribs = {"layer": layer}
    if np.any(curve.weights != 1.0):  # equal weights ≠ 1 too, so the file keeps them
        return msp.add_rational_spline(points, curve.weights.tolist(), degree=curve.degree,
                                       knots=curve.knots.tolist(), dxfattribs=attribs)
    return msp.add_open_spline(points, degree=curve.degree, knots=curve.knots.tolist(),
                               dxfattribs=attribs)


@pytest.mark.parametrize("name", shape_names())
def test_each_shipped_shape_round_trips_through_dxf(name, tmp_path):
    curve = load_shape(name).curve
    doc, msp = new_doc()
    add_curve(msp, curve)
    path = tmp_path / f"{name}.dxf"
    doc.saveas(path)
    back = load_shape(str(path))
    assert back.polyline is None and back.curve.degree == curve.degree
    np.testing.assert_allclose(back.curve.knots, curve.knots, rtol=0, atol=1e-9)
    np.testing.assert_allclose(back.curve.weights, curve.weights, rtol=0, atol=1e-9)
    pad = np.zeros((curve.n_control_points, 3 - back.curve.dim))
    np.testing.assert_allclose(np.hstack([back.curve.control_points, pad])[:, :curve.dim],
                               curve.control_points, rtol=0, atol=1e-9)
    u = np.linspace(*curve.domain, 5001)
    np.testing.assert_allclose(back.curve(u)[:, :2], curve(u)[:, :2], rtol=0, atol=1e-9)
    assert back.curve.length == pytest.approx(curve.length, abs=1e-9)


def test_fit_point_spline_loads_through_ezdxf_construction_tool(tmp_path):
    t = np.linspace(0, np.pi, 9)
    fit = np.column_stack([30 * np.cos(t), 20 * np.sin(t), np.zeros_like(t)])
    doc, msp = new_doc()
    spline = msp.add_spline(fit.tolist())
    assert len(spline.control_points) == 0
    path = tmp_path / "fit.dxf"
    doc.saveas(path)
    shape = load_shape(str(path))
    assert "fit points" in shape.notes and shape.curve.degree == 3
    # the interpolating spline passes through every fit point (closest parameter found by a scan)
    u = np.linspace(0, 1, 200001)
    c = shape.curve(u)
    for p in fit[:, :2]:
        assert np.min(np.linalg.norm(c - p, axis=1)) < 1e-3
    np.testing.assert_allclose(c[0], fit[0, :2], atol=1e-9)
    np.testing.assert_allclose(c[-1], fit[-1, :2], atol=1e-9)
    # independent: ezdxf's own evaluation of its construction tool equals ours
    tool = ezdxf.readfile(path).modelspace().query("SPLINE")[0].construction_tool()
    ts = np.linspace(0, tool.max_t, 101)
    ref = np.array([tuple(tool.point(x))[:2] for x in ts])
    np.testing.assert_allclose(shape.curve(ts / tool.max_t), ref, atol=1e-9)


def test_polylines_closed_3d_and_bulge(tmp_path):
    doc, msp = new_doc()
    lw = msp.add_lwpolyline([(0, 0), (10, 0), (10, 5), (0, 5)], close=True,
                            dxfattribs={"layer": "CUT"})
    p3 = msp.add_polyline3d([(0, 0, 0), (1, 2, -1), (3, 2, -1), (4, 0, -2)],
                            dxfattribs={"layer": "3D"})
    # a half circle of radius 5 around (5, 0) as one bulge segment (bulge = tan(180°/4) = 1)
    arc = msp.add_lwpolyline([(0, 0, 0, 0, 1), (10, 0, 0, 0, 0), (12, 1)], format="xyseb",
                             dxfattribs={"layer": "ARC"})
    path = tmp_path / "poly.dxf"
    doc.saveas(path)
    shapes = load_shapes(str(path))
    assert len(shapes) == 3
    rect = load_shape(f"{path}#layer=cut")
    # the vertices, straight edges cut into steps of at most 1 mm (STRAIGHT_STEP_MM)
    corners = [[0, 0], [10, 0], [10, 5], [0, 5], [0, 0]]
    assert rect.polyline.shape == (31, 2)
    np.testing.assert_array_equal(rect.polyline[[0, 10, 15, 25, 30]], corners)
    assert np.linalg.norm(np.diff(rect.polyline, axis=0), axis=1).max() == 1.0
    poly3 = load_shape(f"{path}#{p3.dxf.handle}")
    vertices = np.array([[0, 0, 0], [1, 2, -1], [3, 2, -1], [4, 0, -2]], dtype=float)
    assert all(np.any(np.all(poly3.polyline == v, axis=1)) for v in vertices)
    assert poly3.curve.length == pytest.approx(np.linalg.norm(np.diff(vertices, axis=0), axis=1).sum(), rel=1e-12)
    flat = load_shape(f"{path}#handle={arc.dxf.handle}").polyline
    on_arc = flat[(flat[:, 0] <= 10) & (np.arange(len(flat)) < len(flat) - 1)]
    assert len(on_arc) > 10
    np.testing.assert_allclose(np.linalg.norm(on_arc - [5, 0], axis=1), 5.0, atol=1e-12)
    sagitta = 5.0 - np.linalg.norm(0.5 * (on_arc[1:] + on_arc[:-1]) - [5, 0], axis=1)
    assert 0 < sagitta.max() <= 5 * (1 - np.cos(1e-3)) + 1e-12       # chords turn by <= 2e-3 rad
    assert load_shape(f"{path}#path=1").polyline.shape == (31, 2)
    # the planners' samples are the points; the corners are the controller's blend
    samples = sample_shape(rect)
    assert len(samples) == 31
    np.testing.assert_allclose(samples.curvature[[0, 10, 15, 25, 30]], 41.42135623730950, rtol=1e-12)
    assert np.all(np.delete(samples.curvature, [0, 10, 15, 25, 30]) == 0)
    assert lw.dxf.handle in rect.name


def test_several_entities_need_a_selector(tmp_path):
    doc, msp = new_doc()
    a = add_curve(msp, load_shape("infinity").curve, layer="A")
    b = add_curve(msp, load_shape("trident").curve, layer="B")
    msp.add_line((0, 0), (1, 1))
    path = tmp_path / "two.dxf"
    doc.saveas(path)
    with pytest.raises(PathFormatError, match=rf"3 contours \(1: closed contour of SPLINE {a.dxf.handle} "
                                              rf"\(layer A\), 2: closed contour of SPLINE {b.dxf.handle} "
                                              r"\(layer B\), 3: open contour of LINE \w+ \(layer 0\)\); pick one"):
        load_shape(str(path))
    assert load_shape(f"{path}#layer=B").curve.n_control_points == 7
    assert load_shape(f"{path}#{a.dxf.handle.lower()}").curve.weights[0] == 0.6
    with pytest.raises(PathFormatError, match="no contour holds an entity with handle FFFF"):
        load_shape(f"{path}#FFFF")
    with pytest.raises(PathFormatError, match="no contour on layer 'C'"):
        load_shape(f"{path}#layer=C")
    with pytest.raises(PathFormatError, match="unknown selector 'colour'"):
        load_shape(f"{path}#colour=red")


def test_units_inch_and_ezdxf_default_metres(tmp_path):
    curve = load_shape("trident2").curve
    for code, factor in ((1, 25.4), (6, 1000.0), (0, 1.0)):
        doc, msp = new_doc(code)
        add_curve(msp, curve)
        doc.saveas(tmp_path / f"u{code}.dxf")
        back = load_shape(str(tmp_path / f"u{code}.dxf")).curve
        np.testing.assert_allclose(back.control_points, curve.control_points[:, :2] * factor, atol=1e-9)
    doc, msp = new_doc(14)  # decimetres: refused
    add_curve(msp, curve)
    doc.saveas(tmp_path / "dm.dxf")
    with pytest.raises(PathFormatError, match=r"\$INSUNITS = 14 is not supported"):
        load_shape(str(tmp_path / "dm.dxf"))


def test_no_usable_entity_binary_and_garbage(tmp_path):
    doc, msp = new_doc()
    msp.add_text("PART 7")
    msp.add_text("REV B")
    msp.add_point((1, 1))
    doc.saveas(tmp_path / "text.dxf")
    with pytest.raises(PathFormatError, match=r"text\.dxf: no curve to follow .* found POINT x1, TEXT x2$"):
        load_shape(str(tmp_path / "text.dxf"))
    (tmp_path / "blob.dxf").write_bytes(bytes(range(256)) * 4)
    with pytest.raises(PathFormatError, match=r"blob\.dxf: binary file that is not a DXF"):
        load_shape(str(tmp_path / "blob.dxf"))
    (tmp_path / "prose.dxf").write_text("this is not a drawing\n")
    with pytest.raises(PathFormatError, match=r"prose\.dxf: not a DXF that ezdxf can read or recover"):
        load_shape(str(tmp_path / "prose.dxf"))


def test_nan_vertex_and_bad_spline_are_one_line_errors(tmp_path):
    doc, msp = new_doc()
    pl = msp.add_lwpolyline([(0, 0), (1, 0), (2, 1)])
    doc.saveas(tmp_path / "ok.dxf")
    text = (tmp_path / "ok.dxf").read_text()
    # corrupt the second vertex's x (group code 10 value "1.0") into nan, as a broken exporter would
    marker = "\n 10\n1.0\n"
    start = text.index("AcDbPolyline")
    assert marker in text[start:]
    (tmp_path / "nan.dxf").write_text(text[:start] + text[start:].replace(marker, "\n 10\nnan\n", 1))
    with pytest.raises(PathFormatError, match=rf"nan\.dxf: LWPOLYLINE {pl.dxf.handle} \(layer 0\): "
                                              r"vertex 1 = \[nan, 0\.0, 0\.0\]; coordinates must be finite"):
        load_shape(str(tmp_path / "nan.dxf"))
    doc, msp = new_doc()
    msp.add_open_spline([(0, 0), (1, 1), (2, 0), (3, 1)], degree=3, knots=[0, 0, 0, 0, 2, 1, 1, 1])
    doc.saveas(tmp_path / "bad.dxf")
    with pytest.raises(PathFormatError, match=r"bad\.dxf: SPLINE \w+ \(layer 0\): knots\[5\] = 1 < knots\[4\] = 2"):
        load_shape(str(tmp_path / "bad.dxf"))


def test_closed_periodic_spline_is_clamped_to_the_same_curve(tmp_path):
    """A closed spline with an unclamped (uniform periodic) knot vector, as CAD programs write
    them: loads as the same curve on [u_p, u_n] (reference: scipy's B-spline on the raw knots)."""
    from ezdxf.math import closed_uniform_bspline
    from scipy.interpolate import BSpline

    square = [(0, 0, 0), (10, 0, 0), (10, 10, 0), (0, 10, 0)]
    periodic = closed_uniform_bspline(square, order=4)
    knots = np.array(periodic.knots())
    cps = np.array([tuple(p) for p in periodic.control_points])
    doc, msp = new_doc()
    spline = msp.add_open_spline(cps.tolist(), degree=3, knots=knots.tolist())
    spline.closed = True
    doc.saveas(tmp_path / "closed.dxf")
    shape = load_shape(str(tmp_path / "closed.dxf"))
    assert "clamped" in shape.notes
    n, p = len(cps), 3
    assert shape.curve.domain == (knots[p], knots[n])
    u = np.linspace(knots[p], knots[n], 2001)
    ref = BSpline(knots, cps[:, :2], p)(u)
    np.testing.assert_allclose(shape.curve(u), ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(shape.curve(u[:1]), shape.curve(u[-1:]), atol=1e-12)  # closed
    # rational, non-uniform unclamped knots
    rng = np.random.default_rng(3)
    knots = np.sort(rng.uniform(0, 5, 6 + 2 + 1))
    cps = rng.uniform(-20, 20, (6, 2))
    w = rng.uniform(0.5, 3.0, 6)
    doc, msp = new_doc()
    msp.add_rational_spline([tuple(c) + (0.0,) for c in cps], w.tolist(), degree=2, knots=knots.tolist())
    doc.saveas(tmp_path / "rational.dxf")
    curve = load_shape(str(tmp_path / "rational.dxf")).curve
    u = np.linspace(knots[2], knots[6], 1001)
    ref = BSpline(knots, cps * w[:, None], 2)(u) / BSpline(knots, w, 2)(u)[:, None]
    np.testing.assert_allclose(curve(u), ref, rtol=0, atol=1e-9)
