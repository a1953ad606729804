"""Run every design-rule check on a build folder's files."""

from __future__ import annotations

from pathlib import Path

from pnmold.checks.casting import check_casting
from pnmold.checks.context import BuildFiles
from pnmold.checks.findings import CheckReport
from pnmold.checks.fit import check_fit
from pnmold.checks.mesh_checks import check_meshes
from pnmold.checks.printing import check_printing


def check_parts(directory: str | Path, *, use_slicer: bool = True) -> CheckReport:
    """Read the exported files of ``directory`` and report every finding (never raises on
    a bad part: a broken file is a failed finding)."""
    files = BuildFiles(directory)
    files.design  # noqa: B018 - refuse a folder without a valid design.toml up front
    findings = [*check_meshes(files), *check_fit(files), *check_printing(files, use_slicer=use_slicer),
                *check_casting(files)]
    return CheckReport(tuple(findings))
