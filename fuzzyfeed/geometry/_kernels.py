"""Inner loops in two forms: numpy for small calls, numba-compiled for large ones.

Importing numba and loading even a cached kernel costs about half a second of CPU, and the first
compilation after an install several seconds; a call on a few thousand points (seed 002's 2000
samples) costs milliseconds in numpy. So a call below :data:`COMPILED_MIN_POINTS` points runs the
numpy form and numba is never imported; a larger call runs the compiled loop. Both forms do the
same floating-point operations in the same order (tests check they agree bit for bit).

Compiled kernels are compiled for one explicit signature (read-only inputs accept writable arrays,
so one compilation serves both) and cached on disk by numba: in ``__pycache__`` beside the module
when that folder is writable, else in the user's cache folder (numba's own fallback), or in
``NUMBA_CACHE_DIR`` when it is set. When a compilation really happens (no cached copy) and stderr is
a terminal, one line says so (once per process); a run whose stderr is a file or a pipe stays silent.
"""

from __future__ import annotations

import sys
from functools import cache

import numpy as np

#: Calls on fewer points than this use the numpy form (no numba import, no compilation).
COMPILED_MIN_POINTS = 65_536
#: Once the kernel is loaded in this process, calls on at least this many points use it too
#: (a long schedule makes thousands of mid-sized calls after its first large one).
LOADED_MIN_POINTS = 256


def use_compiled(n_points: int, loaded: bool = False) -> bool:
    """Whether a call on ``n_points`` points should use the compiled form (``loaded``: the
    kernel is already loaded in this process, so a mid-sized call costs no import)."""
    return n_points >= COMPILED_MIN_POINTS or (loaded and n_points >= LOADED_MIN_POINTS)


def nurbs_compiled(n_points: int) -> bool:
    """:func:`use_compiled` for the NURBS kernel."""
    return use_compiled(n_points, nurbs_kernel.cache_info().currsize > 0)


_notice_shown = False


def compile_once(dispatcher, signature, what: str, estimate_s: float):
    """Compile (or load from numba's disk cache) ``dispatcher`` for ``signature`` only.

    Further compilation is then disabled, so an argument of another type is an error instead of a
    silent second compilation. If numba really compiles (a cache miss) and stderr is a terminal,
    one line ``fuzzyfeed: compiling numba kernels once ...`` is printed first (once per process).
    """
    from numba.core import event

    class _Notice(event.Listener):
        def on_start(self, ev):
            global _notice_shown
            if not _notice_shown and sys.stderr.isatty():
                print(f"fuzzyfeed: compiling numba kernels once (~{estimate_s:g} s each, first {what}); "
                      "later runs load them from the cache", file=sys.stderr, flush=True)
                _notice_shown = True

        def on_end(self, ev):
            pass

    with event.install_listener("numba:compile", _Notice()):
        dispatcher.compile(signature)
    dispatcher.disable_compile()
    return dispatcher


@cache
def nurbs_kernel():
    """Compiled ``kernel(spans, coeffs, u, order, out)`` filling out[0..order, i, :dim]."""
    import numba

    from fuzzyfeed.geometry._nurbs_jit import evaluate_power_basis

    ro = lambda ndim: numba.types.Array(numba.float64, ndim, "C", readonly=True)  # noqa: E731
    sig = numba.void(ro(1), ro(3), ro(1), numba.int64, numba.float64[:, :, ::1])
    return compile_once(evaluate_power_basis, sig, "the NURBS kernel", 2)


@cache
def arc_kernel():
    """Compiled u(s) (geometry/_arc_jit.py): ``kernel(spans, coeffs, breaks, cumulative,
    end_speeds, target, iterations, tol, short_step, eps_span, nodes, weights, nodes3, weights3,
    chain, out)``, ArcLengthTable._param_block point by point."""
    import numba

    from fuzzyfeed.geometry._arc_jit import param_at

    ro = lambda ndim: numba.types.Array(numba.float64, ndim, "C", readonly=True)  # noqa: E731
    f8 = numba.float64
    sig = numba.void(ro(1), ro(3), ro(1), ro(1), ro(2), ro(1), numba.int64, f8, f8, f8,
                     ro(1), ro(1), ro(1), ro(1), f8, numba.float64[::1])
    return compile_once(param_at, sig, "the arc-length kernel", 3)


