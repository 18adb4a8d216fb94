"""One exception hierarchy for fuzzyfeed.

Every error is also the builtin a caller would expect (``ValueError`` for a bad value,
``OSError`` for an unreadable file), so ``except ValueError`` keeps working. Messages name the
value, where it is (file, line, field, index) and the rule it breaks, in one line; the CLI prints
that line and exits with code 2.
"""

from __future__ import annotations


class FuzzyfeedError(Exception):
    """Base class of every error fuzzyfeed raises on purpose."""


class NurbsError(ValueError, FuzzyfeedError):
    """A NURBS definition breaks a rule (degree, knots, control points, weights)."""


class ShapeFileError(ValueError, FuzzyfeedError):
    """A shape file is unreadable, malformed, or names an unknown shape."""


class RuleTableError(ValueError, FuzzyfeedError):
    """A rule table file or an in-memory rule table breaks a rule."""


class MachineLimitsError(ValueError, FuzzyfeedError):
    """A machine limit (feed, velocity, acceleration, jerk, tolerance, period) is invalid."""


class InputError(ValueError, FuzzyfeedError):
    """Numeric input that cannot be processed (NaN, infinite, empty, out of range)."""


class PathFormatError(ValueError, FuzzyfeedError):
    """An imported path file (CSV, G-code, DXF) is malformed or has nothing usable."""


class ExportError(ValueError, FuzzyfeedError):
    """A profile cannot be exported in the requested format."""


class BatchError(ValueError, FuzzyfeedError):
    """A batch cannot run as asked (no input found, results folder among the inputs, a cluster
    that cannot be reached or runs another fuzzyfeed)."""


class FileConflictError(FuzzyfeedError):
    """A file to be written changed on disk since it was read, or is another file; the caller
    asks before overwriting it."""


class FuzzyfeedNotice(UserWarning):
    """Something the user should know that is not an error (a damaged file read through recovery,
    units assumed); the CLI prints it as one line ``fuzzyfeed: notice: ...`` on stderr."""
