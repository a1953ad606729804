"""Compiled (numba) kernels on boundary facets: the paper membrane and the cavity pressure.

Same conventions as :mod:`.kernels`: per facet ``e``, ``W[e]`` (energy), ``R[e, :]``
(gradient w.r.t. the facet's unknowns, node-major ``3*a + i``) and, when asked, ``K[e, :]``
(upper triangle of the symmetric facet tangent, row by row). mm, N, MPa.

The membrane (:func:`membrane`) is a St.Venant-Kirchhoff sheet whose compression is
*relaxed*: a principal membrane force below ``-nc`` is held at ``-nc`` (the sheet wrinkles
instead of carrying more compression; ``nc = 0`` is tension-field theory). The relaxed
energy, in the principal Green strains ``e1 >= e2`` with ``D = E t / (1 - nu^2)``::

    taut      N2 >= -nc            W = D/2 (e1^2 + e2^2 + 2 nu e1 e2)          (SVK)
    wrinkled  N2 < -nc <= N1       W = W_taut(e1, e2*) - nc (e2 - e2*),  e2* = -nc/D - nu e1
    slack     e1 < e_c             W = W_taut(e_c, e_c) - nc (e1 + e2 - 2 e_c), e_c = -nc/(D (1 + nu))

is continuous with a continuous gradient (Pipkin's relaxed energy when ``nc = 0``); its
second derivative jumps between the regimes. The tangent of an isotropic function of the
strain is ``sum_ij h_ij P_i (x) P_j + 2 (N1 - N2) / (e1 - e2) M (x) M`` with ``P_i = n_i n_i``,
``M = sym(n1 n2)`` and ``h_ij`` the Hessian in the principal strains.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

_CACHE = True


@nb.njit(cache=_CACHE, inline="always")
def _start_facet(u, X, fdofs, e, nd, want_k, R, K):
    """Current positions of facet ``e``'s nodes; zero its residual (and stiffness) rows."""
    nbf = fdofs.shape[1]
    xe = np.empty((nbf, 3))
    for a in range(nbf):
        d = fdofs[e, a]
        for i in range(3):
            xe[a, i] = X[d, i] + u[3 * d + i]
    for r in range(nd):
        R[e, r] = 0.0
    if want_k:
        for r in range(K.shape[1]):
            K[e, r] = 0.0
    return xe


@nb.njit(cache=_CACHE, inline="always")
def _taut_energy(e1, e2, dmod, nu):
    return 0.5 * dmod * (e1 * e1 + e2 * e2 + 2.0 * nu * e1 * e2)


@nb.njit(cache=_CACHE)
def relaxed_sheet(e11, e22, e12, dmod, nu, nc, relax, S, C):
    """Energy density of the (relaxed) sheet at the Green strain ``(e11, e22, 2 e12)``.

    Fills ``S`` = (S11, S22, S12) and the Voigt tangent ``C`` (3 x 3, engineering shear);
    returns ``(energy, regime)`` with regime 0 taut, 1 wrinkled, 2 slack. ``relax`` False
    gives the plain St.Venant-Kirchhoff sheet.
    """
    mean = 0.5 * (e11 + e22)
    half = 0.5 * (e11 - e22)
    rad = math.sqrt(half * half + e12 * e12)
    e1 = mean + rad
    e2 = mean - rad
    if not relax or dmod * (e2 + nu * e1) >= -nc:
        S[0] = dmod * (e11 + nu * e22)
        S[1] = dmod * (e22 + nu * e11)
        S[2] = dmod * (1.0 - nu) * e12
        for i in range(3):
            for j in range(3):
                C[i, j] = 0.0
        C[0, 0] = dmod
        C[1, 1] = dmod
        C[0, 1] = dmod * nu
        C[1, 0] = dmod * nu
        C[2, 2] = 0.5 * dmod * (1.0 - nu)
        return 0.5 * (S[0] * e11 + S[1] * e22 + 2.0 * S[2] * e12), 0
    theta = 0.5 * math.atan2(e12, half)
    c, s = math.cos(theta), math.sin(theta)
    p1 = (c * c, s * s, c * s)
    p2 = (s * s, c * c, -c * s)
    m = (-c * s, c * s, 0.5 * (c * c - s * s))
    et = dmod * (1.0 - nu * nu)
    ec = -nc / (dmod * (1.0 + nu))
    if e1 >= ec:  # wrinkled: uniaxial tension along n1, -nc across
        e2s = -nc / dmod - nu * e1
        energy = _taut_energy(e1, e2s, dmod, nu) - nc * (e2 - e2s)
        n1, n2, h11 = et * e1 - nu * nc, -nc, et
        g = (n1 - n2) / (e1 - e2)
        regime = 1
    else:  # slack: -nc both ways
        energy = _taut_energy(ec, ec, dmod, nu) - nc * (e1 + e2 - 2.0 * ec)
        n1, n2, h11, g = -nc, -nc, 0.0, 0.0
        regime = 2
    for i in range(3):
        S[i] = n1 * p1[i] + n2 * p2[i]
        for j in range(3):
            C[i, j] = h11 * p1[i] * p1[j] + 2.0 * g * m[i] * m[j]
    return energy, regime


