"""Small calls run numpy, large calls numba: both forms give the same floats, one compilation per
kernel, a notice only when numba really compiles (and only on a terminal), and a small run never
imports numba. The numpy forms are themselves checked against geomdl and scikit-fuzzy in
test_nurbs.py and test_fuzzy_engine.py (their sizes are below the threshold)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from conftest import circle_nurbs, random_nurbs_definition

from fuzzyfeed.geometry import _kernels
from fuzzyfeed.geometry._kernels import COMPILED_MIN_POINTS, evaluate_power_basis, use_compiled
from fuzzyfeed.fuzzy.engine import compile_table
from fuzzyfeed.fuzzy.rule_reader import load_rule_table
from fuzzyfeed.io.shapes import load_shape, shape_names
from fuzzyfeed.geometry.nurbs import Nurbs
from fuzzyfeed.geometry.sampling import max_curvature


def both_forms(curve: Nurbs, u: np.ndarray, order: int = 2):
    out = []
    for compiled in (False, True):
        arr = np.empty((order + 1, u.size, curve.dim))
        evaluate_power_basis(curve._spans, curve._coeffs, u, order, arr, compiled=compiled)
        out.append(arr)
    return out


@pytest.mark.parametrize("name", shape_names())
def test_nurbs_forms_bit_identical_on_shipped_shapes(name):
    curve = load_shape(name).curve
    u = np.linspace(*curve.domain, 5001)
    for order in (0, 1, 2):
        a, b = both_forms(curve, u, order)
        np.testing.assert_array_equal(a, b)


def test_nurbs_forms_bit_identical_on_random_curves():
    rng = np.random.default_rng(7)
    for _ in range(40):
        d = random_nurbs_definition(rng)
        curve = Nurbs(d["degree"], d["knots"], d["points"], d["weights"])
        u = np.sort(np.concatenate([rng.uniform(0, 1, 300), curve.span_breaks]))
        a, b = both_forms(curve, u)
        np.testing.assert_array_equal(a, b)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 400), order=st.integers(0, 2))
def test_property_both_nurbs_forms_agree_bit_for_bit(seed, n, order):
    rng = np.random.default_rng(seed)
    d = random_nurbs_definition(rng)
    curve = Nurbs(d["degree"], d["knots"], d["points"], d["weights"])
    u = np.sort(np.concatenate([rng.uniform(0, 1, n), rng.choice(curve.span_breaks, min(n, 5))]))
    a, b = both_forms(curve, u, order)
    np.testing.assert_array_equal(a, b)


def test_evaluate_switches_form_at_the_threshold():
    assert not use_compiled(COMPILED_MIN_POINTS - 1) and use_compiled(COMPILED_MIN_POINTS)
    curve = circle_nurbs(3.0)
    u = np.linspace(0.0, 1.0, COMPILED_MIN_POINTS)
    big = curve.evaluate(u)                       # compiled
    small = np.concatenate([curve.evaluate(part) for part in np.array_split(u, 2)], axis=1)  # numpy
    np.testing.assert_array_equal(big, small)
    np.testing.assert_allclose(np.linalg.norm(big[0], axis=1), 3.0, rtol=1e-14)


def test_fuzzy_forms_bit_identical_read_only_and_writable():
    engine = compile_table(load_rule_table(None))
    rng = np.random.default_rng(3)
    vertices_k = engine.k_terms.ravel()
    vertices_d = engine.d_terms.ravel()
    kappa = np.concatenate([rng.uniform(-0.2, 1.5, 20_000), rng.choice(vertices_k, 3000), [0.0, 1e9]])
    dk = np.concatenate([rng.uniform(-0.2, 1.2, 20_000), rng.choice(vertices_d, 3000), [0.0, 1e9]])
    small = engine.feed_pct(kappa, dk, compiled=False)
    big = engine.feed_pct(kappa, dk, compiled=True)
    np.testing.assert_array_equal(small, big)
    kappa.flags.writeable = False
    dk.flags.writeable = False
    np.testing.assert_array_equal(engine.feed_pct(kappa, dk, compiled=True), big)
    from fuzzyfeed.fuzzy._kernel import centroid_kernel

    assert len(centroid_kernel().signatures) == 1    # one compilation serves both kinds of arrays


def test_compile_notice_only_on_a_terminal_and_only_when_compiling(monkeypatch, capsys):
    numba = pytest.importorskip("numba")

    def make():
        return numba.njit(lambda x: x + 1.0)

    monkeypatch.setattr(_kernels, "_notice_shown", False)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False, raising=False)
    _kernels.compile_once(make(), numba.float64(numba.float64), "a test kernel", 1)
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    kernel = _kernels.compile_once(make(), numba.float64(numba.float64), "a test kernel", 1)
    err = capsys.readouterr().err
    assert err == ("fuzzyfeed: compiling numba kernels once (~1 s each, first a test kernel); "
                   "later runs load them from the cache\n")
    assert kernel(1.0) == 2.0
    _kernels.compile_once(make(), numba.float64(numba.float64), "another kernel", 1)
    assert capsys.readouterr().err == ""          # one line per process
    with pytest.raises(TypeError):  # no silent second compilation for another type
        kernel(np.zeros(2))


CACHED_MODULE = """
import sys
import numba
sys.stderr.isatty = lambda: True
from fuzzyfeed.geometry._kernels import compile_once

