"""Results derived from one curve, kept while the curve lives (a Nurbs is immutable).

``compare`` schedules the same path twice (``slw`` and ``fuzzy-safe``) and simulates it five
times; what depends only on the curve and a few settings — the fitted polyline, the machine's
feed-limit staircase, the dense grid of the contour-error search — is computed once.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Hashable
from typing import TypeVar

T = TypeVar("T")

_PER_CURVE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def per_curve(curve: object, key: Hashable, make: Callable[[], T]) -> T:
    """``make()`` for ``curve`` and ``key``, computed once while ``curve`` is alive.

    The value must not refer to ``curve`` (the cache holds values strongly: the curve would never
    be freed)."""
    cached = _PER_CURVE.setdefault(curve, {})
    if key not in cached:
        cached[key] = make()
    return cached[key]
