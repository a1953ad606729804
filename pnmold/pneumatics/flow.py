"""The flow laws of the restrictions, compiled (numba, nopython, cached): written once here.

:mod:`pnmold.pneumatics.gas` states the laws and makes the restriction elements; its
:class:`~pnmold.pneumatics.gas.Orifice` and :func:`~pnmold.pneumatics.gas.duct_mass_flow_kg_s`
call these functions, and so does the step model's right-hand side
(:mod:`pnmold.pneumatics.rates`). SI units; flows for p_up >= p_dn (the caller signs them).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb

#: ISO 6358-1:2013 / Simscape laminar pressure ratio
B_LAMINAR = 0.999
#: where the laminar friction factor 64/Re meets Blasius' 0.3164 Re^-1/4: Re = 1195
RE_CROSS = (64 / 0.3164) ** (1 / 0.75)


class DuctCoefficients(NamedTuple):
    """One duct's constants for :func:`duct_mass_flow` (SI): friction and minor losses
    written as p_up^2 - p_dn^2 = R T (laminar G + minor_loss G^2) below ``g_cross`` and
    R T (blasius G^1.75 + minor_loss G^2) above it, G the mass flux (kg/(s m^2))."""

    laminar: float  # 64 mu L / D^2
    blasius: float  # 0.3164 (mu / D)^(1/4) L / D
    minor_loss: float  # K, entry and exit losses
    g_cross: float  # mass flux at Re = RE_CROSS
    area_m2: float


@nb.njit(cache=True)
def orifice_mass_flow(choked_kg_per_s_pa: float, critical_ratio: float, p_up_pa: float, p_dn_pa: float) -> float:
    """ISO 6358 mass flow (kg/s) of an orifice for ``p_up_pa >= p_dn_pa``.

    ``choked_kg_per_s_pa`` is C rho0 sqrt(T0 / T_up) (the choked flow per upstream Pa):
    choked below the critical ratio b, Sanville's ellipse above it, linear in (1 - r) in
    the laminar zone r > ``B_LAMINAR`` (zero at equal pressures)."""
    r = p_dn_pa / p_up_pa
    if r < 0.0:
        r = 0.0
    elif r > 1.0:
        r = 1.0
    if r <= critical_ratio:
        shape = 1.0
    else:
        u = (min(r, B_LAMINAR) - critical_ratio) / (1.0 - critical_ratio)
        shape = math.sqrt(max(1.0 - u * u, 0.0))
        if r > B_LAMINAR:
            shape *= (1.0 - r) / (1.0 - B_LAMINAR)
    return choked_kg_per_s_pa * p_up_pa * shape


@nb.njit(cache=True)
def duct_flux(phi: float, laminar: float, blasius: float, minor_loss: float, g_cross: float) -> float:
    """The mass flux G >= 0 with G^2 (f(G) L / D + K) R T = phi R T, i.e. the root of
    ``laminar G + K G^2 = phi`` (a quadratic) or, above ``g_cross``, of ``blasius G^1.75 +
    K G^2 = phi``, by Newton from above on that convex, increasing function (monotone
    convergence)."""
    if phi <= 0.0:
        return 0.0
    g = 2.0 * phi / (laminar + math.sqrt(laminar * laminar + 4.0 * minor_loss * phi))
    if g <= g_cross:
        return g
    gt = math.inf
    if blasius > 0:
        gt = (phi / blasius) ** (1.0 / 1.75)
    if minor_loss > 0:
        gt = min(gt, math.sqrt(phi / minor_loss))
    for _ in range(60):
        g075 = gt ** 0.75
        step = (blasius * g075 * gt + minor_loss * gt * gt - phi) / (1.75 * blasius * g075 + 2.0 * minor_loss * gt)
        gt = gt - step
        if abs(step) / gt <= 1e-14:
            break
    return gt


@nb.njit(cache=True)
def duct_mass_flow(duct: DuctCoefficients, p_up_pa: float, p_dn_pa: float, rt: float) -> float:
    """Mass flow (kg/s) through a duct for ``p_up_pa >= p_dn_pa`` at gas constant times
    temperature ``rt`` (J/kg): the friction-limited flux, capped where the outlet reaches
    the isothermal choke (p_up^2 = G^2 R T (1 + f L / D + K)); the cap binds only when the
    capped law's left-hand side, increasing in G, exceeds p_up^2 / (R T) at the free flux."""
    up2 = p_up_pa * p_up_pa / rt
    g = duct_flux(up2 - p_dn_pa * p_dn_pa / rt, duct.laminar, duct.blasius, duct.minor_loss, duct.g_cross)
    friction = duct.laminar * g if g <= duct.g_cross else duct.blasius * g ** 1.75
    if friction + (duct.minor_loss + 1.0) * g * g > up2:
        g = min(g, duct_flux(up2, duct.laminar, duct.blasius, duct.minor_loss + 1.0, duct.g_cross))
    return duct.area_m2 * g