@cache
def chord_kernels():
    """Compiled (pass_terms, pass_error, retarget) of geometry/_chord_jit.py: one pass of the
    chord-exact interpolator over every tick, its error and its retargeting."""
    import numba

    from fuzzyfeed.geometry._chord_jit import pass_error, pass_terms, retarget

    ro = lambda ndim: numba.types.Array(numba.float64, ndim, "C", readonly=True)  # noqa: E731
    rb = numba.types.Array(numba.boolean, 1, "C", readonly=True)
    f8, w8, wb = numba.float64, numba.float64[::1], numba.boolean[::1]
    terms = compile_once(pass_terms, numba.int64(ro(1), ro(3), f8, f8, ro(1), ro(1), ro(1), w8, w8, wb, w8, w8),
                         "the interpolator's kernels", 3)
    error = compile_once(pass_error, f8(ro(1), ro(1), rb, f8), "the interpolator's kernels", 1)
    step = compile_once(retarget, numba.int64(ro(1), ro(1), f8, f8, w8, w8, ro(1), ro(1), ro(1), rb, f8, f8,
                                              numba.boolean, wb), "the interpolator's kernels", 2)
    return terms, error, step


def evaluate_power_basis_numpy(spans: np.ndarray, coeffs: np.ndarray, u: np.ndarray, order: int,
                               out: np.ndarray) -> None:
    """The numpy form of the compiled NURBS loop (same operations, same order), for small calls.

    Seed 004 step 3: Horner on each point's span polynomial in homogeneous coordinates and its
    t-derivatives, then the rational quotient rule (The NURBS Book eq. 4.8).
    """
    m = coeffs.shape[0]
    p = coeffs.shape[1] - 1
    dim = coeffs.shape[2] - 1
    k = np.clip(np.searchsorted(spans, u, side="right") - 1, 0, m - 1)
    left = spans[k]
    h = spans[k + 1] - left
    t = ((u - left) / h)[:, None]
    c = coeffs[k]                       # (N, p + 1, dim + 1)
    a0 = c[:, p].copy()
    a1 = np.zeros_like(a0)
    a2 = np.zeros_like(a0)
    for j in range(p - 1, -1, -1):
        a2 = a2 * t + 2.0 * a1
        a1 = a1 * t + a0
        a0 = a0 * t + c[:, j]
    w = a0[:, dim:]
    c0 = a0[:, :dim] / w
    out[0] = c0
    if order >= 1:
        inv_h = (1.0 / h)[:, None]
        w1 = a1[:, dim:] * inv_h
        c1 = (a1[:, :dim] * inv_h - w1 * c0) / w
        out[1] = c1
        if order >= 2:
            inv_h2 = inv_h * inv_h
            w2 = a2[:, dim:] * inv_h2
            out[2] = (a2[:, :dim] * inv_h2 - 2.0 * w1 * c1 - w2 * c0) / w


def evaluate_power_basis(spans: np.ndarray, coeffs: np.ndarray, u: np.ndarray, order: int,
                         out: np.ndarray, compiled: bool | None = None) -> None:
    """Fill ``out[0..order]`` with C(u), C′(u), C″(u): the compiled loop for large calls, numpy
    below :data:`COMPILED_MIN_POINTS` (``compiled`` forces one form)."""
    if compiled is None:
        compiled = nurbs_compiled(u.size)
    if compiled:
        nurbs_kernel()(spans, coeffs, u, order, out)
    else:
        evaluate_power_basis_numpy(spans, coeffs, u, order, out)
