"""The chambers' quasi-static laws: cavity volume, bend angle and tip against pressure.

The pneumatic model needs only a :class:`ChamberLaw`: vectorised functions of the gauge
pressure (kPa). :func:`chamber_law_from_curve` makes one from a sampled curve (the FE's
free-bending steps) by monotone interpolation (``scipy.interpolate.PchipInterpolator``,
which keeps monotone data monotone).

A law is known up to its last sample and no further: the FE's last solved step, which
ended at full bend, at a named physical stop (a pressure maximum, the stretch at break,
...) or at a pressure cap (:class:`LawEnd`, from the characterisation's ``stop``). Reading
a :class:`CurveLaw` past it (a pressure above the last, a bend above the last) raises
:class:`BeyondLaw` naming that end: no answer comes from a line drawn past what the FE
solved. :func:`chamber_law_for` first extends a characterisation that ended merely at its
pressure cap below full bend by solving on with the FE up to the pressure asked for.
Below the first sample (a venting undershoot below 0 kPa, a bend below the rest angle)
the law continues linearly with the slope of the first segment (a secant): physically
benign, a linear spring about the rest state, and only ever a sliver of a kPa or a degree.
The tip follows the bend angle: it is interpolated against the angle, and below the first
sample it moves as the end point of a constant-curvature arc, shifted to meet the first
sampled tip.

The compiled step model reads a law as :class:`Pieces` (:meth:`CurveLaw.volume_pieces`,
:meth:`CurveLaw.pressure_pieces`): the PCHIP's breaks and cubic coefficients and the two
linear continuations, the same polynomials, not a re-fit. The continuation above the last
sample is there only for the integrator's Newton iterates within the step that crosses
the end: the integration ends there (the step model's stop event,
:mod:`pnmold.pneumatics.trbdf2`), so no answer reads it. Any other :class:`ChamberLaw` is
first sampled into a :class:`CurveLaw` (:func:`as_curve_law`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np
from scipy.interpolate import PchipInterpolator

from pnmold.conventions import FULL_BEND_DEG
from pnmold.errors import SolveError

log = logging.getLogger(__name__)


@runtime_checkable
class ChamberLaw(Protocol):
    """Quasi-static response of the whole cavity to a uniform gauge pressure (kPa)."""

    def volume_ml(self, p_kpa): ...

    def bend_angle_deg(self, p_kpa): ...

    def tip_mm(self, p_kpa): ...


class BeyondLaw(SolveError):
    """A law read past its last solved point (a pressure or a bend above the FE's last step)."""


@dataclass(frozen=True)
class LawEnd:
    """Where a law's solved range ends: its last point (gauge kPa, deg, mL), how the curve ended
    (``stop``: one of :data:`pnmold.fem.STOPS`, or ``sampled`` for an analytic law sampled up to
    there) and why, in words (``reason``)."""

    pressure_kpa: float
    angle_deg: float
    volume_ml: float
    stop: str
    reason: str

    def describe(self) -> str:
        return (f"ends at {self.pressure_kpa:.4g} kPa, {self.angle_deg:.1f} deg, {self.volume_ml:.4g} mL: "
                f"{self.reason}")

    def scaled(self, modulus_scale: float) -> LawEnd:
        return LawEnd(self.pressure_kpa * modulus_scale, self.angle_deg, self.volume_ml, self.stop, self.reason)


class Pieces(NamedTuple):
    """A piecewise cubic (scipy's ``PPoly`` layout: ``coefficients[0]`` multiplies dx^3)
    inside [breaks[0], breaks[-1]], continued linearly outside: ``value_lo + slope_lo (x -
    breaks[0])`` below, ``value_hi + slope_hi (x - breaks[-1])`` above (above only for the
    Newton iterates of the step that crosses the law's end, see the module docstring).
    Numba reads it in nopython mode (:func:`pnmold.pneumatics.rates.evaluate`)."""

    breaks: np.ndarray
    coefficients: np.ndarray  # (4, len(breaks) - 1)
    value_lo: float
    value_hi: float
    slope_lo: float
    slope_hi: float


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

    def pieces(self) -> Pieces:
        return Pieces(np.ascontiguousarray(self.pchip.x, float), np.ascontiguousarray(self.pchip.c, float),
                      float(self.y[0]), float(self.y[-1]), float(self.slope_lo), float(self.slope_hi))


def _arc_tip(angle_rad, length_mm):
    """Tip of a constant-curvature arc of the given length bent by ``angle`` (toward -z)."""
    a = np.asarray(angle_rad, float)
    x = length_mm * np.sinc(a / np.pi)
    z = -length_mm * (a / 2) * np.sinc(a / (2 * np.pi)) ** 2
    return x, z


@dataclass(frozen=True, eq=False)
class CurveLaw:
    """A :class:`ChamberLaw` from a sampled curve; also the inverse angle -> pressure. Known up to
    its last sample (``end``; default: "the curve's last sample"): a read past it raises
    :class:`BeyondLaw`."""

    pressure_kpa: np.ndarray
    volume_ml_samples: np.ndarray
    angle_deg_samples: np.ndarray
    tip_x_mm_samples: np.ndarray
    tip_z_mm_samples: np.ndarray
    length_mm: float
    end: LawEnd | None = None

    def __post_init__(self):
        p, v, a = self.pressure_kpa, self.volume_ml_samples, self.angle_deg_samples
        if self.end is None:
            object.__setattr__(self, "end", LawEnd(float(p[-1]), float(a[-1]), float(v[-1]), "sampled",
                                                   "the curve's last sample"))
        object.__setattr__(self, "_volume", _Linear(p, v))
        object.__setattr__(self, "_angle", _Linear(p, a))
        object.__setattr__(self, "_pressure", _Linear(a, p))
        object.__setattr__(self, "_tip_x", _Linear(a, self.tip_x_mm_samples))
        object.__setattr__(self, "_tip_z", _Linear(a, self.tip_z_mm_samples))

    def scaled(self, modulus_scale: float) -> CurveLaw:
        """The law of a rubber whose constants all scale by ``modulus_scale``: the same
        shapes and volumes at pressures scaled alike (without gravity the FE is scale-free)."""
        return CurveLaw(self.pressure_kpa * modulus_scale, self.volume_ml_samples, self.angle_deg_samples,
                        self.tip_x_mm_samples, self.tip_z_mm_samples, self.length_mm, self.end.scaled(modulus_scale))

    @property
    def top_kpa(self) -> float:
        """The last pressure solved (gauge kPa): the law is not known above it."""
        return float(self.pressure_kpa[-1])

    @property
    def top_deg(self) -> float:
        """The last bend solved (deg): the law is not known above it."""
        return float(self.angle_deg_samples[-1])

    def within(self, p_kpa) -> np.ndarray:
        """Whether each pressure lies within the solved range (at or below :attr:`top_kpa`)."""
        return np.asarray(p_kpa, float) <= self.top_kpa * (1 + 1e-12)

    def _check(self, x, top: float, what: str, unit: str) -> np.ndarray:
        x = np.asarray(x, float)
        if np.any(x > top * (1 + 1e-12) + 1e-12):
            raise BeyondLaw(f"chamber law: {what} {float(np.max(x)):.4g} {unit} lies past the last the FE solved "
                            f"({top:.4g} {unit}; the law {self.end.describe()}); past it the law is unknown")
        return x

    def volume_ml(self, p_kpa):
        return self._volume(self._check(p_kpa, self.top_kpa, "pressure", "kPa"))

    def volume_pieces(self) -> Pieces:
        """The cavity volume (mL) against the gauge pressure (kPa), as compiled code reads it."""
        return self._volume.pieces()

    def pressure_pieces(self) -> Pieces:
        """The quasi-static pressure (gauge kPa) against the bend angle (deg), as compiled code reads it."""
        return self._pressure.pieces()

    def compliance_ml_per_kpa(self, p_kpa):
        """dV/dp of the cavity (mL/kPa)."""
        return self._volume.derivative(self._check(p_kpa, self.top_kpa, "pressure", "kPa"))

    def bend_angle_deg(self, p_kpa):
        return self._angle(self._check(p_kpa, self.top_kpa, "pressure", "kPa"))

    def pressure_for_angle_kpa(self, angle_deg):
        """The quasi-static pressure that holds the bend ``angle_deg`` (inverse of the angle law)."""
        return self._pressure(self._check(angle_deg, self.top_deg, "bend", "deg"))

    def dpressure_dangle_kpa_per_deg(self, angle_deg):
        return self._pressure.derivative(self._check(angle_deg, self.top_deg, "bend", "deg"))

    def full_bend_kpa(self) -> float | None:
        """The quasi-static full-bend pressure when the solved range reaches full bend, else None
        (:meth:`short_of_full_bend` says why)."""
        if self.top_deg < FULL_BEND_DEG:
            return None
        return float(self.pressure_for_angle_kpa(FULL_BEND_DEG))

    def short_of_full_bend(self) -> str:
        """Why full bend is not within the solved range (the words of the summary)."""
        return f"not reached within the FE's solved range ({self.end.describe()})"

    def tip_for_angle_mm(self, angle_deg):
        """(tip_x, tip_z) in mm at a bend angle; an arc below the first sampled angle."""
        a = self._check(angle_deg, self.top_deg, "bend", "deg")
        inside = np.clip(a, self.angle_deg_samples[0], self.angle_deg_samples[-1])
        x, z = self._tip_x(inside), self._tip_z(inside)
        sel = a < self.angle_deg_samples[0]
        if np.any(sel):
            ax, az = _arc_tip(np.radians(a), self.length_mm)
            ex, ez = _arc_tip(np.radians(self.angle_deg_samples[0]), self.length_mm)
            x = np.where(sel, self.tip_x_mm_samples[0] + ax - ex, x)
            z = np.where(sel, self.tip_z_mm_samples[0] + az - ez, z)
        return x, z

    def tip_mm(self, p_kpa):
        return self.tip_for_angle_mm(self.bend_angle_deg(p_kpa))


def chamber_law_from_curve(pressure_kpa, volume_ml, bend_angle_deg, tip_x_mm, tip_z_mm,
                           length_mm: float | None = None, *, stop: str = "sampled",
                           reason: str = "the curve's last sample") -> CurveLaw:
    """A monotone :class:`CurveLaw` from a sampled quasi-static curve (gauge kPa, mL, deg, mm).

    Pressures must increase; volume and angle must not decrease with pressure (tiny FE
    dips, below 1e-6 of the range, are flattened); the angle must increase strictly (it is
    inverted). ``length_mm`` (the actuator's length, for the arc beyond the last sample)
    defaults to the first tip's x. ``stop`` and ``reason``: how the curve ended (:class:`LawEnd`).
    A curve that breaks these (an FE run gone wrong) raises :class:`~pnmold.errors.SolveError`."""
    p, v, a, tx, tz = (np.asarray(c, float).ravel() for c in (pressure_kpa, volume_ml, bend_angle_deg,
                                                             tip_x_mm, tip_z_mm))
    if not (len(p) == len(v) == len(a) == len(tx) == len(tz)) or len(p) < 2:
        raise SolveError("chamber law: the curve needs at least two samples and columns of equal length")
    if not np.all(np.isfinite(np.stack([p, v, a, tx, tz]))):
        raise SolveError("chamber law: the curve has non-finite values")
    order = np.argsort(p, kind="stable")
    p, v, a, tx, tz = p[order], v[order], a[order], tx[order], tz[order]
    keep = np.concatenate([[True], np.diff(p) > 0])
    p, v, a, tx, tz = p[keep], v[keep], a[keep], tx[keep], tz[keep]
    for name, y in (("volume", v), ("bend angle", a)):
        dips = np.maximum.accumulate(y) - y
        if dips.max() > 1e-6 * max(np.ptp(y), 1e-12):
            raise SolveError(f"chamber law: the {name} decreases with pressure (by {dips.max():.3g}); "
                             "the law must be monotone")
    v, a = np.maximum.accumulate(v), np.maximum.accumulate(a)
    if np.any(np.diff(a) <= 0):
        raise SolveError("chamber law: the bend angle must increase strictly with pressure (it is inverted)")
    if not v[0] > 0:
        raise SolveError(f"chamber law: the cavity volume must be positive, got {v[0]} mL")
    length = float(length_mm) if length_mm is not None else float(tx[0])
    return CurveLaw(p, v, a, tx, tz, length, LawEnd(float(p[-1]), float(a[-1]), float(v[-1]), stop, reason))


def as_curve_law(law: ChamberLaw, p_max_kpa: float, samples: int = 600) -> CurveLaw:
    """``law`` itself when it is a :class:`CurveLaw`; any other :class:`ChamberLaw` sampled
    from 0 to 1.2 ``p_max_kpa`` (its solved range: a chamber never passes the supply)."""
    if isinstance(law, CurveLaw):
        return law
    top = 1.2 * max(float(p_max_kpa), 1.0)
    p = np.linspace(0.0, top, samples)
    tip_x, tip_z = law.tip_mm(p)
    return chamber_law_from_curve(p, law.volume_ml(p), law.bend_angle_deg(p), tip_x, tip_z,
                                  length_mm=float(np.asarray(tip_x, float).ravel()[0]), stop="sampled",
                                  reason=f"the law sampled up to {top:.4g} kPa")


def chamber_law_for(design, *, up_to_kpa: float | None = None, progress=None) -> CurveLaw:
    """The design's law from the FE's free-bending curve (no gravity): its characterisation
    (:func:`pnmold.physics.characterise.characterise`, cached; the templates' ship with pnmold),
    ending where the FE's curve ended (:class:`LawEnd`). ``up_to_kpa``: the pressure asked for
    (a supply); a characterisation that ended merely at its pressure cap below full bend and
    below it is extended by solving on with the FE
    (:func:`pnmold.physics.characterise.characterise_up_to`, cached)."""
    from pnmold.physics.characterise import characterise, characterise_up_to

    c = characterise(design, progress=progress) if up_to_kpa is None else characterise_up_to(
        design, up_to_kpa, progress=progress)
    return chamber_law_from_curve(c.pressure_kpa, c.cavity_volume_ml, c.bend_angle_deg, c.tip_x_mm,
                                  c.tip_z_mm, length_mm=design.length_mm, stop=c.how_ended,
                                  reason=c.end_reason)
