"""CSV: exact round trip through pandas (float64 bit for bit), atomic refusal of NaN, and point-list
CSV import as paths."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from fuzzyfeed.errors import ExportError, PathFormatError
from fuzzyfeed.io.csv import write_columns
from fuzzyfeed.io.shapes import load_shape, sample_shape
from fuzzyfeed.machine.profile import FeedProfile
from fuzzyfeed.geometry.sampling import sample_uniform_u

pd = pytest.importorskip("pandas")

PROFILE_COLUMNS = ["u", "x_mm", "y_mm", "z_mm", "s_mm", "curvature_1_mm", "feed_pct", "feed_mm_min"]


def read_csv_exact(path, **kwargs):
    """pandas ≥ 3 parses floats correctly rounded by default (and deprecates float_precision);
    pandas 2 needs float_precision="round_trip" for that."""
    if int(pd.__version__.split(".")[0]) < 3:
        kwargs["float_precision"] = "round_trip"
    return pd.read_csv(path, **kwargs)


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def profile_columns(name: str = "butterfly", n: int = 2000) -> dict:
    samples = sample_uniform_u(load_shape(name).curve, n)
    feed = 5.0 + 95.0 / (1.0 + samples.curvature)
    profile = FeedProfile(samples, feed, "test", 100.0)
    return {**samples.columns(), "feed_pct": profile.feed_pct, "feed_mm_min": profile.feed_mm_min}


def test_profile_csv_round_trip_bit_for_bit_with_pandas(tmp_path):
    columns = profile_columns()
    path = tmp_path / "profile.csv"
    write_columns(path, columns)
    frame = read_csv_exact(path)
    assert list(frame.columns) == PROFILE_COLUMNS
    for name, values in columns.items():
        assert frame[name].dtype == np.float64
        np.testing.assert_array_equal(bits(frame[name].to_numpy()), bits(values), err_msg=name)


finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, st.integers(1, 40), elements=finite))
def test_property_any_finite_float64_round_trips(tmp_path_factory, values):
    path = tmp_path_factory.mktemp("csv") / "v.csv"
    write_columns(path, {"a": values, "b": values[::-1].copy()})
    frame = read_csv_exact(path, dtype=np.float64)
    np.testing.assert_array_equal(bits(frame["a"].to_numpy()), bits(values))  # -0.0 kept too
    np.testing.assert_array_equal(bits(frame["b"].to_numpy()), bits(values[::-1]))


def test_nan_refused_with_row_and_no_partial_file(tmp_path):
    columns = profile_columns("trident", 100)
    columns["feed_mm_min"] = columns["feed_mm_min"].copy()
    columns["feed_mm_min"][37] = np.nan
    target = tmp_path / "out.csv"
    with pytest.raises(ExportError, match=r"column feed_mm_min row 37 = nan"):
        write_columns(target, columns)
    assert not list(tmp_path.iterdir())
    target.write_text("previous\n")
    with pytest.raises(ExportError):
        write_columns(target, columns)
    assert target.read_text() == "previous\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


# ------------------------------------------------------------------------------ point lists
def test_fuzzyfeed_csv_loads_back_as_the_same_points(tmp_path):
    columns = profile_columns("wm", 500)
    write_columns(tmp_path / "wm.csv", columns)
    shape = load_shape(str(tmp_path / "wm.csv"))
    xyz = np.column_stack([columns["x_mm"], columns["y_mm"], columns["z_mm"]])
    np.testing.assert_array_equal(bits(shape.polyline), bits(xyz))
    samples = sample_shape(shape)
    assert len(samples) == 500 and np.all(np.isfinite(samples.curvature))
    # the degree-1 NURBS through the points has chord-length knots and passes through them
    knots = shape.curve.knots
    np.testing.assert_allclose(shape.curve(knots[1:-1]), xyz, atol=1e-9)


@pytest.mark.parametrize("header, rows, expected", [
    ("x,y", ["0,0", "1,0", "1,1"], [[0, 0], [1, 0], [1, 1]]),
    (" X , Y , Z ,note", ["0,0,1,a", "1,0,1,b", "", "2,3,0.5,c"], [[0, 0, 1], [1, 0, 1], [2, 3, 0.5]]),
    ("id,y_mm,x_mm", ["1,5,0.1", "2,6,0.2"], [[0.1, 5], [0.2, 6]]),
])
def test_point_csv_column_names(tmp_path, header, rows, expected):
    path = tmp_path / "pts.csv"
    path.write_text("\n".join([header] + rows) + "\n")
    shape = load_shape(str(path))
    got = shape.polyline if shape.polyline is not None else shape.curve.control_points
    np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize("text, message", [
    ("x_mm,y_mm\n0,0\n1,nan\n2,2\n", r"pts\.csv:3: column y_mm = nan; coordinates must be finite"),
    ("x,y\n0,0\n1,inf\n", r"pts\.csv:3: column y = inf; coordinates must be finite"),
    ("x,y\n0,0\n1,abc\n", r"pts\.csv:3: column y = 'abc' is not a number"),
    ("x,y\n0,0\n1\n", r"pts\.csv:3: column y = '' is not a number"),
    ("a,b\n0,0\n", r"pts\.csv:1: header \['a', 'b'\] has no x_mm,y_mm or x,y columns"),
    ("x,y\n0,0\n", r"pts\.csv: 1 point row\(s\); a path needs at least 2"),
    ("x,y\n1,1\n1,1\n1,1\n", r"pts\.csv: every point repeats the first; a path needs at least 2"),
    ("", r"pts\.csv: empty file"),
])
def test_bad_point_csv_one_clear_line(tmp_path, text, message):
    path = tmp_path / "pts.csv"
    path.write_text(text)
    with pytest.raises(PathFormatError, match=message) as info:
        load_shape(str(path))
    assert "\n" not in str(info.value)


def test_binary_csv_and_selector(tmp_path):
    path = tmp_path / "blob.csv"
    path.write_bytes(b"x,y\n\x00\x01\x02")
    with pytest.raises(PathFormatError, match=r"blob\.csv: binary file; expected a CSV text file"):
        load_shape(str(path))
    ok = tmp_path / "ok.csv"
    ok.write_text("x,y\n0,0\n1,1\n2,0\n")
    assert load_shape(f"{ok}#1").polyline.shape == (3, 2)
    with pytest.raises(PathFormatError, match="path 2 does not exist"):
        load_shape(f"{ok}#2")


# ------------------------------------------------------------------------------ the fast writer
def test_text_is_shortest_round_trip_and_integral_floats_keep_their_point(tmp_path):
    values = np.array([0.0, -0.0, 100.0, 0.1, 1 / 3, 1e-7, 1e16, 1e300, 5e-324, -2.5, 123456789.0,
                       2.0**53, 1.7976931348623157e308])
    write_columns(tmp_path / "v.csv", {"a": values})
    text = (tmp_path / "v.csv").read_text().splitlines()[1:]
    assert text[:4] == ["0.0", "-0.0", "100.0", "0.1"]
    for field, value in zip(text, values.tolist()):
        assert float(field) == value and np.signbit(float(field)) == np.signbit(value)
        # as short as Python's repr: the shortest digits that read back (exponent style may differ)
        digits = lambda s: len(s.split("e")[0].replace("-", "").replace(".", "").strip("0") or "0")  # noqa: E731
        assert digits(field) == digits(repr(value)), (field, repr(value))


def test_many_blocks_mixed_columns_read_back_like_the_csv_module(tmp_path, monkeypatch):
    import csv

    from fuzzyfeed.io import csv as csv_mod

    monkeypatch.setattr(csv_mod, "ROWS_PER_BLOCK", 7)
    rng = np.random.default_rng(4)
    n = 50
    columns = {"x mm": rng.standard_normal(n) * 1e3, "whole": np.round(rng.standard_normal(n) * 10),
               "zero": np.zeros(n), "count": np.arange(n) - 3,
               "label": np.array(["plain", "a,b", 'say "hi"', "line\nbreak", ""] * 10),
               "ratio": np.where(np.arange(n) % 5 == 0, np.nan, 0.5)}
    write_columns(tmp_path / "m.csv", columns, allow_nan=("ratio",))
    with open(tmp_path / "m.csv", newline="") as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == list(columns)
    body = rows[1:]
    assert len(body) == n
    for j, (name, values) in enumerate(columns.items()):
        got = [r[j] for r in body]
        if values.dtype.kind == "f":
            back = np.array([float(g) for g in got])
            np.testing.assert_array_equal(bits(back), bits(values), err_msg=name)
        else:
            assert got == [str(v) for v in values.tolist()], name
    frame = read_csv_exact(tmp_path / "m.csv", keep_default_na=False, na_values=["nan"])
    for name in ("x mm", "whole", "zero", "ratio"):
        assert frame[name].dtype == np.float64, name


def test_repeated_rows_are_dropped_with_a_note(tmp_path):
    path = tmp_path / "dup.csv"
    path.write_text("x,y\n0,0\n1,0\n1,0\n2,1\n2,1\n3,3\n")
    shape = load_shape(str(path))
    np.testing.assert_array_equal(shape.polyline, [[0, 0], [1, 0], [2, 1], [3, 3]])
    assert "2 repeated point(s) dropped" in shape.notes


# ------------------------------------------------------------------------------ small tables
def float_corpus(seed: int, n: int) -> np.ndarray:
    """Doubles of every kind: random bit patterns, every decimal magnitude, integral values, and the
    edges of Arrow's decimal range (exponents -6..9) and of the repr shortcut (1e-4, 1e10)."""
    rng = np.random.default_rng(seed)
    edges = [0.0, -0.0, 1.0, 100.0, 1e9, 1e10, 1e15, 1e16, 1e17, 1e21, 1e22, 1e23, 1e-4, 1e-5, 1e-6,
             1e-7, 1.5e-6, 1.25e-5, 0.0001234, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
             2.0**53, 2.0**53 + 2, 2.0**60, 0.1, 1 / 3, 9999999999.0, 9999999999.5, 123456789012.0]
    edges += [np.nextafter(e, towards) for e in (1e-4, 1e-6, 1e-7, 1e9, 1e10) for towards in (0.0, np.inf)]
    edges = np.array(edges)
    return np.concatenate([
        edges, -edges,
        rng.standard_normal(n) * 10.0 ** rng.integers(-30, 30, n),
        rng.integers(0, 2**63 - 2**52, n, dtype=np.int64).view(np.float64) * rng.choice([-1.0, 1.0], n),
        np.round(rng.standard_normal(n) * 10.0 ** rng.integers(0, 25, n)),
    ])


