"""``advise_file(path, options=None, **overrides)``: a G-code program, a drawing or a shape advised
with one :class:`~fuzzyfeed.advice.options.AdviceOptions` value, as ``fuzzyfeed advise`` does,
returning an :class:`~fuzzyfeed.advice.result.AdviceResult` (nothing written until its ``write``)."""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Iterator
from pathlib import Path

from fuzzyfeed.advice.options import AdviceOptions, make_options, shape_settings
from fuzzyfeed.advice.result import AdviceResult
from fuzzyfeed.advice.shape import advise_path  # noqa: F401  (one place a path is advised)


def is_program(spec: str | os.PathLike) -> bool:
    """True when ``spec`` names a G-code file (with or without #N)."""
    from fuzzyfeed.io.shapes import split_selector
    from fuzzyfeed.program.model import GCODE_SUFFIXES

    base, _ = split_selector(os.fspath(spec))
    return Path(str(base)).suffix.lower() in GCODE_SUFFIXES


def advise_file(path: str | os.PathLike, options: AdviceOptions | None = None, **overrides) -> AdviceResult:
    """Advise the program, drawing or shape at ``path`` (a file, ``FILE#SELECTOR`` or a shipped
    shape's name) with ``options`` (default: every field at its default), any field replaced by
    ``overrides`` (``advise_file("part.ngc", machine="reference")``). A program on a machine is run
    as written, its cuts that break the tolerance advised, and the value report made (``.value``).
    Bad options or input are one-line :class:`~fuzzyfeed.errors.FuzzyfeedError`s; notices are
    :class:`~fuzzyfeed.errors.FuzzyfeedNotice` warnings."""
    options = make_options(options, **overrides)
    spec = os.fspath(path)
    settings = (spec, options.units, options.point_tolerance, options.path_tolerance)
    with shape_settings(*settings):
        if is_program(spec):
            from fuzzyfeed.advice.program import advise_program_file

            result = advise_program_file(spec, options)
        else:
            from fuzzyfeed.advice.shape import advise_shape_file

            result = advise_shape_file(spec, options)
    result.settings = settings      # what it computes later (columns, text, files) uses them too
    return result


@contextlib.contextmanager
def collect_notices() -> Iterator[list[str]]:
    """Collect the :class:`~fuzzyfeed.errors.FuzzyfeedNotice` warnings raised inside, each text once,
    in order, into the list it yields (other warnings pass on)."""
    from fuzzyfeed.errors import FuzzyfeedNotice

    notices: list[str] = []

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, FuzzyfeedNotice):
            if str(message) not in notices:
                notices.append(str(message))
            return
        previous(message, category, filename, lineno, file, line)

    previous = warnings.showwarning
    with warnings.catch_warnings():
        warnings.simplefilter("always", FuzzyfeedNotice)
        warnings.showwarning = show
        yield notices
