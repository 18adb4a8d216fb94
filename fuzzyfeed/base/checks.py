"""Argument checks at the public API's door: a wrong type becomes the project's one-line error
(:class:`~fuzzyfeed.errors.InputError`, also a ValueError) instead of an AttributeError or
TypeError from deep inside."""

from __future__ import annotations

import numpy as np

from fuzzyfeed.errors import InputError


def expect(value: object, types: type | tuple[type, ...], name: str, what: str) -> None:
    """Raise InputError unless ``value`` is an instance of ``types`` (``what`` names them)."""
    if not isinstance(value, types):
        shown = repr(value)
        shown = shown if len(shown) <= 40 else shown[:37] + "..."
        raise InputError(f"{name}: {type(value).__name__} {shown}; expected {what}")


def float_array(value: object, name: str, error: type[Exception] = InputError) -> np.ndarray:
    """``value`` as a float array, or a one-line ``error`` naming ``name``."""
    if isinstance(value, (str, bytes)) or value is None:
        raise error(f"{name}: {type(value).__name__} {value!r:.40}; expected numbers")
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise error(f"{name}: cannot be read as numbers ({' '.join(str(exc).split())})") from None


def finite_vector(value: object, name: str, rule: str) -> np.ndarray:
    """``value`` as a flat float array of finite numbers, or a one-line InputError naming ``name``,
    the index and value, and ``rule`` (why it must be finite)."""
    arr = float_array(value, name)
    if arr.ndim != 1:
        raise InputError(f"{name}: shape {arr.shape}; expected a flat array")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"{name}[{i}] = {arr[i]}; {rule}")
    return arr
