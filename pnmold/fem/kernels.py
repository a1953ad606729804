"""Compiled (numba) element kernels of the solid, and the gather/scatter helpers.

Each kernel fills, per element ``e``: ``W[e]`` (energy), ``R[e, :]`` (gradient of the
energy w.r.t. the element's unknowns, ordered node-major ``3*a + i``) and, when asked,
``K[e, :]`` (the upper triangle ``r <= s`` of the symmetric element tangent, row by row).
``bad[e] = 1`` flags an inverted element (J <= 0); its energy is then ``inf``.
All quantities in mm, N, MPa. The surface kernels (membrane, pressure) are in
:mod:`.surface`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

_CACHE = True
#: runs of elements :func:`solid` deals to its threads (each allocates its scratch once)
_RUNS = 64


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


@nb.njit(cache=_CACHE, inline="always")
def _tri(r, s, nd):
    """Position of ``(r, s)``, ``r <= s``, in the row-by-row upper triangle of ``nd x nd``."""
    return r * nd - (r * (r - 1)) // 2 + (s - r)


@nb.njit(cache=_CACHE)
def _element(e, u, edofs, dN, wq, c10, c20, c30, kappa, mean_dil, want_k, mixed, pbar_e,
             W, R, K, bad, ue, Fq, Hq, Jq, gv, f, h, sv, G, Kl):
    """Element ``e`` of :func:`solid`; the arrays after ``bad`` are its scratch space."""
    nq = wq.shape[1]
    nbf = edofs.shape[1]
    nd = 3 * nbf
    for a in range(nbf):
        d = 3 * edofs[e, a]
        ue[a, 0] = u[d]
        ue[a, 1] = u[d + 1]
        ue[a, 2] = u[d + 2]
    for r in range(nd):
        R[e, r] = 0.0
    if want_k:
        for t in range(K.shape[1]):
            Kl[t] = 0.0
    for q in range(nq):
        for i in range(3):
            for J in range(3):
                s = 0.0
                for a in range(nbf):
                    s += ue[a, i] * dN[e, q, a, J]
                Fq[q, i, J] = s + 1.0 if i == J else s
        Jd = _cofactor(Fq[q], Hq[q])
        if not Jd > 0.0:
            bad[e] = 1
            W[e] = np.inf
            if want_k:
                for t in range(K.shape[1]):
                    K[e, t] = 0.0
            return
        Jq[q] = Jd
        for i in range(3):
            for J in range(3):
                Hq[q, i, J] /= Jd
    bad[e] = 0
    vol = 0.0
    vcur = 0.0
    for q in range(nq):
        vol += wq[e, q]
        vcur += wq[e, q] * Jq[q]
    theta = vcur / vol
    pbar = kappa * (theta - 1.0)
    pk = pbar_e if mixed and mean_dil else pbar
    energy = 0.5 * kappa * vol * (theta - 1.0) ** 2 if mean_dil else 0.0
    for r in range(nd):
        gv[r] = 0.0
    for q in range(nq):
        w = wq[e, q]
        Jd = Jq[q]
        I1 = 0.0
        for i in range(3):
            for J in range(3):
                I1 += Fq[q, i, J] * Fq[q, i, J]
        aj = Jd ** (-2.0 / 3.0)
        x = aj * I1 - 3.0
        energy += w * (c10 * x + c20 * x * x + c30 * x * x * x)
        W1 = c10 + 2.0 * c20 * x + 3.0 * c30 * x * x
        W11 = 2.0 * c20 + 6.0 * c30 * x
        if mean_dil:
            pc = pbar * Jd
            cA = pk * Jd
        else:
            energy += w * 0.5 * kappa * (Jd - 1.0) ** 2
            up = kappa * (Jd - 1.0)
            pc = up * Jd
            cA = kappa * Jd * Jd + pc
        cB = cA if mean_dil else pc
        for a in range(nbf):
            for i in range(3):
                sf = 0.0
                sh = 0.0
                for J in range(3):
                    sf += Fq[q, i, J] * dN[e, q, a, J]
                    sh += Hq[q, i, J] * dN[e, q, a, J]
                f[a, i] = sf
                h[a, i] = sh
                v = 2.0 * sf - (2.0 / 3.0) * I1 * sh
                sv[a, i] = v
                R[e, 3 * a + i] += w * (W1 * aj * v + pc * sh)
                if mean_dil:
                    gv[3 * a + i] += w * Jd * sh
        if not want_k:
            continue
        # the (a i, b k) entry: al sv_ai sv_bk + be h_ai h_bk + ga (f_ai h_bk + h_ai f_bk)
        #   + ep h_ak h_bi + de delta_ik dN_a . dN_b (isochoric Yeoh, then the pressure terms)
        k2 = w * W1 * aj
        al = w * W11 * aj * aj
        be = k2 * (4.0 / 9.0) * I1 + w * cA
        ga = -(4.0 / 3.0) * k2
        ep = k2 * (2.0 / 3.0) * I1 - w * cB
        de = 2.0 * k2
        for a in range(nbf):
            for b in range(a, nbf):
                g = 0.0
                for J in range(3):
                    g += dN[e, q, a, J] * dN[e, q, b, J]
                G[a, b] = de * g
        for a in range(nbf):
            for i in range(3):
                r = 3 * a + i
                A1 = al * sv[a, i]
                A2 = be * h[a, i] + ga * f[a, i]
                A3 = ga * h[a, i]
                for b in range(a, nbf):
                    k0 = i if b == a else 0
                    t = _tri(r, 3 * b + k0, nd)
                    for k in range(k0, 3):
                        v = A1 * sv[b, k] + A2 * h[b, k] + A3 * f[b, k] + ep * h[a, k] * h[b, i]
                        if i == k:
                            v += G[a, b]
                        Kl[t] += v
                        t += 1
    W[e] = energy
    if want_k:
        if mean_dil:
            c = kappa / vol
            t = 0
            for r in range(nd):
                gr = c * gv[r]
                for s in range(r, nd):
                    Kl[t] += gr * gv[s]
                    t += 1
        for t in range(K.shape[1]):
            K[e, t] = Kl[t]


@nb.njit(parallel=True, cache=_CACHE)
def solid(u, edofs, dN, wq, c10s, c20s, c30s, kappas, mean_dil, want_k, mixed, pbar_in, W, R, K, bad):
    """Yeoh elastomer with isochoric I1b and a pointwise or mean-dilatation penalty; the
    constants per element (``c10s[e]``, ..., ``kappas[e]``: a body of several rubbers).

    With ``mixed`` (mean dilatation only), the tangent's stress terms use the element
    pressure ``pbar_in[e]`` instead of ``kappa (theta - 1)`` (the mixed-integration-point
    Newton, see :mod:`.newton`); the energy and residual never do.

    The elements are dealt in ``_RUNS`` contiguous runs, each with its scratch
    arrays allocated once (allocating them per element serialised the threads on the
    allocator); the tangent is built by node pairs, its 3 x 3 blocks from per-point vectors.
    """
    nel, nq = wq.shape
    nbf = edofs.shape[1]
    nd = 3 * nbf
    nchunk = min(nel, _RUNS)
    for c in nb.prange(nchunk):
        ue = np.empty((nbf, 3))
        Fq = np.empty((nq, 3, 3))
        Hq = np.empty((nq, 3, 3))
        Jq = np.empty(nq)
        gv = np.empty(nd)
        f = np.empty((nbf, 3))
        h = np.empty((nbf, 3))
        sv = np.empty((nbf, 3))
        G = np.empty((nbf, nbf))
        Kl = np.empty(nd * (nd + 1) // 2)
        for e in range(c * nel // nchunk, (c + 1) * nel // nchunk):
            _element(e, u, edofs, dN, wq, c10s[e], c20s[e], c30s[e], kappas[e], mean_dil, want_k, mixed,
                     pbar_in[e], W, R, K, bad, ue, Fq, Hq, Jq, gv, f, h, sv, G, Kl)


@nb.njit(parallel=True, cache=_CACHE)
def element_pressure(u, d, edofs, dN, wq, kappas, out):
    """Mean-dilatation pressure ``kappa (theta - 1)`` at ``u`` plus its change along ``d``
    to first order, ``kappa dtheta`` with ``dtheta = (1/V) int J tr(F^-1 grad d)``."""
    nel, nq = wq.shape
    nbf = edofs.shape[1]
    for e in nb.prange(nel):
        F = np.empty((3, 3))
        G = np.empty((3, 3))
        H = np.empty((3, 3))
        vol = 0.0
        vcur = 0.0
        dv = 0.0
        for q in range(nq):
            for i in range(3):
                for J in range(3):
                    s = 0.0
                    t = 0.0
                    for a in range(nbf):
                        k = 3 * edofs[e, a] + i
                        s += u[k] * dN[e, q, a, J]
                        t += d[k] * dN[e, q, a, J]
                    F[i, J] = s + (1.0 if i == J else 0.0)
                    G[i, J] = t
            Jd = _cofactor(F, H)  # H = cof(F) = J F^-T
            w = wq[e, q]
            vol += w
            vcur += w * Jd
            for i in range(3):
                for J in range(3):
                    dv += w * H[i, J] * G[i, J]  # J tr(F^-1 G) = cof(F) : G
        out[e] = kappas[e] * (vcur / vol - 1.0) + kappas[e] * dv / vol


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
