"""Adaptive TR-BDF2 over the step model's right-hand side, compiled (numba, nopython, cached).

TR-BDF2 (Bank et al., IEEE Trans. Electron Devices 32, 1985) in its ESDIRK form, L-stable
and second order, with Hosea & Shampine's embedded third-order error estimate (Appl.
Numer. Math. 20, 1996) filtered through the iteration matrix; the step size follows the
error (factor 0.9 err^(-1/3), within [0.2, 5]); every valve switch is landed on exactly and
each valve phase starts with a small step (its flows jump); other jumps (the contact stop
switching on at full bend) are crossed with steps as small as the tolerance needs, down to
10 eps |t|. The stages are solved by
Newton on :func:`pnmold.pneumatics.rates.jacobian` (the pressure block factorised with
partial pivoting, then the bending block), with a backtracking line search: near
equilibrium the short inlet channel's flow law is nearly a square root of its pressure
difference (its minor loss dominates), on which a plain Newton iteration overshoots. The
Jacobian is kept from step to step while both stages converge within two iterations,
refreshed at the step's start otherwise, and at the iterate when Newton contracts slowly.

The metered gas is a quadrature (nothing depends on it): each stage takes it from the
converged pressures with the method's own weights, outside the error control, so the
network's linear invariant (metered gas = gas stored) holds as for any Runge-Kutta method.
Outputs are cubic Hermite interpolants at the requested times; the first upward crossing of
the bend angle through a level (full bend) is located on the same interpolant. So is the
law's end: the integration stops at the first time a chamber's pressure or the bend rises
through the last the chamber law holds (past it the law is unknown); the outputs after it
are NaN.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from pnmold.pneumatics.rates import jacobian, rates

OK, UNDERFLOW, TOO_MANY_STEPS = 0, 1, 2
EPS = float(np.finfo(np.float64).eps)  # a step below 10 eps |t| underflows (as scipy's solvers)


class Tolerances(NamedTuple):
    """Relative tolerance and absolute ones per kind of state (Pa, rad, rad/s)."""

    rtol: float
    atol_pa: float
    atol_rad: float
    atol_rad_per_s: float
    first_step_s: float = 1e-6  # each valve phase starts with a jump in the flows
    max_steps: int = 200_000

    def atol(self, nodes: int) -> np.ndarray:
        """Per state (the metered gas's entry is unused: it is not error-controlled)."""
        return np.concatenate([np.full(nodes, self.atol_pa), [self.atol_rad, self.atol_rad_per_s, 1.0]])


@nb.njit(cache=True)
def _norm(v, y0, y1, atol, rtol):
    """Weighted RMS over the error-controlled states (all but the metered gas)."""
    m = v.size - 1
    s = 0.0
    for i in range(m):
        w = atol[i] + rtol * max(abs(y0[i]), abs(y1[i]))
        s += (v[i] / w) ** 2
    return math.sqrt(s / m)


@nb.njit(cache=True)
def _factor(hd, jpp, lu, piv):
    """LU with partial pivoting of I - hd J_pp, in place in ``lu``."""
    n = jpp.shape[0]
    for i in range(n):
        for j in range(n):
            lu[i, j] = (1.0 if i == j else 0.0) - hd * jpp[i, j]
    for k in range(n):
        best, row = abs(lu[k, k]), k
        for i in range(k + 1, n):
            if abs(lu[i, k]) > best:
                best, row = abs(lu[i, k]), i
        piv[k] = row
        if row != k:
            for j in range(n):
                lu[k, j], lu[row, j] = lu[row, j], lu[k, j]
        for i in range(k + 1, n):
            lu[i, k] /= lu[k, k]
            for j in range(k + 1, n):
                lu[i, j] -= lu[i, k] * lu[k, j]


@nb.njit(cache=True)
def _solve(hd, lu, piv, mech, weight, r, x):
    """x = (I - hd J)^-1 r: the pressures by the LU, then the 2 x 2 bending block
    [1, -hd; -hd m0, 1 - hd m1] [dtheta, domega] = [r_theta, r_omega + hd m2 sum w dp];
    the metered gas's entry is the residual's."""
    n = lu.shape[0]
    for i in range(n):
        x[i] = r[i]
    for k in range(n):
        if piv[k] != k:
            x[k], x[piv[k]] = x[piv[k]], x[k]
    for i in range(n):
        for j in range(i):
            x[i] -= lu[i, j] * x[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            x[i] -= lu[i, j] * x[j]
        x[i] /= lu[i, i]
    drive = 0.0
    for i in range(n):
        drive += weight[i] * x[i]
    r1 = r[n]
    r2 = r[n + 1] + hd * mech[2] * drive
    det = (1.0 - hd * mech[1]) - hd * hd * mech[0]
    x[n + 1] = (r2 + hd * mech[0] * r1) / det
    x[n] = r1 + hd * x[n + 1]
    x[n + 2] = r[n + 2]


@nb.njit(cache=True)
def _newton(z, base, hd, phase, net, mode, atol, rtol, jpp, lu, piv, mech, f, r, dx, zt, ft, rt):
    """Solve z = base + hd f(z) in place (``f``: f(z) on return); the iterations taken, -1
    when it does not converge. The metered gas is then set from the converged pressures."""
    m = z.size
    rates(z, phase, net, mode, f)
    for i in range(m):
        r[i] = base[i] + hd * f[i] - z[i]
    norm_r = _norm(r, z, z, atol, rtol)
    previous = math.inf
    refresh = False
    refreshes = 0
    for it in range(30):
        if refresh:
            jacobian(z, f, phase, net, mode, atol, jpp, mech)
            _factor(hd, jpp, lu, piv)
            refresh = False
            refreshes += 1
        _solve(hd, lu, piv, mech, mode.chamber_weight, r, dx)
        size = _norm(dx, z, z, atol, rtol)
        if not np.isfinite(size):
            return -1
        alpha = 1.0
        accepted = False
        while alpha > 1.0 / 64.0:
            for i in range(m):
                zt[i] = z[i] + alpha * dx[i]
            rates(zt, phase, net, mode, ft)
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
            z[m - 1] = base[m - 1] + hd * f[m - 1]
            return it + 1
        if alpha < 1.0 or size > 0.5 * previous:
            if refreshes >= 6:
                return -1
            refresh = True
        previous = alpha * size
    return -1


@nb.njit(cache=True)
def _hermite(y0, f0, y1, f1, h, th):
    """The cubic Hermite interpolant at step fraction ``th`` of one state."""
    return ((1.0 + 2.0 * th) * (1.0 - th) ** 2 * y0 + th * (1.0 - th) ** 2 * h * f0
            + th * th * (3.0 - 2.0 * th) * y1 + th * th * (th - 1.0) * h * f1)


@nb.njit(cache=True)
def _crossing(y0, f0, y1, f1, h, level):
    """The step fraction in (0, 1] where the interpolant first reaches ``level`` (it is
    below at 0 and at or above at 1), by bisection."""
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _hermite(y0, f0, y1, f1, h, mid) >= level:
            hi = mid
        else:
            lo = mid
    return hi


@nb.njit(cache=True)
def _law_end(y, f0, z3, f3, h, nodes, share, stop_pa, stop_rad):
    """(step fraction, what) of the first crossing within the step of a chamber's pressure through
    ``stop_pa`` (what: its node) or of the bend through ``stop_rad`` (what: ``nodes``); (inf, -1) if none."""
    first, what = math.inf, -1
    for i in range(nodes + 1):
        level = stop_rad if i == nodes else stop_pa
        if (i == nodes or share[i] > 0) and y[i] < level <= z3[i]:
            th = _crossing(y[i], f0[i], z3[i], f3[i], h, level)
            if th < first:
                first, what = th, i
    return first, what


@nb.njit(cache=True)
def integrate(t_out, switch_s, phases, y0, net, mode, atol, rtol, first_step, max_steps, event_level,
              stop_pa, stop_rad):
    """States at ``t_out`` (sorted) over the segments [switch_s[k], switch_s[k + 1]) with
    valve phase ``phases[k]`` (rows before switch_s[0] keep ``y0``). Returns (states (rows x
    states), status (``OK``, ``UNDERFLOW``, ``TOO_MANY_STEPS``), steps taken, the first time
    the bend angle rises through ``event_level`` (rad; NaN if it does not), the time the
    integration stopped at the law's end (NaN if it did not) and what reached it (a chamber's
    node, or ``nodes`` for the bend; -1)). The law's end: a chamber (a node with a share of the
    law) rising through ``stop_pa`` (Pa, absolute) or the bend through ``stop_rad``; the rows
    after it are NaN."""
    n = y0.size
    nodes = n - 3
    m = t_out.size
    outs = np.zeros((m, n))
    gam = 2.0 - math.sqrt(2.0)
    d = gam / 2.0
    w = math.sqrt(2.0) / 4.0
    e1, e2, e3 = (4.0 * w - 1.0) / 3.0, -1.0 / 3.0, 2.0 * d / 3.0
    y = y0.copy()
    k = 0
    while k < m and t_out[k] < switch_s[0]:
        outs[k] = y
        k += 1
    f0, f2, f3 = np.empty(n), np.empty(n), np.empty(n)
    z2, z3, base = np.empty(n), np.empty(n), np.empty(n)
    r, dx, est, err = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    zt, ft, rt = np.empty(n), np.empty(n), np.empty(n)
    jpp, lu = np.zeros((nodes, nodes)), np.zeros((nodes, nodes))
    piv = np.zeros(nodes, np.int64)
    mech = np.zeros(3)
    event_t = math.nan
    steps = 0
    share = net.law_share
    for s in range(phases.size):
        t, t_end, phase = switch_s[s], switch_s[s + 1], phases[s]
        last = s == phases.size - 1
        h = first_step
        rates(y, phase, net, mode, f0)
        keep = False  # the Jacobian may serve this step
        at_y = False  # the Jacobian is of the current state
        while k < m and t_out[k] == t and (t < t_end or last):
            outs[k] = y
            k += 1
        while t < t_end:
            steps += 1
            if steps > max_steps:
                return outs, TOO_MANY_STEPS, steps, event_t, math.nan, -1
            if t + h > t_end or t + 1.05 * h > t_end:
                h = t_end - t
            if not keep:
                jacobian(y, f0, phase, net, mode, atol, jpp, mech)
                keep = True
                at_y = True
            hd = d * h
            _factor(hd, jpp, lu, piv)
            for i in range(n):
                base[i] = y[i] + hd * f0[i]
                z2[i] = y[i] + gam * h * f0[i]
            its2 = _newton(z2, base, hd, phase, net, mode, atol, rtol, jpp, lu, piv, mech, f2, r, dx, zt, ft, rt)
            its3 = -1
            if its2 > 0:
                for i in range(n):
                    base[i] = y[i] + w * h * (f0[i] + f2[i])
                    z3[i] = z2[i] + (1.0 - gam) * h * f2[i]
                its3 = _newton(z3, base, hd, phase, net, mode, atol, rtol, jpp, lu, piv, mech, f3, r, dx, zt, ft,
                               rt)
            if its3 < 0:
                if not at_y:  # first a Jacobian of this state, at the same step
                    keep = False
                    continue
                keep = False
                h *= 0.25
                if h < 10.0 * EPS * max(abs(t), first_step):
                    return outs, UNDERFLOW, steps, event_t, math.nan, -1
                continue
            for i in range(n):
                est[i] = h * (e1 * f0[i] + e2 * f2[i] + e3 * f3[i])
            _solve(hd, lu, piv, mech, mode.chamber_weight, est, err)
            size = _norm(err, y, z3, atol, rtol)
            if size > 1.0:
                h *= max(0.2, 0.9 * size ** (-1.0 / 3.0))
                if h < 10.0 * EPS * max(abs(t), first_step):
                    return outs, UNDERFLOW, steps, event_t, math.nan, -1
                continue
            t_new = t + h
            if t_new > t_end - 1e-15 * max(1.0, abs(t_end)):
                t_new = t_end
            cut, what = _law_end(y, f0, z3, f3, h, nodes, share, stop_pa, stop_rad)
            if math.isnan(event_t) and y[nodes] < event_level <= z3[nodes]:
                th = _crossing(y[nodes], f0[nodes], z3[nodes], f3[nodes], h, event_level)
                if th <= cut:
                    event_t = t + h * th
            if what >= 0:  # the law ends within this step: the outputs up to there, NaN after
                t_stop = t + h * cut
                while k < m and t_out[k] <= t_stop:
                    th = (t_out[k] - t) / h
                    for i in range(n):
                        outs[k, i] = _hermite(y[i], f0[i], z3[i], f3[i], h, th)
                    k += 1
                outs[k:] = np.nan
                return outs, OK, steps, event_t, t_stop, what
            # outputs in (t, t_new] (t_new itself only if it stays in this segment or it is the last one)
            while k < m and (t_out[k] < t_new or (t_out[k] == t_new and (t_new < t_end or last))):
                th = (t_out[k] - t) / h
                for i in range(n):
                    outs[k, i] = _hermite(y[i], f0[i], z3[i], f3[i], h, th)
                k += 1
            t = t_new
            for i in range(n):
                y[i] = z3[i]
                f0[i] = f3[i]
            at_y = False
            keep = keep and its2 <= 2 and its3 <= 2
            h *= min(5.0, max(0.2, 0.9 * max(size, 1e-10) ** (-1.0 / 3.0)))
    while k < m:  # beyond the last segment
        outs[k] = y
        k += 1
    return outs, OK, steps, event_t, math.nan, -1
