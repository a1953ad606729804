"""The small error hierarchy of pnmold.

Every error pnmold raises on purpose is a :class:`PnmoldError`; the CLI maps the
subclasses to exit codes (2 for bad input, 3 for geometry, meshing or solver failures).
"""

from __future__ import annotations

from typing import Any


class PnmoldError(Exception):
    """Base class of every error pnmold raises on purpose."""

    exit_code = 3


class DesignError(PnmoldError, ValueError):
    """A design value is missing, unknown, of the wrong type or violates a rule."""

    exit_code = 2

    def __init__(self, field: str, message: str):
        self.field = field
        super().__init__(f"{field}: {message}")


class UsageError(PnmoldError, ValueError):
    """The command line or an input file other than a design or recording is wrong."""

    exit_code = 2


class RecordingError(PnmoldError, ValueError):
    """A recording (lab CSV) or other data file is malformed; names file, line, column."""

    exit_code = 2

    def __init__(self, path: str, line: int | None, message: str, column: str | int | None = None):
        self.path, self.line, self.column = str(path), line, column
        where = self.path
        if line is not None:
            where += f", line {line}"
        if column is not None:
            where += f", column {column}"
        super().__init__(f"{where}: {message}")


class GeometryError(PnmoldError):
    """A CAD operation failed; names the feature and the numbers that caused it."""

    def __init__(self, feature: str, message: str):
        self.feature = feature
        super().__init__(f"{feature}: {message}")


class ExportError(PnmoldError):
    """Writing an output file failed; names the path."""

    def __init__(self, path: str, message: str):
        self.path = str(path)
        super().__init__(f"{self.path}: {message}")


class MeshingError(PnmoldError):
    """gmsh could not mesh the geometry."""


class SolveError(PnmoldError):
    """The nonlinear solve failed; names the load step and keeps the residual history.

    ``stage`` (e.g. "gravity", "pressure", "blocked force"), ``region`` (where in the body
    it went wrong) and ``hint`` (what to try) are given by solvers that know them;
    ``partial`` is what converged before the failure (for the FE, a
    :class:`pnmold.fem.Solution`), or None.
    """

    def __init__(self, message: str, last_converged: float | None = None,
                 residuals: list[float] | None = None, *, stage: str | None = None,
                 region: str | None = None, hint: str | None = None, partial: Any = None):
        self.last_converged = last_converged
        self.residuals = list(residuals or [])
        self.stage = stage
        self.region = region
        self.hint = hint
        self.partial = partial
        super().__init__(message)
