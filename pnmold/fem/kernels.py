"""Compiled (numba) element kernels: energy, residual and packed tangent per element.

Each kernel fills, per element ``e``: ``W[e]`` (energy), ``R[e, :]`` (gradient of the
energy w.r.t. the element's unknowns, ordered node-major ``3*a + i``) and, when asked,
``K[e, :]`` (the upper triangle ``r <= s`` of the symmetric element tangent, row by row).
``bad[e] = 1`` flags an inverted element (J <= 0); its energy is then ``inf``.
All quantities in mm, N, MPa.
"""

from __future__ import annotations

import numba as nb
import numpy as np

_CACHE = True


@nb.njit(cache=_CACHE, inline="always")
def _cofactor(F, C):
    C[0, 0] = F[1, 1] * F[2, 2] - F[1, 2] * F[2, 1]
    C[0, 1] = F[1, 2] * F[2, 0] - F[1, 0] * F[2, 2]
    C[0, 2] = F[1, 0] * F[2, 1] - F[1, 1] * F[2, 0]
    C[1, 0] = F[0, 2] * F[2, 1] - F[0, 1] * F[2, 2]
    C[1, 1] = F[0, 0] * F[2, 2] - F[0, 2] * F[2, 0]
    C[1, 2] = F[0, 1] * F[2, 0] - F[0, 0] * F[2, 1]
    C[2, 0] = F[0, 1] * F[1, 2] - F[0, 2] * F[1, 1]
    C[2, 1] = F[0, 2] * F[1, 0] - F[0, 0] * F[1, 2]
    C[2, 2] = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
    return F[0, 0] * C[0, 0] + F[0, 1] * C[0, 1] + F[0, 2] * C[0, 2]


@nb.njit(parallel=True, cache=_CACHE)
def solid(u, edofs, dN, wq, c10, c20, c30, kappa, mean_dil, want_k, W, R, K, bad):
    """Yeoh elastomer with isochoric I1b and a pointwise or mean-dilatation penalty."""
    nel, nq = wq.shape
    nbf = edofs.shape[1]
    nd = 3 * nbf
    for e in nb.prange(nel):
        ue = np.empty((nbf, 3))
        for a in range(nbf):
            d = 3 * edofs[e, a]
            ue[a, 0] = u[d]
            ue[a, 1] = u[d + 1]
            ue[a, 2] = u[d + 2]
        Fq = np.zeros((nq, 3, 3))
        Hq = np.empty((nq, 3, 3))
        Jq = np.empty(nq)
        ok = True
        for q in range(nq):
            for i in range(3):
                Fq[q, i, i] = 1.0
                for J in range(3):
                    s = 0.0
                    for a in range(nbf):
                        s += ue[a, i] * dN[e, q, a, J]
                    Fq[q, i, J] += s
            Jd = _cofactor(Fq[q], Hq[q])
            if not Jd > 0.0:
                ok = False
                break
            Jq[q] = Jd
            for i in range(3):
                for J in range(3):
                    Hq[q, i, J] /= Jd
        for r in range(nd):
            R[e, r] = 0.0
        if want_k:
            for r in range(K.shape[1]):
                K[e, r] = 0.0
        if not ok:
            bad[e] = 1
            W[e] = np.inf
            continue
        bad[e] = 0
        vol = 0.0
        vcur = 0.0
        for q in range(nq):
            vol += wq[e, q]
            vcur += wq[e, q] * Jq[q]
        theta = vcur / vol
        pbar = kappa * (theta - 1.0)
        energy = 0.5 * kappa * vol * (theta - 1.0) ** 2 if mean_dil else 0.0
        gv = np.zeros(nd)
        f = np.empty((nbf, 3))
        h = np.empty((nbf, 3))
        sv = np.empty((nbf, 3))
        for q in range(nq):
            F = Fq[q]
            H = Hq[q]
            Jd = Jq[q]
            w = wq[e, q]
            I1 = 0.0
            for i in range(3):
                for J in range(3):
                    I1 += F[i, J] * F[i, J]
            aj = Jd ** (-2.0 / 3.0)
            x = aj * I1 - 3.0
            energy += w * (c10 * x + c20 * x * x + c30 * x * x * x)
            W1 = c10 + 2.0 * c20 * x + 3.0 * c30 * x * x
            W11 = 2.0 * c20 + 6.0 * c30 * x
            if mean_dil:
                pc = pbar * Jd
                cA = pc
            else:
                energy += w * 0.5 * kappa * (Jd - 1.0) ** 2
                up = kappa * (Jd - 1.0)
                pc = up * Jd
                cA = kappa * Jd * Jd + pc
            cB = pc
            for a in range(nbf):
                for i in range(3):
                    sf = 0.0
                    sh = 0.0
                    for J in range(3):
                        sf += F[i, J] * dN[e, q, a, J]
                        sh += H[i, J] * dN[e, q, a, J]
                    f[a, i] = sf
                    h[a, i] = sh
                    sv[a, i] = 2.0 * sf - (2.0 / 3.0) * I1 * sh
                    R[e, 3 * a + i] += w * (W1 * aj * sv[a, i] + pc * sh)
                    if mean_dil:
                        gv[3 * a + i] += w * Jd * sh
            if not want_k:
                continue
            k1 = w * W11 * aj * aj
            k2 = w * W1 * aj
            t = 0
            for r in range(nd):
                a = r // 3
                i = r - 3 * a
                for s in range(r, nd):
                    b = s // 3
                    k = s - 3 * b
                    v = k1 * sv[a, i] * sv[b, k]
                    g = 0.0
                    if i == k:
                        for J in range(3):
                            g += dN[e, q, a, J] * dN[e, q, b, J]
                    v += k2 * (2.0 * g - (4.0 / 3.0) * (h[b, k] * f[a, i] + f[b, k] * h[a, i])
                               + (4.0 / 9.0) * I1 * h[a, i] * h[b, k]
                               + (2.0 / 3.0) * I1 * h[a, k] * h[b, i])
                    v += w * (cA * h[a, i] * h[b, k] - cB * h[a, k] * h[b, i])
                    K[e, t] += v
                    t += 1
        W[e] = energy
        if want_k and mean_dil:
            c = kappa / vol
            t = 0
            for r in range(nd):
                for s in range(r, nd):
                    K[e, t] += c * gv[r] * gv[s]
                    t += 1


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


