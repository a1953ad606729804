"""Castability and demoldability: elastomer walls, the air path from the inlet to every
chamber, no air traps while pouring, the tubing in the inlet, molds that come off."""

from __future__ import annotations

import math

import numpy as np

from pnmold.checks import measure
from pnmold.checks.context import BuildFiles
from pnmold.checks.findings import LENGTH_TOL_MM, Finding, at_least, at_most, equal
from pnmold.conventions import MOLDS, USES
from pnmold.design.rules import TUBE_INTERFERENCE_MAX


def _elastomer_walls(files: BuildFiles) -> list[Finding]:
    limit = files.design.casting.min_elastomer_wall_mm
    out = []
    for name in ("top_layer", "bottom_layer"):
        solid = files.solid(name)
        if solid is None:
            out.append(Finding(f"cast.elastomer_wall.{name}", False, None, limit, f"{name} is not a closed solid"))
            continue
        t, where = measure.wall_thickness(files.mesh(name), solid)
        out.append(at_least(f"cast.elastomer_wall.{name}", t, limit,
                            f"{name}: thinnest elastomer wall (near "
                            f"{tuple(round(float(v), 1) for v in where)})", " mm", tol=LENGTH_TOL_MM))
    return out


def _air_path(files: BuildFiles) -> list[Finding]:
    actuator = files.solid("actuator")
    if actuator is None:
        return [Finding("cast.chambers_connected", False, None, 1, "actuator is not a closed solid")]
    sealed = measure.voids(actuator + files.inlet_plug())
    open_ = measure.voids(actuator)
    reaches = len(open_) == len(sealed) - 1
    return [
        equal("cast.chambers_connected", len(sealed), 1,
              "separate air cavities with the inlet sealed (every chamber on the one channel)"),
        Finding("cast.inlet_reaches_channel", reaches, len(open_), len(sealed) - 1,
                "the inlet bore " + ("opens the cavity to the outside" if reaches else
                                     "does not open the channel to the outside (blocked inlet)")),
    ]


def bore_diameter_mm(files: BuildFiles, x_mm: float = 0.5) -> float:
    """Equivalent diameter of the bore's hole in a cross-section of the actuator at x."""
    section = files.solid("actuator").rotate((0, -90, 0)).slice(x_mm)  # x becomes z
    holes = []
    for poly in section.to_polygons():
        p = np.asarray(poly)
        area = 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
        if area < 0:
            holes.append(-area)
    return 2 * math.sqrt(max(holes) / math.pi) if holes else 0.0


def _tubing(files: BuildFiles) -> Finding:
    inlet = files.design.inlet
    if files.solid("actuator") is None:
        return Finding("cast.tubing_fits_inlet", False, None, None, "actuator is not a closed solid")
    d = bore_diameter_mm(files)
    interference = (inlet.tubing_od_mm - d) / d if d > 0 else math.inf
    ok = 0 < interference <= TUBE_INTERFERENCE_MAX
    return Finding("cast.tubing_fits_inlet", ok, round(interference, 4), [0.0, TUBE_INTERFERENCE_MAX],
                   f"tubing OD {inlet.tubing_od_mm:.3g} mm in a {d:.3g} mm bore: interference "
                   f"{100 * interference:.0f}% (seals when slightly larger, "
                   f"at most {100 * TUBE_INTERFERENCE_MAX:.0f}%)")


def _air_traps(files: BuildFiles) -> list[Finding]:
    return [at_most(f"cast.air_trap.{name}", measure.down_faces_off_the_base(files.mesh(name), use.pour_up), 0.0,
                    f"{name}: ceilings facing down into the pour, which trap air", " mm2")
            for name, use in USES.items() if use.pour_up is not None]


def _undercut_area(files: BuildFiles, mold: str) -> float:
    """Area of the mold's surface whose path along the pull direction runs into the part."""
    use = USES[mold]
    mesh, part = files.mesh(mold), files.solid(use.cast_part)
    if part is None:
        return math.inf
    pull = np.asarray(use.pull, float)
    points, normals = measure.surface_samples(mesh)
    area = np.tile(np.asarray(mesh.area_faces), 4) / 4
    reach = float(np.linalg.norm(np.ptp(np.asarray(mesh.bounds), axis=0))) * 2 + 10.0
    eps = 1e-4
    blocked = 0.0
    for p, n, a in zip(points, normals, area, strict=True):
        start = p - eps * n
        hits = part.ray_cast(tuple(start), tuple(start + reach * pull))
        if any(h.distance * reach > 2 * eps for h in hits):
            blocked += a
    return blocked


def _demold(files: BuildFiles) -> list[Finding]:
    return [at_most(f"demold.{name}", _undercut_area(files, name), 0.0,
                    f"{name}: surface that hits {USES[name].cast_part} when pulled along "
                    f"{USES[name].pull} (undercuts)", " mm2") for name in MOLDS]


def check_casting(files: BuildFiles) -> list[Finding]:
    return [*_elastomer_walls(files), *_air_path(files), _tubing(files), *_air_traps(files),
            *_demold(files)]