@numba.njit(cache=True)
def twice(x):
    return 2.0 * x

compile_once(twice, numba.float64(numba.float64), "twice", 1)
print(twice(2.5))
"""


def test_compile_notice_not_shown_when_numba_loads_its_cache(tmp_path):
    pytest.importorskip("numba")
    (tmp_path / "cached_mod.py").write_text(CACHED_MODULE)
    env = {**__import__("os").environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = [subprocess.run([sys.executable, "cached_mod.py"], cwd=tmp_path, env=env, capture_output=True,
                           text=True, check=True) for _ in range(2)]
    assert [r.stdout for r in runs] == ["5.0\n", "5.0\n"]
    assert runs[0].stderr.startswith("fuzzyfeed: compiling numba kernels once (~1 s each, first twice)")
    assert runs[1].stderr == ""          # loaded from the cache written by the first run


@pytest.mark.parametrize("seed", range(8))
def test_fuzzy_forms_bit_identical_on_random_tables(seed):
    from test_fuzzy_engine import _random_inputs, random_table

    table = random_table(seed, vertical_edges=seed % 2 == 0)
    kappa, dk = _random_inputs(table, np.random.default_rng(seed), 5000)
    engine = compile_table(table)
    np.testing.assert_array_equal(engine.feed_pct(kappa, dk, compiled=False),
                                  engine.feed_pct(kappa, dk, compiled=True))


HEAVY = ("numba", "matplotlib", "pandas", "scipy", "skfuzzy", "ezdxf", "pyarrow")


@pytest.mark.parametrize("argv, allowed", [
    (["--version"], ()),
    (["shapes"], ()),
    (["advise", "infinity", "-o", "{tmp}/a.csv"], ("pyarrow",)),
    (["rules", "show"], ()),
])
def test_commands_import_only_what_they_use(tmp_path, argv, allowed):
    argv = [a.format(tmp=tmp_path) for a in argv]
    code = ("import sys\nfrom fuzzyfeed.cli import main\n"
            "try:\n    main(%r)\nexcept SystemExit:\n    pass\n"
            "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))" % argv)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    loaded = set(out.split()) & set(HEAVY)
    assert loaded <= set(allowed), f"fuzzyfeed {' '.join(argv)} imported {sorted(loaded - set(allowed))}"


def test_max_curvature_closed_form_ellipse_and_circle():
    r = 4.0
    _, k = max_curvature(circle_nurbs(r))
    assert k == pytest.approx(1.0 / r, rel=1e-12)
    a, b = 30.0, 2.0   # the circle scaled to an ellipse: max κ = a / b² at the ends of the major axis
    c = circle_nurbs(1.0)
    ellipse = Nurbs(2, c.knots, c.control_points * [a, b], c.weights)
    u, k = max_curvature(ellipse)
    assert k == pytest.approx(a / b**2, rel=1e-9)
    assert abs(ellipse(u)[1]) == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize("name", shape_names())
def test_max_curvature_not_below_a_dense_scan(name):
    curve = load_shape(name).curve
    scan = float(curve.curvature(np.linspace(*curve.domain, 200_001)).max())
    _, k = max_curvature(curve)
    assert scan * (1 - 1e-12) <= k <= scan * (1 + 1e-6)