@nb.njit(parallel=True, cache=_CACHE)
def membrane(u, X, fdofs, dNs, wa, dmod, nu, nc, relax, want_k, mixed, S_in, W, R, K, regime):
    """Relaxed St.Venant-Kirchhoff membrane, plane stress; ``dmod`` = E t / (1 - nu^2),
    ``nc`` the compressive force (N/mm) at which the sheet wrinkles. ``regime[e]`` counts
    the facet's quadrature points that are wrinkled or slack. With ``mixed``, the
    tangent's stress term uses ``S_in[e, q]`` (mixed-integration-point Newton)."""
    nf, nq = wa.shape
    nbf = fdofs.shape[1]
    nd = 3 * nbf
    for e in nb.prange(nf):
        xe = _start_facet(u, X, fdofs, e, nd, want_k, R, K)
        energy = 0.0
        Fs = np.empty((3, 2))
        Bv = np.empty((nd, 3))
        S = np.empty(3)
        C = np.empty((3, 3))
        CB = np.empty(3)
        relaxed = 0
        for q in range(nq):
            w = wa[e, q]
            for i in range(3):
                for al in range(2):
                    s = 0.0
                    for a in range(nbf):
                        s += xe[a, i] * dNs[e, q, a, al]
                    Fs[i, al] = s
            e11 = 0.5 * (Fs[0, 0] ** 2 + Fs[1, 0] ** 2 + Fs[2, 0] ** 2 - 1.0)
            e22 = 0.5 * (Fs[0, 1] ** 2 + Fs[1, 1] ** 2 + Fs[2, 1] ** 2 - 1.0)
            e12 = 0.5 * (Fs[0, 0] * Fs[0, 1] + Fs[1, 0] * Fs[1, 1] + Fs[2, 0] * Fs[2, 1])
            wq, reg = relaxed_sheet(e11, e22, e12, dmod, nu, nc, relax, S, C)
            relaxed += reg > 0
            energy += w * wq
            s11, s22, s12 = S[0], S[1], S[2]
            for a in range(nbf):
                n1 = dNs[e, q, a, 0]
                n2 = dNs[e, q, a, 1]
                for i in range(3):
                    R[e, 3 * a + i] += w * (Fs[i, 0] * (s11 * n1 + s12 * n2)
                                            + Fs[i, 1] * (s12 * n1 + s22 * n2))
                    Bv[3 * a + i, 0] = Fs[i, 0] * n1
                    Bv[3 * a + i, 1] = Fs[i, 1] * n2
                    Bv[3 * a + i, 2] = Fs[i, 0] * n2 + Fs[i, 1] * n1
            if not want_k:
                continue
            if mixed:
                s11, s22, s12 = S_in[e, q, 0], S_in[e, q, 1], S_in[e, q, 2]
            t = 0
            for r in range(nd):
                a = r // 3
                i = r - 3 * a
                for j in range(3):
                    CB[j] = C[j, 0] * Bv[r, 0] + C[j, 1] * Bv[r, 1] + C[j, 2] * Bv[r, 2]
                for s in range(r, nd):
                    b = s // 3
                    k = s - 3 * b
                    v = Bv[s, 0] * CB[0] + Bv[s, 1] * CB[1] + Bv[s, 2] * CB[2]
                    if i == k:
                        na1 = dNs[e, q, a, 0]
                        na2 = dNs[e, q, a, 1]
                        nb1 = dNs[e, q, b, 0]
                        nb2 = dNs[e, q, b, 1]
                        v += (na1 * (s11 * nb1 + s12 * nb2) + na2 * (s12 * nb1 + s22 * nb2))
                    K[e, t] += w * v
                    t += 1
        W[e] = energy
        regime[e] = relaxed