@nb.njit(parallel=True, cache=_CACHE)
def membrane(u, X, fdofs, dNs, wa, dmod, nu, want_k, W, R, K):
    """St.Venant-Kirchhoff membrane, plane stress; ``dmod`` = E t / (1 - nu^2)."""
    nf, nq = wa.shape
    nbf = fdofs.shape[1]
    nd = 3 * nbf
    for e in nb.prange(nf):
        xe = _start_facet(u, X, fdofs, e, nd, want_k, R, K)
        energy = 0.0
        Fs = np.empty((3, 2))
        Bv = np.empty((nd, 3))
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
            s11 = dmod * (e11 + nu * e22)
            s22 = dmod * (e22 + nu * e11)
            s12 = dmod * (1.0 - nu) * e12
            energy += 0.5 * w * (s11 * e11 + s22 * e22 + 2.0 * s12 * e12)
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
            t = 0
            for r in range(nd):
                a = r // 3
                i = r - 3 * a
                for s in range(r, nd):
                    b = s // 3
                    k = s - 3 * b
                    v = dmod * (Bv[r, 0] * (Bv[s, 0] + nu * Bv[s, 1])
                                + Bv[r, 1] * (Bv[s, 1] + nu * Bv[s, 0])
                                + 0.5 * (1.0 - nu) * Bv[r, 2] * Bv[s, 2])
                    if i == k:
                        na1 = dNs[e, q, a, 0]
                        na2 = dNs[e, q, a, 1]
                        nb1 = dNs[e, q, b, 0]
                        nb2 = dNs[e, q, b, 1]
                        v += (na1 * (s11 * nb1 + s12 * nb2) + na2 * (s12 * nb1 + s22 * nb2))
                    K[e, t] += w * v
                    t += 1
        W[e] = energy


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
                    # skew(v) = [[0,-v2,v1],[v2,0,-v0],[-v1,v0,0]]
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
    if i == k:
        return 0.0
    if i == 0:
        return -v[2] if k == 1 else v[1]
    if i == 1:
        return v[2] if k == 0 else -v[0]
    return -v[1] if k == 0 else v[0]


@nb.njit(cache=_CACHE)
def scatter_matrix(Kp, kmap, data):
    """``data[kmap[e, t]] += Kp[e, t]`` where ``kmap >= 0`` (serial: no races)."""
    for e in range(Kp.shape[0]):
        for t in range(Kp.shape[1]):
            m = kmap[e, t]
            if m >= 0:
                data[m] += Kp[e, t]


@nb.njit(cache=_CACHE)
def scatter_vector(Re, gdofs, out):
    """``out[3*gdofs[e, a] + i] += Re[e, 3a+i]``."""
    for e in range(Re.shape[0]):
        for a in range(gdofs.shape[1]):
            d = 3 * gdofs[e, a]
            for i in range(3):
                out[d + i] += Re[e, 3 * a + i]


@nb.njit(cache=_CACHE)
def pair_keys(gdofs, free_index, nfree):
    """CSR keys ``row * nfree + col`` (upper triangle of the reduced system) per entry."""
    ne, nbf = gdofs.shape
    nd = 3 * nbf
    keys = np.full((ne, nd * (nd + 1) // 2), -1, dtype=np.int64)
    for e in range(ne):
        t = 0
        for r in range(nd):
            fr = free_index[3 * gdofs[e, r // 3] + r % 3]
            for s in range(r, nd):
                fs = free_index[3 * gdofs[e, s // 3] + s % 3]
                if fr >= 0 and fs >= 0:
                    lo = min(fr, fs)
                    hi = max(fr, fs)
                    keys[e, t] = lo * nfree + hi
                t += 1
    return keys
