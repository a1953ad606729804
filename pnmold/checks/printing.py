"""Printability of each ABS mold on an FDM printer, and PrusaSlicer's verdict."""

from __future__ import annotations

from pnmold.checks import measure, slicer
from pnmold.checks.context import BuildFiles
from pnmold.checks.findings import LENGTH_TOL_MM, Finding, at_least, at_most
from pnmold.conventions import MOLDS, USES

BED_CONTACT_MIN = 0.5  # assumed: at least half the footprint flat on the bed


def _build_volume(files: BuildFiles, name: str) -> Finding:
    pr = files.design.printer
    a, b, h = measure.footprint(files.mesh(name), USES[name].print_up)
    bed = sorted((pr.build_x_mm, pr.build_y_mm))
    fits = sorted((a, b))[0] <= bed[0] and sorted((a, b))[1] <= bed[1] and h <= pr.build_z_mm
    worst = max(max(a, b) / bed[1], min(a, b) / bed[0], h / pr.build_z_mm)
    return Finding(f"print.build_volume.{name}", fits, round(worst, 4), 1.0,
                   f"{name} prints as {a:.1f} x {b:.1f} x {h:.1f} mm in a "
                   f"{pr.build_x_mm:g} x {pr.build_y_mm:g} x {pr.build_z_mm:g} mm build volume")


def _mold_findings(files: BuildFiles, name: str) -> list[Finding]:
    mesh, solid, up = files.mesh(name), files.solid(name), USES[name].print_up
    if solid is None:
        return [Finding(f"print.min_wall.{name}", False, None, None, f"{name} is not a closed solid")]
    thickness, where = measure.wall_thickness(mesh, solid)
    a, b, _ = measure.footprint(mesh, up)
    return [
        at_least(f"print.min_wall.{name}", thickness, files.design.printable_wall_mm,
                 f"{name}: thinnest wall (near {tuple(round(float(v), 1) for v in where)})", " mm",
                 tol=LENGTH_TOL_MM),
        _build_volume(files, name),
        at_least(f"print.bed_contact.{name}", measure.base_area(mesh, up) / (a * b), BED_CONTACT_MIN,
                 f"{name}: flat face on the bed, as a fraction of the footprint"),
        at_most(f"print.overhang.{name}", measure.down_faces_off_the_base(mesh, up), 0.0,
                f"{name}: overhanging area that would need supports", " mm2"),
    ]


def _slicer_finding(files: BuildFiles, name: str) -> Finding:
    path = files.dir / "print" / f"{name}.stl"
    if not path.is_file():
        return Finding(f"print.slicer.{name}", False, None, None, f"print/{name}.stl is missing")
    result = slicer.slice_part(path)
    value = {"print_time_s": result.print_time_s, "filament_mm": result.filament_mm,
             "filament_g": result.filament_g, "slicer_version": result.slicer_version}
    passed = {"ok": True, "failed": False}.get(result.verdict)
    detail = (f"PrusaSlicer: {result.print_time_s / 60:.0f} min, {result.filament_g:.1f} g of ABS"
              if passed else f"PrusaSlicer {result.verdict}: {result.reason}")
    return Finding(f"print.slicer.{name}", passed, value, "sliced without errors", f"{name}: {detail}")


def check_printing(files: BuildFiles, *, use_slicer: bool = True) -> list[Finding]:
    findings = [f for name in MOLDS for f in _mold_findings(files, name)]
    for name in MOLDS:
        if use_slicer:
            findings.append(_slicer_finding(files, name))
        else:
            findings.append(Finding(f"print.slicer.{name}", None, None, None,
                                    f"{name}: slicing skipped (--no-slicer)"))
    return findings
