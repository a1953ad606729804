"""Casting fit and clearance: molds and cast parts partition their casting regions, the
interior mold seats at its depth, the actuator's cavity is the interior mold's cores, and
parts keep their designed clearances. Volume-based (manifold3d), so a part hidden fully
inside another is caught, not only crossing surfaces."""

from __future__ import annotations

import itertools

from pnmold.checks import solids as S
from pnmold.checks.context import BuildFiles
from pnmold.checks.findings import LENGTH_TOL_MM, Finding, at_least, at_most

OVERLAP_FRACTION = 1e-4  # 0.01 % of the cast part's volume
SEAT_TOL_MM = 0.02


def _missing(id: str, names) -> Finding:
    return Finding(id, False, None, None, f"cannot check: {', '.join(names)} not a closed solid")


def _partition(files: BuildFiles, tag: str, names: list[str], region) -> list[Finding]:
    solids = [files.solid(n) for n in names]
    if any(s is None for s in solids):
        bad = [n for n, s in zip(names, solids, strict=True) if s is None]
        return [_missing(f"fit.overlap.{tag}", bad), _missing(f"fit.void.{tag}", bad)]
    cast = S.volume(solids[0])
    limit = OVERLAP_FRACTION * cast
    worst, pair = 0.0, (names[0], names[1])
    for (na, a), (nb, b) in itertools.combinations(zip(names, solids, strict=True), 2):
        v = S.overlap(a, b)
        if v > worst:
            worst, pair = v, (na, nb)
    return [
        at_most(f"fit.overlap.{tag}", worst, limit,
                f"largest overlap among {', '.join(names)} ({pair[0]} with {pair[1]})", " mm3"),
        at_most(f"fit.void.{tag}", S.void(region, solids), limit,
                f"casting region of the {tag} layer filled by none of {', '.join(names)}", " mm3"),
    ]


def _seat(files: BuildFiles) -> Finding:
    """Seated at the designed depth: pushed further in (toward +z) by the tolerance, the
    interior mold runs into the exterior mold's ledge, and its cores then end exactly at
    the chambers' height."""
    d = files.design
    interior, exterior = files.solid("mold_interior"), files.solid("mold_exterior")
    if interior is None or exterior is None:
        return _missing("fit.seat.interior", ["mold_interior", "mold_exterior"])
    blocked = S.overlap(interior.translate((0, 0, SEAT_TOL_MM)), exterior) > 0
    depth_error = float(files.mesh("mold_interior").bounds[1][2]) - (d.top_z0_mm + d.chambers.height_mm)
    ok = blocked and abs(depth_error) <= SEAT_TOL_MM
    return Finding("fit.seat.interior", ok, depth_error, SEAT_TOL_MM,
                   f"interior mold {'stops against' if blocked else 'is not held by'} the exterior "
                   f"mold's ledge; its cores end {depth_error:+.3g} mm from the designed "
                   f"{d.top_z0_mm + d.chambers.height_mm:.4g} mm")


def _cavity(files: BuildFiles) -> Finding:
    """The actuator's air inside the top layer's envelope, less the fPN gaps and the inlet
    bore, is exactly the interior mold's cores."""
    names = ["actuator", "mold_interior", "mold_exterior"]
    actuator, interior, exterior = (files.solid(n) for n in names)
    if actuator is None or interior is None or exterior is None:
        return _missing("fit.cavity.interior", names)
    env = files.top_envelope()
    cores = interior ^ env
    air = env - actuator - exterior - (files.inlet_bore() - cores)
    mismatch = S.volume(air - cores) + S.volume(cores - air)
    limit = OVERLAP_FRACTION * S.volume(cores) + 1.0
    return at_most("fit.cavity.interior", mismatch, limit,
                   "actuator cavity differing from the interior mold's chambers and channel", " mm3")


def _slide_clearance(files: BuildFiles) -> Finding:
    """Side gap between the interior plate and the exterior mold's recess walls."""
    d = files.design
    interior, exterior = files.solid("mold_interior"), files.solid("mold_exterior")
    if interior is None or exterior is None:
        return _missing("clearance.slide.interior", ["mold_interior", "mold_exterior"])
    big = 10 * (d.length_mm + d.width_mm + d.height_mm)
    below = S.box((-big, -big, -big), (big, big, d.top_z0_mm - 0.01))  # under the seat plane
    plate, walls = interior ^ below, exterior ^ below
    designed = d.mold.clearance_mm
    gap = float(plate.min_gap(walls, 2 * designed + 1.0))
    ok = abs(gap - designed) <= max(0.02, 0.1 * designed)
    return Finding("clearance.slide.interior", ok, gap, designed,
                   f"side clearance of the interior plate in the exterior mold's recess: "
                   f"{gap:.3g} mm (designed {designed:.3g} mm)")


def _apart(files: BuildFiles) -> Finding:
    """The interior mold's cores and the exterior mold never touch: elastomer walls lie
    between them, at least the designed clearance thick."""
    d = files.design
    interior, exterior = files.solid("mold_interior"), files.solid("mold_exterior")
    if interior is None or exterior is None:
        return _missing("clearance.apart.cores_exterior", ["mold_interior", "mold_exterior"])
    lift = 0.01  # clear of the plate's face, which lies in the envelope's bottom
    cores = interior ^ files.top_envelope().translate((0, 0, lift))
    limit = d.mold.clearance_mm
    gap = float(cores.min_gap(exterior, 10.0))
    return at_least("clearance.apart.cores_exterior", gap, limit,
                    "distance between the interior mold's cores and the exterior mold", " mm",
                    tol=LENGTH_TOL_MM)


def _passive_side(files: BuildFiles) -> list[Finding]:
    """A passive side is cast in the top layer's molds: it must be the top layer turned over about the
    bottom layer's mid-plane, and it must not overlap the bottom layer (no findings without one)."""
    d = files.design
    if not d.passive_side.present:
        return []
    names = ["passive_layer", "top_layer", "bottom_layer"]
    passive, top, bottom = (files.solid(n) for n in names)
    if passive is None or top is None or bottom is None:
        return [_missing("fit.passive.mirror", names)]
    turned = top.mirror((0.0, 0.0, 1.0)).translate((0.0, 0.0, 2 * d.mid_plane_z_mm))
    mismatch = S.volume(passive - turned) + S.volume(turned - passive)
    limit = OVERLAP_FRACTION * S.volume(top) + 1.0
    return [
        at_most("fit.passive.mirror", mismatch, limit,
                "passive layer differing from the top layer turned over (what the top layer's molds cast)", " mm3"),
        at_most("fit.overlap.passive", S.overlap(passive, bottom), OVERLAP_FRACTION * S.volume(passive),
                "overlap of the passive layer with the bottom layer", " mm3"),
    ]


def check_fit(files: BuildFiles) -> list[Finding]:
    return [
        *_partition(files, "top", ["top_layer", "mold_interior", "mold_exterior"], files.top_envelope()),
        *_partition(files, "bottom", ["bottom_layer", "mold_bottom"], files.bottom_envelope()),
        _seat(files), _cavity(files), _slide_clearance(files), _apart(files), *_passive_side(files),
    ]
