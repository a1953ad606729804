"""The chambers' quasi-static laws: cavity volume, bend angle and tip against pressure.

The pneumatic model needs only a :class:`ChamberLaw`: vectorised functions of the gauge
pressure (kPa). :func:`chamber_law_from_curve` makes one from a sampled curve (the FE's
free-bending steps) by monotone interpolation (``scipy.interpolate.PchipInterpolator``,
which keeps monotone data monotone). Outside the sampled range the law continues
linearly with the slope of the nearest end segment (a secant, robust to a noisy last
step): below the first pressure (venting undershoot) and above the last (a supply far
above the full-bend pressure). The tip follows the bend angle: it is interpolated against
the angle, and beyond the last sample it moves as the end point of a constant-curvature
arc, shifted to meet the last sampled tip.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from scipy.interpolate import PchipInterpolator

log = logging.getLogger(__name__)


@runtime_checkable
class ChamberLaw(Protocol):
    """Quasi-static response of the whole cavity to a uniform gauge pressure (kPa)."""

    def volume_ml(self, p_kpa): ...

    def bend_angle_deg(self, p_kpa): ...

    def tip_mm(self, p_kpa): ...


class _Linear:
    """A monotone PCHIP inside [x0, xn], linear with the end secants outside."""

    def __init__(self, x: np.ndarray, y: np.ndarray):
        self.x, self.y = x, y
        self.pchip = PchipInterpolator(x, y, extrapolate=False)
        self.dpchip = self.pchip.derivative()
        self.slope_lo = (y[1] - y[0]) / (x[1] - x[0])
        self.slope_hi = (y[-1] - y[-2]) / (x[-1] - x[-2])

    def __call__(self, x):
        x = np.asarray(x, float)
        lo, hi = x < self.x[0], x > self.x[-1]
        inside = np.clip(x, self.x[0], self.x[-1])
        out = self.pchip(inside)
        out = np.where(lo, self.y[0] + self.slope_lo * (x - self.x[0]), out)
        return np.where(hi, self.y[-1] + self.slope_hi * (x - self.x[-1]), out)

    def derivative(self, x):
        x = np.asarray(x, float)
        out = self.dpchip(np.clip(x, self.x[0], self.x[-1]))
        out = np.where(x < self.x[0], self.slope_lo, out)
        return np.where(x > self.x[-1], self.slope_hi, out)


def _arc_tip(angle_rad, length_mm):
    """Tip of a constant-curvature arc of the given length bent by ``angle`` (toward -z)."""
    a = np.asarray(angle_rad, float)
    x = length_mm * np.sinc(a / np.pi)
    z = -length_mm * (a / 2) * np.sinc(a / (2 * np.pi)) ** 2
    return x, z


@dataclass(frozen=True, eq=False)
class CurveLaw:
    """A :class:`ChamberLaw` from a sampled curve; also the inverse angle -> pressure."""

    pressure_kpa: np.ndarray
    volume_ml_samples: np.ndarray
    angle_deg_samples: np.ndarray
    tip_x_mm_samples: np.ndarray
    tip_z_mm_samples: np.ndarray
    length_mm: float

    def __post_init__(self):
        p, v, a = self.pressure_kpa, self.volume_ml_samples, self.angle_deg_samples
        object.__setattr__(self, "_volume", _Linear(p, v))
        object.__setattr__(self, "_angle", _Linear(p, a))
        object.__setattr__(self, "_pressure", _Linear(a, p))
        object.__setattr__(self, "_tip_x", _Linear(a, self.tip_x_mm_samples))
        object.__setattr__(self, "_tip_z", _Linear(a, self.tip_z_mm_samples))

    def scaled(self, modulus_scale: float) -> CurveLaw:
        """The law of a rubber whose constants all scale by ``modulus_scale``: the same
        shapes and volumes at pressures scaled alike (without gravity the FE is scale-free)."""
        return CurveLaw(self.pressure_kpa * modulus_scale, self.volume_ml_samples, self.angle_deg_samples,
                        self.tip_x_mm_samples, self.tip_z_mm_samples, self.length_mm)

    def volume_ml(self, p_kpa):
        return self._volume(p_kpa)

    def compliance_ml_per_kpa(self, p_kpa):
        """dV/dp of the cavity (mL/kPa)."""
        return self._volume.derivative(p_kpa)

    def bend_angle_deg(self, p_kpa):
        return self._angle(p_kpa)

    def pressure_for_angle_kpa(self, angle_deg):
        """The quasi-static pressure that holds the bend ``angle_deg`` (inverse of the angle law)."""
        return self._pressure(angle_deg)

    def dpressure_dangle_kpa_per_deg(self, angle_deg):
        return self._pressure.derivative(angle_deg)

    def tip_for_angle_mm(self, angle_deg):
        """(tip_x, tip_z) in mm at a bend angle; an arc beyond the sampled angles."""
        a = np.asarray(angle_deg, float)
        inside = np.clip(a, self.angle_deg_samples[0], self.angle_deg_samples[-1])
        x, z = self._tip_x(inside), self._tip_z(inside)
        for end, sel in ((0, a < self.angle_deg_samples[0]), (-1, a > self.angle_deg_samples[-1])):
            if np.any(sel):
                ax, az = _arc_tip(np.radians(a), self.length_mm)
                ex, ez = _arc_tip(np.radians(self.angle_deg_samples[end]), self.length_mm)
                x = np.where(sel, self.tip_x_mm_samples[end] + ax - ex, x)
                z = np.where(sel, self.tip_z_mm_samples[end] + az - ez, z)
        return x, z

    def tip_mm(self, p_kpa):
        return self.tip_for_angle_mm(self.bend_angle_deg(p_kpa))


def chamber_law_from_curve(pressure_kpa, volume_ml, bend_angle_deg, tip_x_mm, tip_z_mm,
                           length_mm: float | None = None) -> CurveLaw:
    """A monotone :class:`CurveLaw` from a sampled quasi-static curve (gauge kPa, mL, deg, mm).

    Pressures must increase; volume and angle must not decrease with pressure (tiny FE
    dips, below 1e-6 of the range, are flattened); the angle must increase strictly (it is
    inverted). ``length_mm`` (the actuator's length, for the arc beyond the last sample)
    defaults to the first tip's x."""
    p, v, a, tx, tz = (np.asarray(c, float).ravel() for c in (pressure_kpa, volume_ml, bend_angle_deg,
                                                             tip_x_mm, tip_z_mm))
    if not (len(p) == len(v) == len(a) == len(tx) == len(tz)) or len(p) < 2:
        raise ValueError("the curve needs at least two samples and columns of equal length")
    if not np.all(np.isfinite(np.stack([p, v, a, tx, tz]))):
        raise ValueError("the curve has non-finite values")
    order = np.argsort(p, kind="stable")
    p, v, a, tx, tz = p[order], v[order], a[order], tx[order], tz[order]
    keep = np.concatenate([[True], np.diff(p) > 0])
    p, v, a, tx, tz = p[keep], v[keep], a[keep], tx[keep], tz[keep]
    for name, y in (("volume", v), ("bend angle", a)):
        dips = np.maximum.accumulate(y) - y
        if dips.max() > 1e-6 * max(np.ptp(y), 1e-12):
            raise ValueError(f"the {name} decreases with pressure (by {dips.max():.3g}); the law must be monotone")
    v, a = np.maximum.accumulate(v), np.maximum.accumulate(a)
    if np.any(np.diff(a) <= 0):
        raise ValueError("the bend angle must increase strictly with pressure (it is inverted)")
    if not v[0] > 0:
        raise ValueError(f"the cavity volume must be positive, got {v[0]} mL")
    length = float(length_mm) if length_mm is not None else float(tx[0])
    return CurveLaw(p, v, a, tx, tz, length)


def chamber_law_for(design, *, progress=None) -> CurveLaw:
    """The design's law from the FE's free-bending curve (no gravity).

    Uses :func:`pnmold.physics.characterise.characterise` (cached on disk) when that module
    exists; otherwise builds the actuator and runs the quick FE (a minute or two)."""
    try:
        from pnmold.physics.characterise import characterise
    except ImportError:
        characterise = None
    if characterise is not None:
        c = characterise(design, progress=progress)
        return chamber_law_from_curve(c.pressure_kpa, c.cavity_volume_ml, c.bend_angle_deg, c.tip_x_mm,
                                      c.tip_z_mm, length_mm=design.length_mm)
    log.info("pnmold.physics.characterise not available: running the quick FE for %s", design.name)
    steps = _fe_steps(design, progress)
    cols = {k: [s[k] for s in steps] for k in ("pressure_kpa", "cavity_volume_ml", "bend_angle_deg",
                                                "tip_x_mm", "tip_z_mm")}
    return chamber_law_from_curve(cols["pressure_kpa"], cols["cavity_volume_ml"], cols["bend_angle_deg"],
                                  cols["tip_x_mm"], cols["tip_z_mm"], length_mm=design.length_mm)


def _fe_steps(design, progress=None) -> list[dict]:
    import tempfile
    from pathlib import Path

    from pnmold.cad import export_parts, make_parts
    from pnmold.mesh import MeshSize
    from pnmold.quickfe import run_fe

    with tempfile.TemporaryDirectory() as tmp:
        if progress:
            progress(f"{design.name}: actuator CAD for the FE curve")
        export_parts({"actuator": make_parts(design)["actuator"]}, Path(tmp))
        if progress:
            progress(f"{design.name}: free-bending curve (FE, no gravity; a minute or two)")
        run = run_fe(design, Path(tmp) / "actuator.step", orientation="none", size=MeshSize(3.5, 7.0))
    return [s.as_dict() for s in run.solution.steps]