def test_python_fields_are_arrows_text_value_for_value():
    from fuzzyfeed.io.csv import _python_fields, _text_column

    values = float_corpus(0, 30_000)
    assert np.isfinite(values).all()
    python, arrow = _python_fields(values), _text_column(values).to_pylist()
    wrong = [(v, p, a) for v, p, a in zip(values.tolist(), python, arrow) if p != a]
    assert not wrong, wrong[:5]
    for field, value in zip(python, values.tolist()):   # and the text reads back to the same float
        assert float(field) == value and np.signbit(float(field)) == np.signbit(value)


@pytest.mark.parametrize("seed", [1, 2])
def test_small_and_large_tables_write_the_same_bytes(tmp_path, monkeypatch, seed):
    """The Python path (small tables) and Arrow's (large) write byte-identical files: floats of every
    kind, NaN and infinities where allowed, integers, text that needs quoting, float32."""
    from fuzzyfeed.io import csv as csv_mod

    values = float_corpus(seed, 2000)
    n = values.size
    rng = np.random.default_rng(seed)
    columns = {"v": values, "w": values[::-1].copy(), "count": rng.integers(-2**62, 2**62, n),
               "small": (np.arange(n) % 256).astype(np.uint8),
               "label": np.array(["plain", "a,b", 'say "hi"', "line\nbreak", "", "é"] * (n // 6 + 1))[:n],
               "odd": np.where(np.arange(n) % 7 == 0, np.nan, np.where(np.arange(n) % 11 == 0, -np.inf, values))}
    with np.errstate(over="ignore"):
        f32 = values.astype(np.float32)
    columns["f32"] = np.where(np.isfinite(f32), f32, np.float32(0.0))
    out = {}
    for name, small in (("python", 1 << 40), ("arrow", 0)):
        monkeypatch.setattr(csv_mod, "SMALL_VALUES", small)
        write_columns(tmp_path / f"{name}.csv", columns, allow_nan=("odd",))
        out[name] = (tmp_path / f"{name}.csv").read_bytes()
    assert out["python"] == out["arrow"]
    assert out["python"].count(b"\n") > n      # the header, every row, the quoted line break
