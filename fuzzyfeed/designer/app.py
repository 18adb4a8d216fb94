"""The rule designer as one object: a rule table opened for editing, an optional path to advise,
and its Panel view, shown inline in Jupyter or served as a local web app
(:func:`fuzzyfeed.designer.server.serve`, ``fuzzyfeed design``)."""

from __future__ import annotations

from pathlib import Path

from fuzzyfeed.advice.shape import DEFAULT_FEED_MM_MIN
from fuzzyfeed.designer.document import Document
from fuzzyfeed.errors import ShapeFileError


def load_path(shape: str | None = None, program: str | None = None, points: int = 2000):
    """(samples, name) of the path the designer advises: a shape (any file ``advise`` reads,
    sampled at ``points``) or a G-code program's cut (``FILE`` = cut 1, ``FILE#N`` = cut N, on its
    exact geometry); (None, "") for neither."""
    if shape is not None and program is not None:
        raise ShapeFileError(f"--shape {shape} and --program {program}: give one path, not both")
    if shape is not None:
        from fuzzyfeed.io.shapes import load_shape, sample_shape

        s = load_shape(shape)
        return sample_shape(s, points), s.name
    if program is not None:
        from fuzzyfeed.io.points import pick_by_index
        from fuzzyfeed.io.shapes import resolve_shape_path, split_selector
        from fuzzyfeed.program.cuts import sample_cut
        from fuzzyfeed.program.read import read_program

        base, selector = split_selector(program)
        prog = read_program(resolve_shape_path(base))
        if not prog.n_cuts:
            raise ShapeFileError(f"{base}: no cut (a chain of feed moves) to advise")
        described = [f"{k + 1} (line {int(prog.move_line[prog.cut_moves(k)[0]]) + 1})"
                     for k in range(prog.n_cuts)]
        k = pick_by_index(prog.path, selector, described) if selector is not None else 0
        return sample_cut(prog, k).samples, f"{Path(str(base)).name} cut {k + 1}"
    return None, ""


class Designer:
    """Edit a rule table with its membership functions, grid, control surface and the advice on
    a path, all redrawn after every edit. Display it in Jupyter (``pn.extension()`` first) or
    call :meth:`view` for the Panel layout."""

    def __init__(self, table: str | Path | None = None, shape: str | None = None,
                 program: str | None = None, points: int = 2000,
                 feed_mm_min: float = DEFAULT_FEED_MM_MIN, samples=None, path_name: str = "", machine=None):
        self.document = Document(table)
        self.machine = machine
        if samples is None:
            samples, path_name = load_path(shape, program, points)
        self.samples, self.path_name = samples, path_name
        self.max_feed_mm_s = feed_mm_min / 60.0
        self._view = None

    def view(self):
        """The :class:`~fuzzyfeed.designer.view.DesignerView` (built on first use)."""
        if self._view is None:
            from fuzzyfeed.designer.view import DesignerView

            self._view = DesignerView(self.document, self.samples, self.path_name, self.max_feed_mm_s,
                                      machine=self.machine)
        return self._view

    def panel(self):
        """The Panel layout (servable, displayable)."""
        return self.view().layout

    def _repr_mimebundle_(self, include=None, exclude=None):
        return self.panel()._repr_mimebundle_(include, exclude)
