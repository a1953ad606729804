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

Flows are signed (positive from the first node to the second); upstream properties are
those of the node with the higher pressure. ``slpm`` is standard litres per minute at
0 degC and 101.325 kPa (the convention of thermal mass-flow sensors such as Honeywell's
AWM series used in the supplement's rapid-actuation set-up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

R_AIR = 287.05  # J/(kg K), dry air
GAMMA = 1.4  # ratio of specific heats of air
CP_AIR = GAMMA * R_AIR / (GAMMA - 1)
CV_AIR = R_AIR / (GAMMA - 1)
MU_AIR = 1.81e-5  # Pa s, dynamic viscosity of air at 20 degC
T_REF_K = 293.15  # ISO 8778 (ANR) reference temperature, also the default gas temperature
RHO_REF = 1.185  # kg/m^3, ISO 8778 (ANR) reference density (100 kPa, 20 degC, 65 % RH)
P_ATM_PA = 101_325.0
T_STD_K = 273.15  # standard conditions of "standard litres per minute"
RHO_STD = P_ATM_PA / (R_AIR * T_STD_K)  # 1.292 kg/m^3
B_LAMINAR = 0.999  # ISO 6358-1:2013 / Simscape laminar pressure ratio
RE_CROSS = (64 / 0.3164) ** (1 / 0.75)  # where 64/Re meets Blasius: 1195
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
            raise ValueError(f"sonic conductance must be > 0, got {self.conductance_m3_per_s_pa}")
        if not 0 <= self.critical_ratio < B_LAMINAR:
            raise ValueError(f"critical pressure ratio b must be in [0, {B_LAMINAR}), got {self.critical_ratio}")

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

    def mass_flow_kg_s(self, p_up_pa, p_dn_pa, t_up_k=T_REF_K):
        """Mass flow (kg/s) for p_up >= p_dn (arrays broadcast)."""
        p_up, p_dn = np.asarray(p_up_pa, float), np.asarray(p_dn_pa, float)
        b = self.critical_ratio
        choked = self.conductance_m3_per_s_pa * RHO_REF * p_up * np.sqrt(T_REF_K / np.asarray(t_up_k, float))
        r = np.clip(p_dn / p_up, 0.0, 1.0)
        shape = np.sqrt(np.clip(1 - ((np.minimum(r, B_LAMINAR) - b) / (1 - b)) ** 2, 0.0, 1.0))
        shape = np.where(r <= b, 1.0, shape)
        shape = np.where(r > B_LAMINAR, shape * (1 - r) / (1 - B_LAMINAR), shape)
        return choked * shape


@dataclass(frozen=True)
class Duct:
    """A tube or channel: length, hydraulic diameter, flow area, minor-loss coefficient K."""

    length_m: float
    diameter_m: float
    area_m2: float
    minor_loss: float = 0.0

    def __post_init__(self):
        if not (self.length_m >= 0 and self.diameter_m > 0 and self.area_m2 > 0 and self.minor_loss >= 0):
            raise ValueError(f"duct needs length >= 0, diameter > 0, area > 0, K >= 0: {self}")
        if self.length_m == 0 and self.minor_loss == 0:
            raise ValueError("a duct of zero length needs a minor loss K > 0")

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


class DuctSet:
    """Several ducts with their constants precomputed, for fast vectorised flows."""

    def __init__(self, ducts: list[Duct] | tuple[Duct, ...], mu: float = MU_AIR):
        length = np.array([d.length_m for d in ducts], float)
        diameter = np.array([d.diameter_m for d in ducts], float)
        k = np.array([d.minor_loss for d in ducts], float)
        self.n = len(ducts)
        self.area = np.array([d.area_m2 for d in ducts], float)
        # friction-limited and choke-limited flux solved together: 2n entries
        self.a = np.tile(64 * mu * length / diameter**2, 2)  # laminar: phi = a G + K G^2
        self.c = np.tile(0.3164 * (mu / diameter) ** 0.25 * length / diameter, 2)  # Blasius: c G^1.75 + K G^2
        self.k = np.concatenate([k, k + 1.0])
        self.g_cross = np.tile(RE_CROSS * mu / diameter, 2)

    def mass_flow_kg_s(self, p_up_pa: np.ndarray, p_dn_pa: np.ndarray, t_up_k: np.ndarray) -> np.ndarray:
        """Mass flow (kg/s) through each duct for p_up >= p_dn, with the choke limit."""
        rt = R_AIR * t_up_k
        up2 = p_up_pa * p_up_pa / rt
        phi = np.concatenate([up2 - p_dn_pa * p_dn_pa / rt, up2])
        g = self._flux(phi)
        return self.area * np.minimum(g[:self.n], g[self.n:])

    def _flux(self, phi: np.ndarray) -> np.ndarray:
        """G >= 0 with G^2 (f(G) L/D + K) = phi: the laminar branch (f = 64/Re) is a
        quadratic; the turbulent one (Blasius) is solved by Newton from above on the
        convex, increasing left-hand side (monotone convergence)."""
        a, k = self.a, self.k
        g = 2 * phi / (a + np.sqrt(a * a + 4 * k * phi))
        turb = np.flatnonzero(g > self.g_cross)
        if len(turb) == 0:
            return g
        c, kt, target = self.c[turb], k[turb], phi[turb]
        with np.errstate(divide="ignore"):
            gt = np.minimum(np.where(c > 0, (target / np.maximum(c, 1e-300)) ** (1 / 1.75), np.inf),
                            np.where(kt > 0, np.sqrt(target / np.maximum(kt, 1e-300)), np.inf))
        for _ in range(60):
            g075 = gt**0.75
            step = (c * g075 * gt + kt * gt * gt - target) / (1.75 * c * g075 + 2 * kt * gt)
            gt = gt - step
            if np.max(np.abs(step) / gt) <= 1e-14:
                break
        g[turb] = gt
        return g


def duct_mass_flow_kg_s(p_up_pa, p_dn_pa, t_up_k, ducts: list[Duct] | tuple[Duct, ...]):
    """Mass flow (kg/s) through ``ducts`` for p_up >= p_dn (arrays, one entry per duct)."""
    n = len(ducts)
    return DuctSet(ducts).mass_flow_kg_s(*(np.broadcast_to(np.asarray(x, float), (n,)) for x in
                                           (p_up_pa, p_dn_pa, t_up_k)))
