"""The step model's right-hand side, compiled (numba, nopython, cached): written once here.

The network of :mod:`pnmold.pneumatics.network` lowered to arrays (:class:`NetworkArrays`)
and the bending mode of :mod:`pnmold.pneumatics.mechanics` (:class:`ModeArrays`) are read
by name. The state vector (SI)::

    y = [p_0 .. p_(n-1), theta, omega, metered]

node pressures (Pa, absolute), the bend angle (rad) and its rate (rad/s), and the gas that
has passed the flow meter (kg, signed into the line: the integral of the flow through the
orifices that join the line to the supply or the atmosphere). Per node, isothermal::

    dp/dt (V + p dV/dp) = R T q_net

q_net the net mass inflow, V the node's rigid volume plus its share of the chamber law's
cavity volume. The bending mode (:mod:`pnmold.pneumatics.mechanics`)::

    J(theta) theta'' = k_p (p_mean - s p_qs(theta)) - c theta' - J'(theta) theta'^2 / 2 - contact

p_mean the chamber-weighted gauge pressure, p_qs the law's pressure for the angle, s the
modulus scale (the law at p is the nominal law at p / s), the contact stop (stiffness and
critical damping) beyond full bend. Valve ``phase``: 0 the supply orifices are open, 1 the
vent orifices, -1 none (before the valve opens).

:func:`rates` is the whole right-hand side (the TR-BDF2 of :mod:`pnmold.pneumatics.trbdf2`
and the SciPy Radau reference of the tests both integrate it); :func:`jacobian` its
derivative by grouped finite differences on the network's pattern.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from pnmold.pneumatics.flow import DuctCoefficients, duct_mass_flow, orifice_mass_flow
from pnmold.pneumatics.law import Pieces


class OrificeEdges(NamedTuple):
    """The orifices: nodes a -> b (index n is the supply, n + 1 the atmosphere), the choked
    flow per upstream Pa C rho0 sqrt(T0 / T) (kg/(s Pa)), the critical ratio, the phase in
    which each is open."""

    node_a: np.ndarray
    node_b: np.ndarray
    choked_kg_per_s_pa: np.ndarray
    critical_ratio: np.ndarray
    phase: np.ndarray


class DuctEdges(NamedTuple):
    """The ducts: nodes a -> b and the constants of :class:`~pnmold.pneumatics.flow.DuctCoefficients`."""

    node_a: np.ndarray
    node_b: np.ndarray
    laminar: np.ndarray
    blasius: np.ndarray
    minor_loss: np.ndarray
    g_cross: np.ndarray
    area_m2: np.ndarray


class NetworkArrays(NamedTuple):
    """A pneumatic network lowered for compiled code (:meth:`pnmold.pneumatics.network.Network.lower`)."""

    rigid_m3: np.ndarray  # per node
    law_share: np.ndarray  # per node: share of the chamber law's cavity volume
    volume: Pieces  # the nominal cavity volume (mL) against gauge kPa
    pressure_scale: float  # modulus scale s
    orifices: OrificeEdges
    ducts: DuctEdges
    boundary_pa: np.ndarray  # [supply, atmosphere], absolute
    p_atm_pa: float
    rt: float  # R T (J/kg)
    flow_scale: float  # 1 / (1 + flow_restriction)
    depends: np.ndarray  # (n, n) bool: node i's rate depends on node j's pressure
    colour: np.ndarray  # per node: its finite-difference group (no rate depends on two of a group)
    colours: int


class ModeArrays(NamedTuple):
    """The bending mode for compiled code; ``active`` False: theta and omega stay put."""

    active: bool
    moment_per_pa: float  # k_p (N m / Pa)
    inertia_kg_m2: float  # m L^2
    inertia_shape: Pieces  # j(theta)
    hold: Pieces  # the nominal law's pressure (gauge kPa) against the bend angle (deg)
    pressure_scale: float  # modulus scale s
    damping_nms: float
    contact_nm_per_rad: float
    contact_nms: float
    full_bend_rad: float
    chamber_weight: np.ndarray  # per node, summing to 1: p_mean = sum w_i (p_i - p_atm)
    p_atm_pa: float


@nb.njit(cache=True, inline="always")
def evaluate(pieces: Pieces, x: float) -> tuple[float, float]:
    """Value and slope of :class:`~pnmold.pneumatics.law.Pieces` at ``x``."""
    xs = pieces.breaks
    if x < xs[0]:
        return pieces.value_lo + pieces.slope_lo * (x - xs[0]), pieces.slope_lo
    if x > xs[-1]:
        return pieces.value_hi + pieces.slope_hi * (x - xs[-1]), pieces.slope_hi
    k = np.searchsorted(xs, x, side="right") - 1
    if k > xs.size - 2:
        k = xs.size - 2
    dx = x - xs[k]
    cs = pieces.coefficients
    c0, c1, c2, c3 = cs[0, k], cs[1, k], cs[2, k], cs[3, k]
    return ((c0 * dx + c1) * dx + c2) * dx + c3, (3.0 * c0 * dx + 2.0 * c1) * dx + c2


@nb.njit(cache=True)
def _at(p, boundary, node):
    """The pressure of a node or of a boundary (index n: supply, n + 1: atmosphere)."""
    return p[node] if node < p.size else boundary[node - p.size]


@nb.njit(cache=True)
def _book(out, a, b, q):
    """Book the mass flow ``q`` (a -> b) on the nodes; returns its part that enters the line
    from a boundary (what the flow meter reads)."""
    n = out.size
    if a < n:
        out[a] -= q
    if b < n:
        out[b] += q
    if a >= n > b:
        return q
    if b >= n > a:
        return -q
    return 0.0


@nb.njit(cache=True)
def pneumatic_rates(p: np.ndarray, phase: int, net: NetworkArrays, out: np.ndarray, meter_only: bool = False) -> float:
    """dp/dt of every node into ``out``; returns the metered mass flow (kg/s, into the line).
    ``meter_only``: only the flow meter's reading (``out`` is left partial).

    (The network's fields are read into locals once: handing the whole tuple to a helper
    per node or edge would cost more than the physics.)"""
    scale, rt, boundary = net.flow_scale, net.rt, net.boundary_pa
    out[:] = 0.0
    meter = 0.0
    o = net.orifices
    for e in range(o.node_a.size):
        if o.phase[e] != phase:
            continue
        a, b = o.node_a[e], o.node_b[e]
        if meter_only and a < p.size and b < p.size:
            continue
        pa, pb = _at(p, boundary, a), _at(p, boundary, b)
        choked, ratio = o.choked_kg_per_s_pa[e], o.critical_ratio[e]
        q = orifice_mass_flow(choked, ratio, pa, pb) if pa >= pb else -orifice_mass_flow(choked, ratio, pb, pa)
        meter += _book(out, a, b, scale * q)
    d = net.ducts
    for e in range(d.node_a.size):
        a, b = d.node_a[e], d.node_b[e]
        if meter_only and a < p.size and b < p.size:
            continue
        pa, pb = _at(p, boundary, a), _at(p, boundary, b)
        duct = DuctCoefficients(d.laminar[e], d.blasius[e], d.minor_loss[e], d.g_cross[e], d.area_m2[e])
        q = duct_mass_flow(duct, pa, pb, rt) if pa >= pb else -duct_mass_flow(duct, pb, pa, rt)
        meter += _book(out, a, b, scale * q)
    if meter_only:
        return meter
    rigid, share, volume, s, p_atm = net.rigid_m3, net.law_share, net.volume, net.pressure_scale, net.p_atm_pa
    for i in range(p.size):
        v, dv = rigid[i], 0.0
        if share[i] > 0:
            vol, comp = evaluate(volume, (p[i] - p_atm) / 1000.0 / s)
            v += share[i] * vol * 1e-6
            dv = share[i] * comp / s * 1e-9
        out[i] = rt * out[i] / (v + p[i] * dv)
    return meter


@nb.njit(cache=True)
def mode_acceleration(p: np.ndarray, theta: float, omega: float, mode: ModeArrays) -> tuple[float, float]:
    """(d omega / dt, J(theta)) of the bending mode at the node pressures ``p``."""
    if not mode.active:
        return 0.0, 1.0
    weight, p_atm = mode.chamber_weight, mode.p_atm_pa
    p_mean = 0.0
    for i in range(p.size):
        p_mean += weight[i] * (p[i] - p_atm)
    hold, _ = evaluate(mode.hold, math.degrees(theta))
    hold *= mode.pressure_scale * 1000.0
    j, dj = evaluate(mode.inertia_shape, theta)
    j *= mode.inertia_kg_m2
    dj *= mode.inertia_kg_m2
    moment = mode.moment_per_pa * (p_mean - hold) - mode.damping_nms * omega - 0.5 * dj * omega * omega
    if theta > mode.full_bend_rad:
        moment -= mode.contact_nm_per_rad * (theta - mode.full_bend_rad) + mode.contact_nms * omega
    return moment / j, j


@nb.njit(cache=True)
def rates(y: np.ndarray, phase: int, net: NetworkArrays, mode: ModeArrays, f: np.ndarray) -> None:
    """The whole right-hand side dy/dt into ``f`` (the module docstring's state)."""
    n = y.size - 3
    f[n + 2] = pneumatic_rates(y[:n], phase, net, f[:n])
    f[n] = y[n + 1]
    f[n + 1], _ = mode_acceleration(y[:n], y[n], y[n + 1], mode)


@nb.njit(cache=True)
def jacobian(y: np.ndarray, f0: np.ndarray, phase: int, net: NetworkArrays, mode: ModeArrays, atol: np.ndarray,
             jpp: np.ndarray, mech: np.ndarray) -> None:
    """The Jacobian of :func:`rates` but for the metered gas's row (a quadrature, nothing
    depends on it): the pressure block ``jpp`` (n x n) by one finite difference per colour
    group, and ``mech`` = (d omega'/d theta, d omega'/d omega, k_p / J) (the bending row's
    pressure derivatives are the chamber weights times the last, exactly)."""
    n = y.size - 3
    p = y[:n].copy()
    fp = np.empty(n)
    hs = np.zeros(n)
    colour, depends = net.colour, net.depends
    for g in range(net.colours):
        for j in range(n):
            if colour[j] == g:
                hs[j] = 1e-7 * max(abs(p[j]), 1e3 * atol[j])
                p[j] += hs[j]
        pneumatic_rates(p, phase, net, fp)
        for j in range(n):
            if colour[j] != g:
                continue
            p[j] -= hs[j]
            for i in range(n):
                jpp[i, j] = (fp[i] - f0[i]) / hs[j] if depends[i, j] else 0.0
    theta, omega = y[n], y[n + 1]
    a0 = f0[n + 1]
    h = 1e-7 * max(abs(theta), 1.0)
    a1, j = mode_acceleration(y[:n], theta + h, omega, mode)
    mech[0] = (a1 - a0) / h
    h = 1e-7 * max(abs(omega), 1.0)
    a1, j = mode_acceleration(y[:n], theta, omega + h, mode)
    mech[1] = (a1 - a0) / h
    _, j = mode_acceleration(y[:n], theta, omega, mode)
    mech[2] = mode.moment_per_pa / j if mode.active else 0.0


@nb.njit(cache=True)
def observe(states: np.ndarray, phase_rows: np.ndarray, net: NetworkArrays) -> tuple[np.ndarray, np.ndarray]:
    """Per output row: the metered mass flow (kg/s) with that row's valve phase, and the
    cavity volume (mL: the law's share of every node)."""
    m, n = states.shape[0], states.shape[1] - 3
    flow, cavity = np.zeros(m), np.zeros(m)
    f = np.empty(n)
    share, volume, s, p_atm = net.law_share, net.volume, net.pressure_scale, net.p_atm_pa
    for k in range(m):
        flow[k] = pneumatic_rates(states[k, :n], phase_rows[k], net, f, True)
        v = 0.0
        for i in range(n):
            if share[i] > 0:
                vol, _ = evaluate(volume, (states[k, i] - p_atm) / 1000.0 / s)
                v += share[i] * vol
        cavity[k] = v
    return flow, cavity
