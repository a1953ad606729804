"""The distance of a point to a flat triangle by the feature nearest it, with its exact
gradient and Hessian: the kinematics of the self-contact (:mod:`.contact`).

A pair is a point ``x_s`` and a master triangle ``(a, b, c)`` oriented outward of the solid, in
12 coordinates (node-major). The *signed distance* is measured to the triangle's face (its
plane: ``g = (x_s - x_a) . n``, the normal's rotation included in the Hessian), to one of its
edges (the line through it) or to a vertex, whichever holds the triangle's point nearest the
slave, with the sign of the plane gap (negative behind the face). Across a flat surface the
face is used up to its edges, so the distance is smooth there; at a ridge or a valley the edge
takes over where it is nearer, so it stays continuous with a continuous gradient.
``tests/test_contact.py`` checks every derivative against finite differences.
"""

from __future__ import annotations

import numpy as np

#: (p, e1, e2) = _B (slave, a, b, c): p = x_s - x_a, e1 = x_b - x_a, e2 = x_c - x_a
_B = np.array([[1.0, -1.0, 0.0, 0.0], [0.0, -1.0, 1.0, 0.0], [0.0, -1.0, 0.0, 1.0]])


def _skew(v: np.ndarray) -> np.ndarray:
    """(n, 3, 3) cross-product matrices: ``_skew(v) @ w = v x w``."""
    z = np.zeros(len(v))
    return np.stack([np.stack([z, -v[:, 2], v[:, 1]], -1), np.stack([v[:, 2], z, -v[:, 0]], -1),
                     np.stack([-v[:, 1], v[:, 0], z], -1)], axis=1)


def _flat(h: np.ndarray) -> np.ndarray:
    """(n, 3, 3, 3, 3) blocks (block, block, comp, comp) as (n, 9, 9) matrices."""
    return h.transpose(0, 1, 3, 2, 4).reshape(-1, 9, 9)


