"""The interactive rule designer (layer 9): a rule table's membership functions, rule grid,
control surface and the advice on a path, edited together and redrawn after every edit; inline
in Jupyter or as a local web app (``fuzzyfeed design``). May import every package but ``cli``;
Panel and Bokeh are imported only when a view is built."""

from __future__ import annotations

__all__ = ["Designer", "Document"]


def __getattr__(name: str):
    if name == "Designer":
        from fuzzyfeed.designer.app import Designer
        return Designer
    if name == "Document":
        from fuzzyfeed.designer.document import Document
        return Document
    raise AttributeError(f"module 'fuzzyfeed.designer' has no attribute {name!r}")
