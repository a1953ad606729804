"""The small error hierarchy of pnmold.

Every error pnmold raises on purpose is a :class:`PnmoldError`; the command line maps the
subclasses to exit codes (docs/cli.md): 2 for bad input (a design, the command line, a
recording or data file, an output folder pnmold may not replace), 3 for geometry, meshing or
solver failures, 74 for a file or folder that cannot be read or written. Anything else that
escapes is a bug: the command line prints it in one line and exits with
:data:`EXIT_UNEXPECTED`, never 1 (the code of "a design-rule check failed").
"""

from __future__ import annotations

import os
from typing import Any

#: exit code of an unexpected exception (sysexits.h EX_SOFTWARE, "internal software error")
EXIT_UNEXPECTED = 70
#: exit code of a file or folder that cannot be read or written (sysexits.h EX_IOERR)
EXIT_IO = 74
#: exit code after Ctrl-C (128 + SIGINT, as a shell reports it)
EXIT_INTERRUPTED = 130


class PnmoldError(Exception):
    """Base class of every error pnmold raises on purpose."""

    exit_code = 3


class DesignError(PnmoldError, ValueError):
    """A design value is missing, unknown, of the wrong type or violates a rule."""

    exit_code = 2

    def __init__(self, field: str, message: str):
        self.field, self.message = field, message
        super().__init__(f"{field}: {message}")


class SweepError(DesignError):
    """A sweep file is unreadable or wrong; names the file and the field (exit 2)."""

    def __init__(self, path: str | os.PathLike, field: str, message: str):
        self.path = str(path)
        super().__init__(field, message)
        self.args = (f"{self.path}: {field}: {message}",)


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


class OutputError(UsageError):
    """An output path pnmold may not write: a folder holding files it did not write, a file given
    as a folder, a folder another run is writing (exit 2); names the path and what to do."""

    def __init__(self, path: str | os.PathLike, message: str):
        self.path = str(path)
        super().__init__(f"{self.path}: {message}")


class FileAccessError(PnmoldError):
    """A file or folder cannot be read or written (permissions, a full disk, a folder where a file
    was asked for); names the user's path, never a temporary one (exit :data:`EXIT_IO`)."""

    exit_code = EXIT_IO

    def __init__(self, path: str | os.PathLike, message: str):
        self.path = str(path)
        super().__init__(f"{self.path}: {message}")


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


class RodError(SolveError):
    """The reduced model's rod found no equilibrium for some rows (``rows``: their indices)."""

    def __init__(self, rows: Any):
        self.rows = rows
        super().__init__(f"reduced model: no equilibrium of the rod for {len(rows)} row(s) (first: row {rows[0]}) "
                         "after ramping the weight and starting from the previous row")