def gap(x: np.ndarray, want_hessian: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Signed gap of slave ``x[:, 0]`` to the plane of triangle ``x[:, 1:4]`` (n, 4, 3), its
    gradient (n, 12) and Hessian (n, 12, 12) in the pair's coordinates (node-major).

    ``g = T / A`` with ``T = p . (e1 x e2)`` and ``A = |e1 x e2|`` (module notes)."""
    p, e1, e2 = x[:, 0] - x[:, 1], x[:, 2] - x[:, 1], x[:, 3] - x[:, 1]
    m = np.cross(e1, e2)
    area = np.linalg.norm(m, axis=1)
    n = m / area[:, None]
    T = np.einsum("ij,ij->i", p, m)
    g = T / area
    dT = np.concatenate([m, np.cross(e2, p), np.cross(p, e1)], axis=1)  # (n, 9) in (p, e1, e2)
    dA = np.concatenate([np.zeros_like(n), np.cross(e2, n), np.cross(n, e1)], axis=1)
    dg = dT / area[:, None] - (T / area ** 2)[:, None] * dA
    grad = np.einsum("za,nzc->nac", _B, dg.reshape(-1, 3, 3)).reshape(-1, 12)
    if not want_hessian:
        return g, grad, None
    s_e1, s_e2, s_p, s_n = _skew(e1), _skew(e2), _skew(p), _skew(n)
    H_T = np.zeros((len(g), 3, 3, 3, 3))  # (block, block, 3, 3) over (p, e1, e2)
    H_T[:, 0, 1], H_T[:, 1, 0] = -s_e2, s_e2
    H_T[:, 0, 2], H_T[:, 2, 0] = s_e1, -s_e1
    H_T[:, 1, 2], H_T[:, 2, 1] = -s_p, s_p
    J = np.stack([-s_e2, s_e1], axis=1)  # dm/de1, dm/de2
    proj = (np.eye(3) - n[:, :, None] * n[:, None, :]) / area[:, None, None]
    H_A = np.zeros_like(H_T)
    H_A[:, 1:, 1:] = np.einsum("nbki,nkl,nclj->nbcij", J, proj, J)
    H_A[:, 1, 2] -= s_n
    H_A[:, 2, 1] += s_n
    outer = dT[:, :, None] * dA[:, None, :]
    H = (_flat(H_T) / area[:, None, None] - (outer + outer.transpose(0, 2, 1)) / (area ** 2)[:, None, None]
         - (T / area ** 2)[:, None, None] * _flat(H_A)
         + (2 * T / area ** 3)[:, None, None] * dA[:, :, None] * dA[:, None, :])
    hess = np.einsum("ia,jb,nicjd->nacbd", _B, _B, H.reshape(-1, 3, 3, 3, 3)).reshape(-1, 12, 12)
    return g, grad, hess


def _line_distance(x: np.ndarray, want_hessian: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Distance of slave ``x[:, 0]`` to the line through ``x[:, 1]`` and ``x[:, 2]`` (n, 3, 3), its
    gradient (n, 9) and Hessian (n, 9, 9); from ``D = p.p - (p.e)^2 / e.e``, ``p = x_s - x_a``,
    ``e = x_b - x_a``."""
    p, e = x[:, 0] - x[:, 1], x[:, 2] - x[:, 1]
    b, c = np.einsum("ij,ij->i", p, e), np.einsum("ij,ij->i", e, e)
    r = p - (b / c)[:, None] * e
    d = np.linalg.norm(r, axis=1)
    dD = np.concatenate([2 * r, -2 * (b / c)[:, None] * r], axis=1)  # in (p, e)
    B = np.array([[1.0, -1.0, 0.0], [0.0, -1.0, 1.0]])
    grad = np.einsum("za,nzc->nac", B, (dD / (2 * d)[:, None]).reshape(-1, 2, 3)).reshape(-1, 9)
    if not want_hessian:
        return d, grad, None
    eye, bc = np.eye(3), (b / c)[:, None, None]
    ee, pe = e[:, :, None] * e[:, None, :], e[:, :, None] * p[:, None, :]
    H = np.zeros((len(d), 2, 2, 3, 3))
    H[:, 0, 0] = 2 * eye - 2 * ee / c[:, None, None]
    H[:, 0, 1] = -2 * pe / c[:, None, None] + 4 * bc * ee / c[:, None, None] - 2 * bc * eye
    H[:, 1, 0] = H[:, 0, 1].transpose(0, 2, 1)
    H[:, 1, 1] = (-2 * p[:, :, None] * p[:, None, :] / c[:, None, None]
                  + 4 * bc * (pe + pe.transpose(0, 2, 1)) / c[:, None, None]
                  - 8 * bc ** 2 * ee / c[:, None, None] + 2 * bc ** 2 * eye)
    HD = H.transpose(0, 1, 3, 2, 4).reshape(-1, 6, 6)
    Hd = HD / (2 * d)[:, None, None] - dD[:, :, None] * dD[:, None, :] / (4 * d ** 3)[:, None, None]
    hess = np.einsum("ia,jb,nicjd->nacbd", B, B, Hd.reshape(-1, 2, 3, 2, 3)).reshape(-1, 9, 9)
    return d, grad, hess


def _point_distance(x: np.ndarray, want_hessian: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Distance of ``x[:, 0]`` to ``x[:, 1]`` (n, 2, 3), its gradient (n, 6) and Hessian (n, 6, 6)."""
    p = x[:, 0] - x[:, 1]
    d = np.linalg.norm(p, axis=1)
    unit = p / d[:, None]
    grad = np.concatenate([unit, -unit], axis=1)
    if not want_hessian:
        return d, grad, None
    h = (np.eye(3) - unit[:, :, None] * unit[:, None, :]) / d[:, None, None]
    return d, grad, np.concatenate([np.concatenate([h, -h], axis=2), np.concatenate([-h, h], axis=2)], axis=1)


def signed_distance(x: np.ndarray, feature: np.ndarray, want_hessian: bool = True
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Signed distance of each slave ``x[:, 0]`` to its master ``x[:, 1:4]`` (n, 4, 3) by the
    feature nearest it (:meth:`.contact.ContactSurface.pairs`: 3 the face's plane, 2 the edge through
    ``x[:, 1:3]``, 1 the vertex ``x[:, 1]``), negative behind the face; its gradient (n, 12) and
    Hessian (n, 12, 12) in the pair's coordinates."""
    n = len(feature)
    g, grad = np.zeros(n), np.zeros((n, 12))
    hess = np.zeros((n, 12, 12)) if want_hessian else None
    face = feature == 3
    g[face], grad[face], h = gap(x[face], want_hessian)
    if want_hessian:
        hess[face] = h
    if (~face).any():
        sign = np.where(plane_gap(x[~face, 0], x[~face, 1:4]) < 0, -1.0, 1.0)
        for k, distance in ((2, _line_distance), (1, _point_distance)):
            sel = np.flatnonzero(~face)[feature[~face] == k]
            sk = sign[feature[~face] == k]
            d, gr, h = distance(x[sel, :k + 1], want_hessian)
            g[sel], grad[sel, :3 * (k + 1)] = sk * d, sk[:, None] * gr
            if want_hessian:
                hess[sel, :3 * (k + 1), :3 * (k + 1)] = sk[:, None, None] * h
    return g, grad, hess


def plane_gap(xs: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Signed distance of points (n, 3) to the planes of their triangles (n, 3, 3), along the
    triangles' normals (outward of the solid)."""
    m = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return np.einsum("ij,ij->i", xs - tri[:, 0], m) / np.linalg.norm(m, axis=1)
