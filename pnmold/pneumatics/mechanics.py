"""The bending mode of the actuator: inertia, pressure moment and damping (SI inside).

One generalised coordinate, the bend angle theta (rad) of the free end. The actuator is
taken to curl with constant curvature (the pressure moment is the same in every
chamber), so a point at arc length s = u L sits at L (sin(theta u) / theta,
-(1 - cos(theta u)) / theta). Lagrange's equation with the kinetic energy
(1/2) J(theta) theta'^2, J(theta) = m L^2 j(theta), j(theta) = int_0^1 |d rho / d theta|^2 du
(j(0) = 1/20, the cantilever's constant-curvature mode), gives::

    J(theta) theta'' + (1/2) J'(theta) theta'^2 + c theta' = k_p (p_mean - p_qs(theta))

The right-hand side is the virtual work of the bending moments for a virtual rotation of
the free end: the pressure moment k_p p, with k_p = (cavity cross-section) x (its
centroid's height above the paper) (the moment of the pressure on a section through a
chamber about the inextensible layer), less the elastic moment, which the quasi-static
law fixes: in equilibrium k_p p = M_el(theta), so M_el(theta) = k_p p_qs(theta), p_qs
the law's inverse (the angle's pressure). The model therefore reproduces the FE curve
exactly at rest and needs no separate bending stiffness. The small-signal natural
frequency about the rest state is omega_n = sqrt(k_p dp_qs/dtheta / J(theta_0)).

Assumed: the damping ratio (``DAMPING_RATIO`` = 0.2 about the rest state: silicone's
loss and air drag, an underdamped actuator as the fast PneuNets visibly are), the
neglect of the cross-sections' own rotary inertia and of the offset of the mass centroid
from the bottom face (about 1 % of J each for the templates), and the mass (the design's
elastomer volume times its density; the paper's volume counted as elastomer).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PchipInterpolator

from pnmold.errors import DesignError
from pnmold.pneumatics.law import Pieces

DAMPING_RATIO = 0.2  # assumed (see module docstring)
THETA_RANGE = (-2 * np.pi, 24 * np.pi)  # where j(theta) is tabulated


def _rho(u, theta):
    x = theta * u
    return u * np.sinc(x / np.pi), -u * (x / 2) * np.sinc(x / (2 * np.pi)) ** 2


def _inertia_table():
    """j(theta) on a grid, by Gauss-Legendre in u and central differences in theta."""
    u, w = np.polynomial.legendre.leggauss(48)
    u, w = (u + 1) / 2, w / 2
    thetas = np.linspace(*THETA_RANGE, 5201)  # 0 is a node
    h = 1e-5
    j = np.empty_like(thetas)
    for i, t in enumerate(thetas):
        xp, zp = _rho(u, t + h)
        xm, zm = _rho(u, t - h)
        j[i] = np.sum(w * (((xp - xm) / (2 * h)) ** 2 + ((zp - zm) / (2 * h)) ** 2))
    return PchipInterpolator(thetas, j, extrapolate=True)


@functools.cache
def _inertia_interpolants():
    table = _inertia_table()
    return table, table.derivative()


def inertia_pieces() -> Pieces:
    """j(theta) as :class:`~pnmold.pneumatics.law.Pieces` for compiled code: the same table,
    held at its end values (zero slope) outside ``THETA_RANGE``, as :func:`inertia_shape`."""
    j, _ = _inertia_interpolants()
    lo, hi = float(j(THETA_RANGE[0])), float(j(THETA_RANGE[1]))
    return Pieces(np.ascontiguousarray(j.x, float), np.ascontiguousarray(j.c, float), lo, hi, 0.0, 0.0)


def inertia_shape(theta_rad):
    """(j(theta), dj/dtheta): the dimensionless generalised mass of the curling mode
    (held at its end values outside ``THETA_RANGE``, far past full bend)."""
    j, dj = _inertia_interpolants()
    inside = np.clip(theta_rad, *THETA_RANGE)
    return j(inside), np.where(inside == theta_rad, dj(inside), 0.0)


@dataclass(frozen=True)
class BendingDynamics:
    """Inertia and drive of the bending mode: mass (kg), length (m), pressure moment (N m/Pa)."""

    mass_kg: float
    length_m: float
    moment_per_pa: float
    damping_ratio: float = DAMPING_RATIO

    def __post_init__(self):
        if not (self.mass_kg > 0 and self.length_m > 0 and self.moment_per_pa > 0 and self.damping_ratio >= 0):
            raise DesignError("bending", f"the bending mode needs a positive mass, length and moment arm and a "
                              f"damping ratio >= 0: {self}")

    @classmethod
    def from_design(cls, design, damping_ratio: float = DAMPING_RATIO) -> BendingDynamics:
        return cls(design.elastomer_mass_g * 1e-3, design.length_mm * 1e-3,
                   pressure_moment_m3(design), damping_ratio)

    def inertia_kg_m2(self, theta_rad):
        j, dj = inertia_shape(theta_rad)
        scale = self.mass_kg * self.length_m**2
        return scale * j, scale * dj

    def stiffness_nm_per_rad(self, dp_dtheta_pa_per_rad: float) -> float:
        return self.moment_per_pa * dp_dtheta_pa_per_rad

    def about_rest(self, theta0_rad: float, dp_dtheta_pa_per_rad: float) -> tuple[float, float, float]:
        """(stiffness N m/rad, viscous damping N m s/rad, natural frequency Hz) about the rest
        state: the damping c gives the damping ratio, c = 2 zeta sqrt(k J(theta0))."""
        k = self.stiffness_nm_per_rad(dp_dtheta_pa_per_rad)
        j0 = float(self.inertia_kg_m2(theta0_rad)[0])
        return k, 2 * self.damping_ratio * math.sqrt(k * j0), math.sqrt(k / j0) / (2 * math.pi)

    def natural_frequency_hz(self, theta0_rad: float, dp_dtheta_pa_per_rad: float) -> float:
        return self.about_rest(theta0_rad, dp_dtheta_pa_per_rad)[2]

    def damping_nms(self, theta0_rad: float, dp_dtheta_pa_per_rad: float) -> float:
        """Viscous coefficient c (N m s/rad) giving the damping ratio about the rest state."""
        return self.about_rest(theta0_rad, dp_dtheta_pa_per_rad)[1]


def pressure_moment_m3(design) -> float:
    """k_p = cavity cross-section x centroid height above the paper's mid-plane (m^3)."""
    c = design.chambers
    area = c.width_mm * c.height_mm
    lever = design.top_z0_mm + c.height_mm / 2 - design.sheet_z_mm - design.paper.thickness_mm / 2
    return area * lever * 1e-9
