"""The words every stage shares, defined once (CONTRACTS.md §2, §4).

- recording kinds: what a lab measured (``bending``, ``pv``, ``force``, ``step``);
- test orientations: where gravity points in the actuator frame, and how much of it acts
  (buoyancy when submerged); ``none`` is the gravity-free run of the FE and the reduced
  model's characterisation, not a lab orientation;
- the full bend: 360 degrees, the free end touching the fixed end (supplement: "fully bent
  when both ends of the actuator were in contact"), and the pressure where a curve first
  reaches it.

A leaf module: it imports nothing of pnmold but the errors.
"""

from __future__ import annotations

from collections.abc import Sequence

from pnmold.errors import UsageError

#: recording kinds (CONTRACTS.md §4); the quasi-static ones are pressure curves
RECORDING_KINDS = ("bending", "pv", "force", "step")
QUASI_STATIC_KINDS = ("bending", "pv", "force")
#: test orientations (CONTRACTS.md §4): chambers_up = gravity along -z, chambers_down = +z,
#: horizontal = out of the bending plane (-y), submerged = chambers up in water
ORIENTATIONS = ("chambers_up", "chambers_down", "horizontal", "submerged")
NO_GRAVITY = "none"
#: water at 20 degC (CRC Handbook of Chemistry and Physics: 0.9982 g/mL)
WATER_DENSITY_G_PER_ML = 0.998
#: fully bent: the free end meets the fixed end (CONTRACTS.md §2)
FULL_BEND_DEG = 360.0


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
