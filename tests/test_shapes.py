"""Shape library and shape files: shipped values, loading by name or path, bad files."""

from __future__ import annotations

import json

import pytest

from fuzzyfeed.errors import ShapeFileError
from fuzzyfeed.io.shapes import load_shape, shape_names, shape_to_toml


def test_shipped_shapes_and_lengths():
    assert shape_names() == ["butterfly", "infinity", "trident", "trident2", "wm"]
    expected = {"infinity": 475.162, "trident": 97.991, "butterfly": 382.86}
    for name, length in expected.items():
        shape = load_shape(name)
        assert shape.name == name and shape.source
        assert shape.curve.length == pytest.approx(length, abs=1e-3)


def test_shipped_shapes_match_shared_data():
    """The shipped files carry exactly the benchmark curves of the design data."""
    from pathlib import Path
    import numpy as np

    data_file = Path(__file__).resolve().parents[2] / "shared" / "data" / "shapes.json"
    if not data_file.is_file():
        pytest.skip(f"{data_file} not present (only in the development workspace)")
    data = json.loads(data_file.read_text())
    for name in shape_names():
        curve, ref = load_shape(name).curve, data[name]
        assert curve.degree == ref["degree"]
        np.testing.assert_array_equal(curve.knots, ref["knots"])
        np.testing.assert_array_equal(curve.control_points, ref["control_points"])
        np.testing.assert_array_equal(curve.weights, ref["weights"])


def test_load_by_path_toml_json_and_roundtrip(tmp_path):
    shape = load_shape("trident")
    path = tmp_path / "copy.toml"
    path.write_text(shape_to_toml(shape))
    again = load_shape(str(path))
    assert again.curve.length == shape.curve.length
    geomdl_style = {"shape": {"type": "curve", "data": [{
        "degree": 2, "knotvector": [0, 0, 0, 1, 1, 1],
        "control_points": {"points": [[0, 0], [1, 1], [2, 0]], "weights": [1, 2, 1]}}]}}
    jpath = tmp_path / "arc.json"
    jpath.write_text(json.dumps(geomdl_style))
    arc = load_shape(jpath)
    assert arc.name == "arc" and arc.curve.weights.tolist() == [1, 2, 1]


def test_inch_units_convert_to_mm(tmp_path):
    path = tmp_path / "inch.toml"
    path.write_text('units = "inch"\ndegree = 1\nknotvector = [0, 0, 1, 1]\ncontrol_points = [[0, 0], [1, 0]]\n')
    assert load_shape(path).curve.length == pytest.approx(25.4)


@pytest.mark.parametrize("text, message", [
    ("degree = 2\nknotvector = [0,0,0,1,1,1\n", r"invalid TOML"),
    ("knotvector = [0, 0, 1, 1]\ncontrol_points = [[0, 0], [1, 0]]\n", r"field 'degree' is missing"),
    ("degree = 1\nknotvector = [0, 0, 1]\ncontrol_points = [[0, 0], [1, 0]]\n", r"knots: length 3, expected"),
    ("degree = 1\nknotvector = [0, 0, 1, 1]\ncontrol_points = [[0, 0], [1, 0]]\nweights = [1, -1]\n",
     r"weights\[1\] = -1.0; weights must be finite and > 0"),
    ('units = "furlong"\ndegree = 1\nknotvector = [0, 0, 1, 1]\ncontrol_points = [[0, 0], [1, 0]]\n', r"units = 'furlong'"),
    ('degree = 1\nknotvector = [0, 0, 1, 1]\ncontrol_points = [[0, "a"], [1, 0]]\n', r"control_points must be a list"),
])
def test_bad_shape_files(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ShapeFileError, match=message) as info:
        load_shape(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_unknown_name_missing_file_binary_and_directory(tmp_path):
    with pytest.raises(ShapeFileError, match=r"shape 'nosuch': no such shipped shape or file; shipped shapes are: butterfly"):
        load_shape("nosuch")
    with pytest.raises(ShapeFileError, match=r"no such file"):
        load_shape(tmp_path / "missing.toml")
    binary = tmp_path / "blob.toml"
    binary.write_bytes(b"\x00\x01\x02garbage")
    with pytest.raises(ShapeFileError, match="binary file"):
        load_shape(binary)
    with pytest.raises(ShapeFileError, match="not a regular file"):
        load_shape(tmp_path)
    other = tmp_path / "shape.xyz"
    other.write_text("1 2 3")
    with pytest.raises(ShapeFileError, match=r"unsupported file type '.xyz'"):
        load_shape(other)
