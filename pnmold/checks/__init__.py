"""Design-rule checks on the exported files (trimesh, manifold3d, PrusaSlicer).

They read the STL files exactly as the printer gets them and report findings
``{id, passed, value, limit, message}``; they never raise on a bad part.
"""

from pnmold.checks.findings import CheckReport, Finding
from pnmold.checks.run import check_parts

__all__ = ["CheckReport", "Finding", "check_parts"]
