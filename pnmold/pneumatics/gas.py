"""Compressible flow of air through the restrictions of a pneumatic line (SI units inside).

Air is an ideal gas (``R_AIR``, ``GAMMA``). Two restriction elements:

* :class:`Orifice` -- a valve or any short restriction, by the ISO 6358 flow-rate model
  (Sanville's elliptic law, as in ISO 6358:1989 and ISO 6358-1:2013 with subsonic index
  m = 0.5): sonic conductance C [m^3/(s Pa)] and critical pressure ratio b. With
  ``r = p_dn / p_up``::

      choked      r <= b          q = C rho0 p_up sqrt(T0 / T_up)
      subsonic    b < r <= b_lam  q = C rho0 p_up sqrt(T0 / T_up) sqrt(1 - ((r - b) / (1 - b))^2)
      laminar     r > b_lam       linear in (1 - r), continuous at b_lam = 0.999

  rho0 = 1.185 kg/m^3 and T0 = 293.15 K are the ISO 8778 (ANR) reference. The laminar
  zone (ratio 0.999, as in MathWorks Simscape's "Orifice ISO 6358" block) removes the
  infinite slope of the elliptic law at r -> 1, so pressures settle smoothly.
  An effective orifice diameter d (discharge coefficient included) converts to C by the
  ideal-nozzle choked flow: C = (pi d^2 / 4) sqrt(gamma / (R T0)) (2 / (gamma + 1))^((gamma + 1) /
  (2 (gamma - 1))) / rho0, i.e. C ~ 0.2 dm^3/(s bar) per mm^2, the familiar S ~ 5 C.

* :class:`Duct` -- tubing or the design's connecting channel: quasi-steady isothermal
  compressible flow with wall friction and minor losses (a lumped line)::

      p_up^2 - p_dn^2 = G^2 R T (f(Re) L / D + K),      G = mass flux, Re = G D / mu

  with f = max(64 / Re, 0.3164 Re^-1/4) (Hagen-Poiseuille, then Blasius; continuous at
  Re = 1195), K the entry/exit losses. The acceleration term of the isothermal pipe
  equation is left out except at choking: the flux cannot exceed the isothermal limit at
  the outlet, G = p_out / sqrt(R T) (Mach 1/sqrt(gamma); Shapiro, *The Dynamics and
  Thermodynamics of Compressible Fluid Flow*, 1953, ch. 6), which gives
  p_up^2 = G^2 R T (1 + f L / D + K). Laminar: the compressible Hagen-Poiseuille law
  q = pi D^4 (p_up^2 - p_dn^2) / (256 mu L R T) when K = 0 (the mean density times
  the incompressible law).

The laws themselves are compiled once in :mod:`pnmold.pneumatics.flow`; the elements here
hold their constants and evaluate them through it. Flows are signed (positive from the
first node to the second); upstream properties are those of the node with the higher
pressure. ``slpm`` is standard litres per minute at
0 degC and 101.325 kPa (the convention of thermal mass-flow sensors such as Honeywell's
AWM series used in the supplement's rapid-actuation set-up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pnmold.errors import UsageError
from pnmold.pneumatics.flow import B_LAMINAR, RE_CROSS, DuctCoefficients, duct_mass_flow, orifice_mass_flow

R_AIR = 287.05  # J/(kg K), dry air
GAMMA = 1.4  # ratio of specific heats of air
MU_AIR = 1.81e-5  # Pa s, dynamic viscosity of air at 20 degC
T_REF_K = 293.15  # ISO 8778 (ANR) reference temperature, also the default gas temperature
RHO_REF = 1.185  # kg/m^3, ISO 8778 (ANR) reference density (100 kPa, 20 degC, 65 % RH)
P_ATM_PA = 101_325.0
T_STD_K = 273.15  # standard conditions of "standard litres per minute"
RHO_STD = P_ATM_PA / (R_AIR * T_STD_K)  # 1.292 kg/m^3
#: choked mass flux of an ideal nozzle per unit upstream pressure and sqrt(T): kg/(s m^2 Pa) * sqrt(K)
_NOZZLE = math.sqrt(GAMMA / R_AIR) * (2 / (GAMMA + 1)) ** ((GAMMA + 1) / (2 * (GAMMA - 1)))


def slpm_from_kg_s(q_kg_s):
    """Mass flow (kg/s) -> standard litres per minute (0 degC, 101.325 kPa)."""
    return np.asarray(q_kg_s) / RHO_STD * 60_000.0


@dataclass(frozen=True)
class Orifice:
    """An ISO 6358 restriction: sonic conductance C (m^3/(s Pa)) and critical ratio b."""

    conductance_m3_per_s_pa: float
    critical_ratio: float = 0.5

    def __post_init__(self):
        if not self.conductance_m3_per_s_pa > 0:
            raise UsageError(f"orifice: the sonic conductance must be > 0, got {self.conductance_m3_per_s_pa}")
        if not 0 <= self.critical_ratio < B_LAMINAR:
            raise UsageError(f"orifice: the critical pressure ratio b must be in [0, {B_LAMINAR}), "
                             f"got {self.critical_ratio}")

    @classmethod
    def from_diameter_mm(cls, diameter_mm: float, critical_ratio: float = 0.5) -> Orifice:
        """From an effective orifice diameter (discharge coefficient included)."""
        area = math.pi * (diameter_mm * 1e-3) ** 2 / 4
        return cls(area * _NOZZLE / math.sqrt(T_REF_K) / RHO_REF, critical_ratio)

    @classmethod
    def from_l_per_s_bar(cls, conductance_l_per_s_bar: float, critical_ratio: float = 0.5) -> Orifice:
        """From a datasheet sonic conductance in dm^3/(s bar) (ANR)."""
        return cls(conductance_l_per_s_bar * 1e-3 / 1e5, critical_ratio)

    @property
    def conductance_l_per_s_bar(self) -> float:
        return self.conductance_m3_per_s_pa * 1e8

    def scaled(self, factor: float) -> Orifice:
        return Orifice(self.conductance_m3_per_s_pa * factor, self.critical_ratio)

    def choked_kg_per_s_pa(self, t_up_k=T_REF_K):
        """C rho0 sqrt(T0 / T_up): the choked mass flow per upstream Pa (kg/(s Pa))."""
        return self.conductance_m3_per_s_pa * RHO_REF * np.sqrt(T_REF_K / np.asarray(t_up_k, float))

    def mass_flow_kg_s(self, p_up_pa, p_dn_pa, t_up_k=T_REF_K):
        """Mass flow (kg/s) for p_up >= p_dn (arrays broadcast), by
        :func:`pnmold.pneumatics.flow.orifice_mass_flow`."""
        return _orifice_flows(self.choked_kg_per_s_pa(t_up_k), self.critical_ratio, p_up_pa, p_dn_pa)


@dataclass(frozen=True)
class Duct:
    """A tube or channel: length, hydraulic diameter, flow area, minor-loss coefficient K."""

    length_m: float
    diameter_m: float
    area_m2: float
    minor_loss: float = 0.0

    def __post_init__(self):
        if not (self.length_m >= 0 and self.diameter_m > 0 and self.area_m2 > 0 and self.minor_loss >= 0):
            raise UsageError(f"duct: needs length >= 0, diameter > 0, area > 0, K >= 0: {self}")
        if self.length_m == 0 and self.minor_loss == 0:
            raise UsageError("duct: a duct of zero length needs a minor loss K > 0")

    @classmethod
    def tube(cls, length_mm: float, id_mm: float, minor_loss: float = 0.5) -> Duct:
        """Round tubing (entry loss 0.5 by default)."""
        d = id_mm * 1e-3
        return cls(length_mm * 1e-3, d, math.pi * d * d / 4, minor_loss)

    @classmethod
    def rectangular(cls, length_mm: float, height_mm: float, width_mm: float, minor_loss: float = 1.5) -> Duct:
        """A rectangular channel (hydraulic diameter 2hw/(h+w); contraction 0.5 + expansion 1.0)."""
        h, w = height_mm * 1e-3, width_mm * 1e-3
        return cls(length_mm * 1e-3, 2 * h * w / (h + w), h * w, minor_loss)

    @property
    def volume_m3(self) -> float:
        return self.length_m * self.area_m2

    def coefficients(self, mu: float = MU_AIR) -> DuctCoefficients:
        """The constants of :func:`pnmold.pneumatics.flow.duct_mass_flow` for gas of viscosity ``mu``."""
        d, length = self.diameter_m, self.length_m
        return DuctCoefficients(64 * mu * length / d**2, 0.3164 * (mu / d) ** 0.25 * length / d, self.minor_loss,
                                RE_CROSS * mu / d, self.area_m2)


_orifice_flows = np.vectorize(orifice_mass_flow, otypes=[float])


def duct_mass_flow_kg_s(p_up_pa, p_dn_pa, t_up_k, ducts: list[Duct] | tuple[Duct, ...]) -> np.ndarray:
    """Mass flow (kg/s) through each of ``ducts`` for p_up >= p_dn (arrays, one entry per duct),
    by :func:`pnmold.pneumatics.flow.duct_mass_flow`."""
    n = len(ducts)
    p_up, p_dn, t_up = (np.broadcast_to(np.asarray(x, float), (n,)) for x in (p_up_pa, p_dn_pa, t_up_k))
    return np.array([duct_mass_flow(d.coefficients(), p_up[i], p_dn[i], R_AIR * t_up[i])
                     for i, d in enumerate(ducts)], float)
