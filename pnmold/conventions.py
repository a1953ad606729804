"""The words every stage shares, defined once (docs/frame-and-units.md, docs/recording-format.md).

- recording kinds: what a lab measured (``bending``, ``pv``, ``force``, ``step``);
- test orientations: where gravity points in the actuator frame, and how much of it acts
  (buoyancy when submerged); ``none`` is the gravity-free run of the FE and the reduced
  model's characterisation, not a lab orientation;
- the full bend: 360 degrees, the free end touching the fixed end (supplement: "fully bent
  when both ends of the actuator were in contact"), and the pressure where a curve first
  reaches it;
- the parts of a build (file stems) and how each mold is used: printed, poured into and
  pulled off its cast part (directions are unit vectors in the actuator frame), shared by the
  CAD export (print-oriented copies), the checks, the pictures and the checklist;
- the default build folder, ``out/<design-name>/``.

A leaf module: it imports nothing of pnmold but the errors.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from pnmold.errors import UsageError

#: recording kinds (docs/recording-format.md); the quasi-static ones are pressure curves
RECORDING_KINDS = ("bending", "pv", "force", "step")
QUASI_STATIC_KINDS = ("bending", "pv", "force")
#: test orientations (docs/recording-format.md): chambers_up = gravity along -z, chambers_down = +z,
#: horizontal = out of the bending plane (-y), submerged = chambers up in water
ORIENTATIONS = ("chambers_up", "chambers_down", "horizontal", "submerged")
NO_GRAVITY = "none"
#: water at 20 degC (CRC Handbook of Chemistry and Physics: 0.9982 g/mL)
WATER_DENSITY_G_PER_ML = 0.998
#: fully bent: the free end meets the fixed end (docs/frame-and-units.md)
FULL_BEND_DEG = 360.0

#: the molds and the cast parts of a build; every part a build may export, in build order (file stems)
MOLDS = ("mold_interior", "mold_exterior", "mold_bottom")
CAST_PARTS = ("actuator", "top_layer", "bottom_layer", "passive_layer", "paper")
PART_NAMES = (*CAST_PARTS, *MOLDS)
#: the build's default folder is OUT_ROOT/<design-name>/
OUT_ROOT = Path("out")


def default_out_dir(design_name: str) -> Path:
    """Where a build (and its by-products) goes when no folder is given: ``out/<design-name>/``."""
    return OUT_ROOT / design_name


@dataclass(frozen=True)
class MoldUse:
    name: str
    cast_part: str  # the cast part it shapes
    print_up: tuple[float, float, float]  # actuator-frame direction that points up on the bed
    pull: tuple[float, float, float]  # direction the mold moves to leave the cast part
    pour_up: tuple[float, float, float] | None  # up while pouring, for a vessel; None otherwise


USES = {
    # the plate prints on the bed, cores up; it is pulled down out of the top layer
    "mold_interior": MoldUse("mold_interior", "top_layer", (0, 0, 1), (0, 0, -1), None),
    # prints and is poured ceiling down (turned over); it lifts off the top layer along +z
    "mold_exterior": MoldUse("mold_exterior", "top_layer", (0, 0, -1), (0, 0, 1), (0, 0, -1)),
    # the tray prints and is poured floor down; the cast layer lifts out along +z
    "mold_bottom": MoldUse("mold_bottom", "bottom_layer", (0, 0, 1), (0, 0, -1), (0, 0, 1)),
}


def check_orientation(orientation: str, *, allow_none: bool = False) -> str:
    """``orientation`` if it is one of :data:`ORIENTATIONS` (or ``none`` when allowed)."""
    valid = (*ORIENTATIONS, NO_GRAVITY) if allow_none else ORIENTATIONS
    if orientation not in valid:
        raise UsageError(f"orientation: one of {', '.join(valid)}, got {orientation!r}")
    return orientation


def gravity_direction(orientation: str, density_g_per_ml: float) -> tuple[float, float, float] | None:
    """Gravity in units of g in the actuator frame for a test orientation, net of the water's
    buoyancy when submerged; None for ``none``. ``horizontal`` points out of the bending
    plane (a half model cannot carry it)."""
    check_orientation(orientation, allow_none=True)
    if orientation == "chambers_up":
        return (0.0, 0.0, -1.0)
    if orientation == "chambers_down":
        return (0.0, 0.0, 1.0)
    if orientation == "horizontal":
        return (0.0, -1.0, 0.0)
    if orientation == "submerged":
        return (0.0, 0.0, -(1.0 - WATER_DENSITY_G_PER_ML / density_g_per_ml))
    return None


def full_bend_crossing(pressure_kpa: Sequence[float], bend_angle_deg: Sequence[float]
                       ) -> tuple[float | None, str | None]:
    """The pressure where the bend first reaches :data:`FULL_BEND_DEG` (linear between
    samples), or (None, the reason: how far the curve got)."""
    rows = list(zip(pressure_kpa, bend_angle_deg, strict=True))
    for (p0, a0), (p1, a1) in zip(rows, rows[1:], strict=False):
        if a1 >= FULL_BEND_DEG > a0:
            return float(p0 + (FULL_BEND_DEG - a0) / (a1 - a0) * (p1 - p0)), None
    if not rows:
        return None, "no converged step"
    p, a = rows[-1]
    return None, f"bend angle reached {a:.1f} deg at {p:.4g} kPa, the highest pressure solved"