@nb.njit(parallel=True, cache=_CACHE)
def membrane_stress(u, d, X, fdofs, dNs, dmod, nu, nc, relax, out):
    """The sheet's stress (S11, S22, S12) at each quadrature point at ``u`` plus its change
    along ``d`` to first order, ``C : dE`` with ``dE`` the Green strain linearised at ``u``."""
    nf, nq = dNs.shape[0], dNs.shape[1]
    nbf = fdofs.shape[1]
    for e in nb.prange(nf):
        xe = np.empty((nbf, 3))
        de = np.empty((nbf, 3))
        for a in range(nbf):
            k = fdofs[e, a]
            for i in range(3):
                xe[a, i] = X[k, i] + u[3 * k + i]
                de[a, i] = d[3 * k + i]
        Fs = np.empty((3, 2))
        Gs = np.empty((3, 2))
        S = np.empty(3)
        C = np.empty((3, 3))
        for q in range(nq):
            for i in range(3):
                for al in range(2):
                    s = 0.0
                    t = 0.0
                    for a in range(nbf):
                        s += xe[a, i] * dNs[e, q, a, al]
                        t += de[a, i] * dNs[e, q, a, al]
                    Fs[i, al] = s
                    Gs[i, al] = t
            e11 = 0.5 * (Fs[0, 0] ** 2 + Fs[1, 0] ** 2 + Fs[2, 0] ** 2 - 1.0)
            e22 = 0.5 * (Fs[0, 1] ** 2 + Fs[1, 1] ** 2 + Fs[2, 1] ** 2 - 1.0)
            e12 = 0.5 * (Fs[0, 0] * Fs[0, 1] + Fs[1, 0] * Fs[1, 1] + Fs[2, 0] * Fs[2, 1])
            relaxed_sheet(e11, e22, e12, dmod, nu, nc, relax, S, C)
            d11 = Fs[0, 0] * Gs[0, 0] + Fs[1, 0] * Gs[1, 0] + Fs[2, 0] * Gs[2, 0]
            d22 = Fs[0, 1] * Gs[0, 1] + Fs[1, 1] * Gs[1, 1] + Fs[2, 1] * Gs[2, 1]
            d12 = (Fs[0, 0] * Gs[0, 1] + Fs[1, 0] * Gs[1, 1] + Fs[2, 0] * Gs[2, 1]
                   + Fs[0, 1] * Gs[0, 0] + Fs[1, 1] * Gs[1, 0] + Fs[2, 1] * Gs[2, 0])
            for j in range(3):
                out[e, q, j] = S[j] + C[j, 0] * d11 + C[j, 1] * d22 + C[j, 2] * d12


@nb.njit(parallel=True, cache=_CACHE)
def pressure(u, X, fdofs, Nq, dNq, wr, p, want_k, V, R, K):
    """Follower pressure ``p`` on facets oriented with the solid's outward normal.

    ``R[e, 3a+i] = p * int N_a (x,1 x x,2)_i dxi`` = p * int N_a cof(F) N0 dA (Nanson),
    the gradient of -p * V_cavity; ``V[e] = -(1/3) int x . (x,1 x x,2) dxi`` is the facet's
    share of the enclosed cavity volume. ``K`` is the symmetric part of dR/du.
    """
    nf = fdofs.shape[0]
    nq = wr.shape[0]
    nbf = fdofs.shape[1]
    nd = 3 * nbf
    for e in nb.prange(nf):
        xe = _start_facet(u, X, fdofs, e, nd, want_k, R, K)
        vol = 0.0
        a1 = np.empty(3)
        a2 = np.empty(3)
        xq = np.empty(3)
        n = np.empty(3)
        Kf = np.zeros((nd, nd))
        for q in range(nq):
            for i in range(3):
                s1 = 0.0
                s2 = 0.0
                s0 = 0.0
                for a in range(nbf):
                    s1 += xe[a, i] * dNq[q, a, 0]
                    s2 += xe[a, i] * dNq[q, a, 1]
                    s0 += xe[a, i] * Nq[q, a]
                a1[i] = s1
                a2[i] = s2
                xq[i] = s0
            n[0] = a1[1] * a2[2] - a1[2] * a2[1]
            n[1] = a1[2] * a2[0] - a1[0] * a2[2]
            n[2] = a1[0] * a2[1] - a1[1] * a2[0]
            w = wr[q]
            vol -= w * (xq[0] * n[0] + xq[1] * n[1] + xq[2] * n[2]) / 3.0
            for a in range(nbf):
                for i in range(3):
                    R[e, 3 * a + i] += w * p * Nq[q, a] * n[i]
            if not want_k:
                continue
            # d(a1 x a2)/dx_b = N_b,2 [a1]x - N_b,1 [a2]x ; [v]x w = v x w
            for a in range(nbf):
                c = w * p * Nq[q, a]
                for b in range(nbf):
                    m1 = c * dNq[q, b, 1]
                    m2 = c * dNq[q, b, 0]
                    for i in range(3):
                        for k in range(3):
                            sk1 = _skew(a1, i, k)
                            sk2 = _skew(a2, i, k)
                            Kf[3 * a + i, 3 * b + k] += m1 * sk1 - m2 * sk2
        V[e] = vol
        if want_k:
            t = 0
            for r in range(nd):
                for s in range(r, nd):
                    K[e, t] = 0.5 * (Kf[r, s] + Kf[s, r])
                    t += 1


@nb.njit(cache=_CACHE, inline="always")
def _skew(v, i, k):
    """Entry (i, k) of the cross-product matrix [v]x: [[0,-v2,v1],[v2,0,-v0],[-v1,v0,0]]."""
    if i == k:
        return 0.0
    if i == 0:
        return -v[2] if k == 1 else v[1]
    if i == 1:
        return v[2] if k == 0 else -v[0]
    return -v[1] if k == 0 else v[0]
