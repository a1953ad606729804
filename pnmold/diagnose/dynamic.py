"""The step response as the diagnosis's forward model (``step`` recordings).

A diagnosis evaluates its model hundreds of times, so the step model of
:mod:`pnmold.pneumatics` (scipy's Radau on a Python right-hand side: seconds per run) is
compiled here (numba) with the same equations, laws and constants:

* the network of :func:`pnmold.pneumatics.network.bench_network` (isothermal): supply and
  vent valves (ISO 6358 orifices), the tubing and the design's channel as ducts
  (Hagen-Poiseuille / Blasius with the choke limit), the inlet node with the
  ``dead_volume`` effect's volume, the N chambers each taking 1/N of the FE chamber law;
  every conductance divided by 1 + ``flow_restriction``;
* the bending mode of :mod:`pnmold.pneumatics.mechanics` (inertia of the curling
  actuator, pressure moment, damping ratio, the contact stop at 360 degrees);
* the chamber law's PCHIP pieces taken from :class:`~pnmold.pneumatics.law.CurveLaw`
  (the same polynomials, not a re-fit), with the nominal ``modulus_scale`` s as the
  exact scaling of an elastomer whose constants all scale by s: the law at pressure p is
  the nominal law at p / s.

Time integration: TR-BDF2 (Bank et al. 1985; the ESDIRK form with Hosea & Shampine's
embedded third-order error estimate, filtered through the iteration matrix), adaptive,
with a Jacobian that exploits the network's chain (tridiagonal pressures, the bending mode
driven by the mean chamber pressure), exact landing on every valve switch, and cubic
Hermite output at the recording's own times. Measured against ``simulate_step`` (Radau,
rtol 1e-7) in ``tests/test_diagnose_step.py``.

The protocol comes from the recording: the supply level is the median of ``supply_kpa``
while the supply valve is open (rows at least half the peak); the valve opens at the first
such row and every later fall below half the level vents it (the vent valve opens), every
rise opens the supply again. The bench's nominal description is read from the
metadata when given (``tubing_length_mm``, ``tubing_id_mm``, ``valve_orifice_mm`` or
``valve_sonic_conductance``, ``valve_critical_ratio``; ``pnmold simulate --dynamic
--recording`` writes the first two), else the defaults of ``pnmold simulate --dynamic``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numba as nb
import numpy as np

from pnmold.errors import RecordingError, SolveError
from pnmold.pneumatics.gas import B_LAMINAR, MU_AIR, P_ATM_PA, R_AIR, RE_CROSS, RHO_REF, RHO_STD, T_REF_K, Orifice
from pnmold.pneumatics.network import (
    TUBING_LENGTH_MM,
    VALVE_CRITICAL_RATIO,
    VALVE_ORIFICE_MM,
    VALVE_VOLUME_ML,
    Duct,
)

#: columns the step model predicts (recording units)
COLUMNS = ("pressure_kpa", "flow_slpm", "bend_angle_deg", "pressure_far_kpa", "volume_ml")
#: tolerances of the adaptive integration (relative; absolute per state kind: Pa, rad, rad/s)
RTOL = 1e-6
ATOL_PA, ATOL_RAD, ATOL_RAD_S = 1.0, 1e-5, 1e-3
FIRST_STEP_S = 1e-6  # each valve phase starts with a jump in the flows (as the Radau model)
MAX_STEPS = 200_000
FULL_BEND_RAD = math.radians(360.0)
CONTACT_MOMENT_FACTOR, CONTACT_DEPTH_DEG = 2.0, 1.0  # as pnmold.pneumatics.dynamics


# -- the compiled model -----------------------------------------------------------------
@nb.njit(cache=True)
def _ppoly(x, xs, cs):
    """Value and slope of a piecewise cubic (scipy PPoly layout) at x inside [xs[0], xs[-1]]."""
    k = np.searchsorted(xs, x, side="right") - 1
    if k < 0:
        k = 0
    elif k > xs.size - 2:
        k = xs.size - 2
    dx = x - xs[k]
    c0, c1, c2, c3 = cs[0, k], cs[1, k], cs[2, k], cs[3, k]
    return ((c0 * dx + c1) * dx + c2) * dx + c3, (3.0 * c0 * dx + 2.0 * c1) * dx + c2


@nb.njit(cache=True)
def _linear(x, xs, cs, ends):
    """pnmold.pneumatics.law._Linear: PCHIP inside, the end secants outside. ends = (y0, yn, slope_lo, slope_hi)."""
    if x < xs[0]:
        return ends[0] + ends[2] * (x - xs[0]), ends[2]
    if x > xs[-1]:
        return ends[1] + ends[3] * (x - xs[-1]), ends[3]
    return _ppoly(x, xs, cs)


@nb.njit(cache=True)
def _orifice(cond, b, p_up, p_dn):
    """ISO 6358 mass flow (gas.Orifice.mass_flow_kg_s, isothermal) for p_up >= p_dn; cond = C rho0 sqrt(T0/T)."""
    r = p_dn / p_up
    if r < 0.0:
        r = 0.0
    elif r > 1.0:
        r = 1.0
    if r <= b:
        shape = 1.0
    else:
        u = (min(r, B_LAMINAR) - b) / (1.0 - b)
        shape = math.sqrt(max(1.0 - u * u, 0.0))
        if r > B_LAMINAR:
            shape *= (1.0 - r) / (1.0 - B_LAMINAR)
    return cond * p_up * shape


@nb.njit(cache=True)
def _flux(phi, a, c, k, g_cross):
    """gas.DuctSet._flux for one duct: G >= 0 with G^2 (f(G) L/D + K) = phi."""
    g = 2.0 * phi / (a + math.sqrt(a * a + 4.0 * k * phi))
    if g <= g_cross:
        return g
    gt = math.inf
    if c > 0:
        gt = (phi / c) ** (1.0 / 1.75)
    if k > 0:
        gt = min(gt, math.sqrt(phi / k))
    for _ in range(60):
        g075 = gt ** 0.75
        step = (c * g075 * gt + k * gt * gt - phi) / (1.75 * c * g075 + 2.0 * k * gt)
        gt = gt - step
        if abs(step) / gt <= 1e-14:
            break
    return gt


@nb.njit(cache=True)
def _metered(p0, phase, sc):
    """Mass flow into the line through the open valve (signed; the flow meter's reading)."""
    scale = sc[7]
    if phase == 0:
        if sc[2] >= p0:
            return scale * _orifice(sc[3], sc[4], sc[2], p0)
        return -scale * _orifice(sc[3], sc[4], p0, sc[2])
    if p0 >= sc[1]:
        return -scale * _orifice(sc[5], sc[6], p0, sc[1])
    return scale * _orifice(sc[5], sc[6], sc[1], p0)


@nb.njit(cache=True)
def _pneumatics(p, phase, rigid, share, vx, vc, vends, da, dc, dk, dg, darea, sc, out):
    """dp/dt of every node (out) and the metered mass flow (returned); isothermal network.

    sc: 0 R T, 1 p_atm, 2 p_supply, 3 supply cond, 4 supply b, 5 vent cond, 6 vent b,
    7 flow scale, 8 modulus scale."""
    n = p.size
    rt, p_atm, scale, s = sc[0], sc[1], sc[7], sc[8]
    for i in range(n):
        out[i] = 0.0
    meter = _metered(p[0], phase, sc)
    out[0] += meter
    for j in range(n - 1):  # duct j joins node j to node j + 1
        pa, pb = p[j], p[j + 1]
        up, dn = (pa, pb) if pa >= pb else (pb, pa)
        up2 = up * up / rt
        g = _flux(up2 - dn * dn / rt, da[j], dc[j], dk[j], dg[j])
        # the choke limit binds only if its left-hand side, increasing in G, exceeds up2 at g
        lhs = (da[j] * g if g <= dg[j] else dc[j] * g ** 1.75) + (dk[j] + 1.0) * g * g
        if lhs > up2:
            g = min(g, _flux(up2, da[j], dc[j], dk[j] + 1.0, dg[j]))
        q = scale * darea[j] * g
        if pa < pb:
            q = -q
        out[j] -= q
        out[j + 1] += q
    for i in range(n):
        v, dv = rigid[i], 0.0
        if share[i] > 0:
            vol, comp = _linear((p[i] - p_atm) / 1000.0 / s, vx, vc, vends)
            v += share[i] * vol * 1e-6
            dv = share[i] * comp / s * 1e-9
        out[i] = rt * out[i] / (v + p[i] * dv)
    return meter


@nb.njit(cache=True)
def _acceleration(p, theta, omega, first_chamber, ax, ac, aends, jx, jc, mc):
    """d omega / dt of the bending mode and J(theta).

    mc: 0 moment per Pa, 1 m L^2, 2 damping, 3 contact k, 4 contact c, 5 full bend (rad),
    6 modulus scale, 7 p_atm, 8 theta lo, 9 theta hi (inertia table)."""
    n = p.size
    p_mean = 0.0
    for i in range(first_chamber, n):
        p_mean += p[i]
    p_mean = p_mean / (n - first_chamber) - mc[7]
    hold, _ = _linear(math.degrees(theta), ax, ac, aends)
    hold *= mc[6] * 1000.0
    th = min(max(theta, mc[8]), mc[9])
    j, dj = _ppoly(th, jx, jc)
    if th != theta:
        dj = 0.0
    j *= mc[1]
    dj *= mc[1]
    moment = mc[0] * (p_mean - hold) - mc[2] * omega - 0.5 * dj * omega * omega
    if theta > mc[5]:
        moment -= mc[3] * (theta - mc[5]) + mc[4] * omega
    return moment / j, j


@nb.njit(cache=True)
def _rhs(y, phase, tabs, sc, mc, f):
    rigid, share, vx, vc, vends, da, dc, dk, dg, darea, ax, ac, aends, jx, jc = tabs
    n = y.size - 2
    meter = _pneumatics(y[:n], phase, rigid, share, vx, vc, vends, da, dc, dk, dg, darea, sc, f[:n])
    f[n] = y[n + 1]
    f[n + 1], _ = _acceleration(y[:n], y[n], y[n + 1], 2, ax, ac, aends, jx, jc, mc)
    return meter


@nb.njit(cache=True)
def _jacobian(y, f0, phase, tabs, sc, mc, scale_y, lower, diag, upper, mech):
    """Tridiagonal pressure block (lower, diag, upper), and the bending rows:
    mech = (d omega'/d theta, d omega'/d omega, d omega'/d p_chamber)."""
    rigid, share, vx, vc, vends, da, dc, dk, dg, darea, ax, ac, aends, jx, jc = tabs
    n = y.size - 2
    p = y[:n].copy()
    fp = np.empty(n)
    for g in range(3):
        hs = np.zeros(n)
        for j in range(g, n, 3):
            hs[j] = 1e-7 * max(abs(p[j]), 1e3 * scale_y[j])
            p[j] += hs[j]
        _pneumatics(p, phase, rigid, share, vx, vc, vends, da, dc, dk, dg, darea, sc, fp)
        for j in range(g, n, 3):
            p[j] -= hs[j]
            diag[j] = (fp[j] - f0[j]) / hs[j]
            if j > 0:
                upper[j - 1] = (fp[j - 1] - f0[j - 1]) / hs[j]
            if j < n - 1:
                lower[j + 1] = (fp[j + 1] - f0[j + 1]) / hs[j]
    theta, omega = y[n], y[n + 1]
    a0 = f0[n + 1]
    h = 1e-7 * max(abs(theta), 1.0)
    a1, j = _acceleration(y[:n], theta + h, omega, 2, ax, ac, aends, jx, jc, mc)
    mech[0] = (a1 - a0) / h
    h = 1e-7 * max(abs(omega), 1.0)
    a1, j = _acceleration(y[:n], theta, omega + h, 2, ax, ac, aends, jx, jc, mc)
    mech[1] = (a1 - a0) / h
    _, j = _acceleration(y[:n], theta, omega, 2, ax, ac, aends, jx, jc, mc)
    mech[2] = mc[0] / ((n - 2) * j)


@nb.njit(cache=True)
def _solve(hd, lower, diag, upper, mech, r, x, cp, dp):
    """x = (I - hd J)^-1 r: Thomas on the pressures, then the 2 x 2 bending block."""
    n = r.size - 2
    b0 = 1.0 - hd * diag[0]
    cp[0] = -hd * upper[0] / b0
    dp[0] = r[0] / b0
    for i in range(1, n):
        a = -hd * lower[i]
        b = 1.0 - hd * diag[i] - a * cp[i - 1]
        if i < n - 1:
            cp[i] = -hd * upper[i] / b
        dp[i] = (r[i] - a * dp[i - 1]) / b
    x[n - 1] = dp[n - 1]
    for i in range(n - 2, -1, -1):
        x[i] = dp[i] - cp[i] * x[i + 1]
    drive = 0.0
    for i in range(2, n):
        drive += x[i]
    # [1, -hd; -hd m0, 1 - hd m1] [dtheta, domega] = [r_theta, r_omega + hd m2 sum dp]
    r1 = r[n]
    r2 = r[n + 1] + hd * mech[2] * drive
    det = (1.0 - hd * mech[1]) - hd * hd * mech[0]
    x[n + 1] = (r2 + hd * mech[0] * r1) / det
    x[n] = r1 + hd * x[n + 1]


@nb.njit(cache=True)
def _norm(v, y0, y1, atol, rtol):
    s = 0.0
    for i in range(v.size):
        w = atol[i] + rtol * max(abs(y0[i]), abs(y1[i]))
        s += (v[i] / w) ** 2
    return math.sqrt(s / v.size)


@nb.njit(cache=True)
def _newton(z, base, hd, phase, tabs, sc, mc, atol, rtol, lower, diag, upper, mech, f, r, dx, cp, dp, zt, ft, rt):
    """Solve z = base + hd f(z) in place (f: f(z) on return); the iterations taken, -1 when
    it does not converge.

    Newton with a backtracking line search on the weighted residual: near equilibrium the
    short inlet channel's flow law is nearly a square root of the pressure difference (its
    minor loss dominates), on which a plain Newton iteration overshoots from side to side.
    The Jacobian is kept while the iteration contracts and refreshed at the iterate when it
    does not."""
    m = z.size
    _rhs(z, phase, tabs, sc, mc, f)
    for i in range(m):
        r[i] = base[i] + hd * f[i] - z[i]
    norm_r = _norm(r, z, z, atol, rtol)
    previous = math.inf
    refresh = False
    refreshes = 0
    for it in range(30):
        if refresh:
            _jacobian(z, f, phase, tabs, sc, mc, atol, lower, diag, upper, mech)
            refresh = False
            refreshes += 1
        _solve(hd, lower, diag, upper, mech, r, dx, cp, dp)
        size = _norm(dx, z, z, atol, rtol)
        if not np.isfinite(size):
            return -1
        alpha = 1.0
        accepted = False
        while alpha > 1.0 / 64.0:
            for i in range(m):
                zt[i] = z[i] + alpha * dx[i]
            _rhs(zt, phase, tabs, sc, mc, ft)
            for i in range(m):
                rt[i] = base[i] + hd * ft[i] - zt[i]
            norm_t = _norm(rt, zt, zt, atol, rtol)
            if norm_t <= (1.0 - 0.1 * alpha) * norm_r or size < 0.03:
                accepted = True
                break
            alpha *= 0.5
        if not accepted:
            if refreshes >= 6:
                return -1
            refresh = True
            continue
        for i in range(m):
            z[i] = zt[i]
            f[i] = ft[i]
            r[i] = rt[i]
        norm_r = norm_t
        if alpha == 1.0 and size < 0.03:
            return it + 1
        if alpha < 1.0 or size > 0.5 * previous:
            if refreshes >= 6:
                return -1
            refresh = True
        previous = alpha * size
    return -1


@nb.njit(cache=True)
def _record(outs, k, y, phase, flowing, tabs, sc):
    """Output row k: inlet gauge kPa, metered kg/s, bend angle rad, far chamber gauge kPa,
    cavity volume change mL."""
    vx, vc, vends = tabs[2], tabs[3], tabs[4]
    share = tabs[1]
    n = y.size - 2
    p_atm, s = sc[1], sc[8]
    outs[k, 0] = (y[1] - p_atm) / 1000.0
    outs[k, 1] = _metered(y[0], phase, sc) if flowing else 0.0
    outs[k, 2] = y[n]
    outs[k, 3] = (y[n - 1] - p_atm) / 1000.0
    v = 0.0
    for i in range(2, n):
        vol, _ = _linear((y[i] - p_atm) / 1000.0 / s, vx, vc, vends)
        v += share[i] * vol
    rest, _ = _linear(0.0, vx, vc, vends)
    outs[k, 4] = v - rest


@nb.njit(cache=True)
def simulate(t_out, seg_t, seg_phase, y0, tabs, sc, mc, atol, rtol, first_step):
    """States integrated over the segments [seg_t[k], seg_t[k + 1]) with valve phase
    seg_phase[k] (0 supply, 1 vent); outputs at t_out (sorted; rows before seg_t[0] keep y0
    with no flow): the columns of :func:`_record`. Returns (outputs, status, steps): status 0
    ok, 1 step size underflow, 2 too many steps.

    The Jacobian is kept from step to step while both stages converge within two iterations
    each, refreshed at the step's start otherwise, and after a failed Newton iteration before
    the step is cut."""
    n = y0.size
    m = t_out.size
    outs = np.zeros((m, 5))
    gam = 2.0 - math.sqrt(2.0)
    d = gam / 2.0
    w = math.sqrt(2.0) / 4.0
    e1, e2, e3 = (4.0 * w - 1.0) / 3.0, -1.0 / 3.0, 2.0 * d / 3.0
    y = y0.copy()
    k = 0
    while k < m and t_out[k] < seg_t[0]:
        _record(outs, k, y, 0, False, tabs, sc)
        k += 1
    f0, f2, f3 = np.empty(n), np.empty(n), np.empty(n)
    z2, z3, base = np.empty(n), np.empty(n), np.empty(n)
    r, dx, cp, dp = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    est, err, ft = np.empty(n), np.empty(n), np.empty(n)
    zt, rt = np.empty(n), np.empty(n)
    lower, diag, upper, mech = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(3)
    yo = np.empty(n)
    steps = 0
    for s in range(seg_phase.size):
        t, t_end, phase = seg_t[s], seg_t[s + 1], seg_phase[s]
        last = s == seg_phase.size - 1
        h = first_step
        _rhs(y, phase, tabs, sc, mc, f0)
        keep = False  # the Jacobian may serve this step
        at_y = False  # the Jacobian is of the current state
        while k < m and t_out[k] == t and (t < t_end or last):
            _record(outs, k, y, phase, True, tabs, sc)
            k += 1
        while t < t_end:
            steps += 1
            if steps > MAX_STEPS:
                return outs, 2, steps
            if t + h > t_end or t + 1.05 * h > t_end:
                h = t_end - t
            if not keep:
                _jacobian(y, f0, phase, tabs, sc, mc, atol, lower, diag, upper, mech)
                keep = True
                at_y = True
            hd = d * h
            for i in range(n):
                base[i] = y[i] + hd * f0[i]
                z2[i] = y[i] + gam * h * f0[i]
            its2 = _newton(z2, base, hd, phase, tabs, sc, mc, atol, rtol, lower, diag, upper, mech, f2, r, dx, cp,
                           dp, zt, ft, rt)
            its3 = -1
            if its2 > 0:
                for i in range(n):
                    base[i] = y[i] + w * h * (f0[i] + f2[i])
                    z3[i] = z2[i] + (1.0 - gam) * h * f2[i]
                its3 = _newton(z3, base, hd, phase, tabs, sc, mc, atol, rtol, lower, diag, upper, mech, f3, r, dx,
                               cp, dp, zt, ft, rt)
            if its3 < 0:
                if not at_y:  # first a Jacobian of this state, at the same step
                    keep = False
                    continue
                keep = False
                h *= 0.25
                if h < 1e-14:
                    return outs, 1, steps
                continue
            for i in range(n):
                est[i] = h * (e1 * f0[i] + e2 * f2[i] + e3 * f3[i])
            _solve(hd, lower, diag, upper, mech, est, err, cp, dp)
            size = _norm(err, y, z3, atol, rtol)
            if size > 1.0:
                h *= max(0.2, 0.9 * size ** (-1.0 / 3.0))
                if h < 1e-14:
                    return outs, 1, steps
                continue
            t_new = t + h
            if t_new > t_end - 1e-15 * max(1.0, abs(t_end)):
                t_new = t_end
            # outputs in (t, t_new] (t_new itself only if it stays in this segment or it is the last one)
            while k < m and (t_out[k] < t_new or (t_out[k] == t_new and (t_new < t_end or last))):
                th = (t_out[k] - t) / h
                h00 = (1.0 + 2.0 * th) * (1.0 - th) ** 2
                h10 = th * (1.0 - th) ** 2
                h01 = th * th * (3.0 - 2.0 * th)
                h11 = th * th * (th - 1.0)
                for i in range(n):
                    yo[i] = h00 * y[i] + h10 * h * f0[i] + h01 * z3[i] + h11 * h * f3[i]
                _record(outs, k, yo, phase, True, tabs, sc)
                k += 1
            t = t_new
            for i in range(n):
                y[i] = z3[i]
                f0[i] = f3[i]
            at_y = False
            keep = keep and its2 <= 2 and its3 <= 2
            h *= min(5.0, max(0.2, 0.9 * max(size, 1e-10) ** (-1.0 / 3.0)))
    while k < m:  # beyond the last segment (not produced by the protocols below)
        _record(outs, k, y, 0, False, tabs, sc)
        k += 1
    return outs, 0, steps


# -- protocols and the model ------------------------------------------------------------------
@dataclass(frozen=True)
class StepProtocol:
    """What a step recording did: output times, valve switches, supply level and the bench."""

    time_s: np.ndarray
    switch_s: np.ndarray  # segment boundaries: valve opens at switch_s[0], the last is the end
    phases: np.ndarray  # 0 supply open, 1 vent open, per segment
    supply_kpa: float
    tubing_length_mm: float = TUBING_LENGTH_MM
    tubing_id_mm: float | None = None  # None: the design's inlet tubing
    supply_valve: Orifice | None = None  # None: the default 1.0 mm orifice, b = 0.5
    vent_valve: Orifice | None = None

    @classmethod
    def from_recording(cls, rec) -> StepProtocol:
        """The protocol of a ``step`` recording (module docstring); RecordingError names the file."""
        t = np.asarray(rec.columns["time_s"], float)
        supply = np.asarray(rec.columns["supply_kpa"], float)
        if not np.all(np.isfinite(t)) or not np.all(np.isfinite(supply)):
            raise RecordingError(rec.path, None, "time_s and supply_kpa must be finite", column="supply_kpa")
        peak = float(np.max(supply))
        if not peak > 0:
            raise RecordingError(rec.path, None, "the supply never opens (supply_kpa is never above 0)",
                                 column="supply_kpa")
        on = supply >= 0.5 * peak
        level = float(np.median(supply[on]))
        first = int(np.argmax(on))
        switch, phases = [float(t[first])], [0]
        for i in range(first + 1, len(t)):
            if on[i] != on[i - 1]:
                switch.append(float(t[i]))
                phases.append(0 if on[i] else 1)
        end = float(t[-1])
        if end > switch[-1]:
            switch.append(end)
        else:  # the last switch is the last row: nothing to integrate after it
            phases.pop()
            if not phases:
                raise RecordingError(rec.path, None, "the supply opens only at the last row", column="supply_kpa")
        meta = rec.metadata

        def number(key: str, low: float = 0.0, high: float = math.inf, closed: bool = False) -> float | None:
            if key not in meta:
                return None
            try:
                v = float(meta[key])
            except ValueError:
                v = math.nan
            if not (math.isfinite(v) and (low <= v if closed else low < v) and v < high):
                raise RecordingError(rec.path, 1, f"metadata {key} must be a number in {'[' if closed else '('}"
                                     f"{low:g}, {high:g}), got {meta[key]!r}")
            return v

        b = number("valve_critical_ratio", 0.0, 0.999, closed=True)
        b = VALVE_CRITICAL_RATIO if b is None else b
        conductance = number("valve_sonic_conductance")
        if conductance is not None:
            valve = Orifice.from_l_per_s_bar(conductance, b)
        else:
            valve = Orifice.from_diameter_mm(number("valve_orifice_mm") or VALVE_ORIFICE_MM, b)
        if meta.get("gas_law", "isothermal") != "isothermal":
            raise RecordingError(rec.path, 1, f"gas_law {meta['gas_law']!r}: the diagnosis's step model is "
                                 "isothermal (pnmold simulate --dynamic --gas-law isothermal)")
        return cls(t, np.array(switch), np.array(phases, np.int64), level,
                   number("tubing_length_mm") or TUBING_LENGTH_MM, number("tubing_id_mm"), valve, valve)


def _law_arrays(fn) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(breaks, coefficients, (y0, yn, slope_lo, slope_hi)) of a law._Linear."""
    return (np.ascontiguousarray(fn.pchip.x, float), np.ascontiguousarray(fn.pchip.c, float),
            np.array([fn.y[0], fn.y[-1], fn.slope_lo, fn.slope_hi], float))


class StepModel:
    """The design's step response, compiled: ``run(protocol, effects, calibration)``."""

    def __init__(self, design, law=None):
        from pnmold.pneumatics.law import chamber_law_for
        from pnmold.pneumatics.mechanics import THETA_RANGE, BendingDynamics, _inertia_interpolants
        from pnmold.pneumatics.network import ActuatorLine

        self.design = design
        self.law = law if law is not None else chamber_law_for(design)
        self.line = ActuatorLine.from_design(design)
        self.bending = BendingDynamics.from_design(design)
        vx, vc, vends = _law_arrays(self.law._volume)
        ax, ac, aends = _law_arrays(self.law._pressure)
        table, _ = _inertia_interpolants()
        self._tables = (vx, vc, vends, ax, ac, aends, np.ascontiguousarray(table.x, float),
                        np.ascontiguousarray(table.c, float))
        self._theta_range = THETA_RANGE
        self.theta0 = math.radians(float(self.law.bend_angle_deg(0.0)))
        self.steps = 0  # integration steps of the last run

    def run(self, protocol: StepProtocol, effects: Mapping[str, float] | None = None,
            calibration: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
        """The recording's observables at its times: ``pressure_kpa`` (inlet), ``flow_slpm``
        (metered at the valves), ``bend_angle_deg``, ``pressure_far_kpa`` (last chamber) and
        ``volume_ml`` (the cavity's volume change); effects ``dead_volume``,
        ``flow_restriction``; calibration ``modulus_scale``."""
        effects = dict(effects or {})
        s = float((calibration or {}).get("modulus_scale", 1.0))
        dead = float(effects.get("dead_volume", 0.0))
        restriction = float(effects.get("flow_restriction", 0.0))
        if not (s > 0 and dead >= 0 and restriction >= 0):
            raise SolveError(f"step model: modulus_scale {s}, dead_volume {dead}, flow_restriction {restriction}")
        tabs, sc, mc, y0 = self._assemble(protocol, s, dead, restriction)
        out, status, steps = simulate(protocol.time_s, protocol.switch_s, protocol.phases, y0, tabs, sc, mc,
                                      self._atol(y0.size), RTOL, FIRST_STEP_S)
        self.steps = int(steps)
        if status != 0:
            why = "step size underflow" if status == 1 else "too many steps"
            raise SolveError(f"the step model's integration failed ({why})")
        return {"pressure_kpa": out[:, 0], "flow_slpm": out[:, 1] / RHO_STD * 60_000.0,
                "bend_angle_deg": np.degrees(out[:, 2]), "pressure_far_kpa": out[:, 3], "volume_ml": out[:, 4]}

    @staticmethod
    def _atol(size: int) -> np.ndarray:
        return np.concatenate([np.full(size - 2, ATOL_PA), [ATOL_RAD, ATOL_RAD_S]])

    def _assemble(self, protocol: StepProtocol, s: float, dead_ml: float, restriction: float):
        design, line, bending = self.design, self.line, self.bending
        vx, vc, vends, ax, ac, aends, jx, jc = self._tables
        n_ch = line.chambers
        n = 2 + n_ch
        tube_id = protocol.tubing_id_mm if protocol.tubing_id_mm is not None else design.inlet.tubing_id_mm
        tube = Duct.tube(protocol.tubing_length_mm, tube_id)
        valve = protocol.supply_valve or Orifice.from_diameter_mm(VALVE_ORIFICE_MM, VALVE_CRITICAL_RATIO)
        vent = protocol.vent_valve or valve
        rigid = np.zeros(n)
        rigid[0] = VALVE_VOLUME_ML * 1e-6 + tube.volume_m3 / 2
        rigid[1] = tube.volume_m3 / 2 + dead_ml * 1e-6
        share = np.zeros(n)
        share[2:] = 1.0 / n_ch
        ducts = [tube, line.inlet_duct()] + [line.link_duct()] * (n_ch - 1)
        length = np.array([x.length_m for x in ducts])
        diameter = np.array([x.diameter_m for x in ducts])
        da = 64 * MU_AIR * length / diameter ** 2
        dc = 0.3164 * (MU_AIR / diameter) ** 0.25 * length / diameter
        dk = np.array([x.minor_loss for x in ducts], float)
        dg = RE_CROSS * MU_AIR / diameter
        darea = np.array([x.area_m2 for x in ducts])
        temperature = T_REF_K
        p_atm = P_ATM_PA
        p_supply = p_atm + protocol.supply_kpa * 1000
        cond = RHO_REF * math.sqrt(T_REF_K / temperature)
        sc = np.array([R_AIR * temperature, p_atm, p_supply, valve.conductance_m3_per_s_pa * cond,
                       valve.critical_ratio, vent.conductance_m3_per_s_pa * cond, vent.critical_ratio,
                       1.0 / (1.0 + restriction), s])
        theta0 = self.theta0
        dp = s * float(self.law.dpressure_dangle_kpa_per_deg(math.degrees(theta0))) * 1000 * 180 / math.pi
        damping = bending.damping_nms(theta0, dp)
        drive = bending.moment_per_pa * max(p_supply - p_atm, 1e3)
        contact_k = CONTACT_MOMENT_FACTOR * drive / math.radians(CONTACT_DEPTH_DEG)
        contact_c = 2 * math.sqrt(contact_k * float(bending.inertia_kg_m2(FULL_BEND_RAD)[0]))
        ml2 = bending.mass_kg * bending.length_m ** 2
        mc = np.array([bending.moment_per_pa, ml2, damping, contact_k, contact_c, FULL_BEND_RAD, s, p_atm,
                       self._theta_range[0], self._theta_range[1]])
        tabs = (rigid, share, vx, vc, vends, da, dc, dk, dg, darea, ax, ac, aends, jx, jc)
        y0 = np.concatenate([np.full(n, p_atm), [theta0, 0.0]])
        return tabs, sc, mc, y0


def step_protocols(recordings: Sequence) -> list[StepProtocol | None]:
    """The protocol of every step recording (None for the other kinds)."""
    return [StepProtocol.from_recording(r) if r.kind == "step" else None for r in recordings]
