"""Frictionless self-contact of the body's outer surface: a smooth point-to-surface penalty.

The contact surface is the body's boundary less the cavity (its walls are pushed apart by the
pressure) and the y = 0 plane of a half model (the mirror half meets it there, held by the
symmetry; the half model carries half of every contact force, as of every other force).

**Slaves and masters.** The *slaves* are the quadrature points of the surface's quadratic
facets (3 a facet, on the P2 surface, each with its reference area): the contact pressure is
integrated against the P2 shape functions, so a uniform pressure loads the corner and
midside nodes as a uniform traction does (node-to-surface on P2 facets lumps it onto the
corners, and the faces it presses go wavy). The *masters* are the 4 flat triangles of each
facet on its P2 nodes. Every facet is both (two passes), each pass with half the weight, so
two facing surfaces pressed together carry the penalty ``penalty_mpa_per_mm`` once.

**Pairs, found on the deformed surface at every evaluation** (each Newton iterate and each
trial of its line search, so residual, tangent and energy at one state use the same pairs):
a KD-tree of the masters' deformed centroids gives each slave its candidates, those of *the
same part* (reference point-to-triangle distance at most ``same_part_mm``, :mod:`.overlap`,
unless the two face each other squarely across air, as the walls of a gap narrower than twice
that do; or, up to :data:`FLAT_FACE_MM`, in the triangle's plane or just behind it; found once)
dropped, into a list kept while the nodes move less than its margin
(:meth:`ContactSurface._candidates`: the same pairs as a fresh search, at a fraction of its cost);
of the candidates a triangle's reach holds, the triangle nearest the slave is its pair (of
triangles as near, around the edge or vertex nearest it, the one it faces most squarely) where
the slave faces it at all (:attr:`SelfContact.facing`) at a signed distance in ``(-max_penetration_mm,
activation_mm)`` (:mod:`.gap`: to the face, an edge or a vertex). The nearest facing triangle is
chosen before that window: a point beside a wall, still beyond the activation distance, must not
pair with the farther face over the wall's edge, behind whose plane it lies (a hanging fPN's
chamber tops closing: the neighbour's corner was pushed 0.5 mm through the top face, and the path
stalled). Over a valley, where two triangles are as near, the slave keeps the last tangent's
(:attr:`SelfContact.hold_mm`); residual and tangent at one state still pair alike.

**Penalty.** Per pair ``A_q w(c) phi(g) / 2``: ``A_q`` the slave point's reference area, halved
(two passes), ``w(c)`` the C2 facing weight of an edge or vertex pair (1 for a face pair;
:func:`pair_energy` carries its derivatives), ``phi'' = k (delta - g) / delta`` between
``g = delta`` and 0 and ``phi'' = k`` below: C2, no force beyond the activation distance
``delta``, a contact pressure ``k (delta/2 - g)`` once the surfaces overlap, so a contact pressed
at ``P`` sits at ``g = delta/2 - P/k`` (at ``g = delta - sqrt(2 delta P / k)`` while ``P < k delta
/ 2``). Its tangent is exact (the distance's and the facing cosine's Hessians through the slave
point's shape functions), so Newton converges quadratically once the pairs settle
(``tests/test_contact.py`` prints the residuals).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..tetmesh import CAVITY, SYMMETRY
from .gap import gap, signed_distance
from .overlap import SAME_PART_MM, near_pairs, point_triangle_distance

#: the 4 flat triangles of a 6-node facet (corners 0-2, midsides 01, 12, 02), oriented as it
SUBTRIANGLES = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]])
#: the slave points of a facet: the 3-point rule (degree 2, exact for the P2 shape functions
#: against a uniform pressure), barycentric coordinates; each weighs 1/6 of the unit
#: triangle's doubled Jacobian
_POINTS = np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])
_UPPER = np.triu_indices(27)  # the row-by-row upper triangle of a pair's 27 x 27 tangent
#: the margin (mm) of the candidate pairs' list beyond the contact's reach (:meth:`ContactSurface._candidates`):
#: a wider list is filtered longer at each evaluation but searched less often. Assumed, set by the
#: fPN build's curve to the tip meeting the base (one run each, on a machine shared with other FE work):
#: 0.25 / 0.5 / 1 / 2 mm took 159 / 136 / 107 / 81 searches and 23.3 / 24.8 / 26.5 / 30.4 s of assembly
CANDIDATE_SKIN_MM = 0.5
#: a point in a triangle's plane, or behind it by at most ``same_part_mm``, in the reference shape (one flat
#: face, a convex corner's two faces) is one part with it up to this far apart (mm; assumed): pressed out
#: into a dome, the sPN's end face put points 1.0-2.1 mm from it 0.3-0.5 mm behind its own and its side's
#: triangles, and its free run with contact ended 20 kPa early. A point in front of a triangle (across a
#: gap, a concave corner's faces) stays another part beyond ``same_part_mm``
FLAT_FACE_MM = 5.0
#: a point and a triangle closer than ``same_part_mm`` in the reference shape are still two parts
#: when they face each other across air this squarely (:meth:`ContactSurface._same_part`; assumed:
#: cos 26 deg, the walls of a narrow gap face each other at 0 deg, a concave corner's faces at 90)
FACING_ACROSS = 0.9


def _p2_shape(L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 6 P2 shape functions at barycentric points ``L`` (n, 3), and their derivatives along
    the unit triangle's two edges from corner 0 (n, 2, 6)."""
    L0, L1, L2 = L.T
    N = np.column_stack([L0 * (2 * L0 - 1), L1 * (2 * L1 - 1), L2 * (2 * L2 - 1),
                         4 * L0 * L1, 4 * L1 * L2, 4 * L0 * L2])
    dL = np.column_stack([4 * L0 - 1, 4 * L1 - 1, 4 * L2 - 1])  # d N_corner / d L_corner
    d1 = np.column_stack([-dL[:, 0], dL[:, 1], np.zeros(len(L)), 4 * (L0 - L1), 4 * L2, -4 * L2])
    d2 = np.column_stack([-dL[:, 0], np.zeros(len(L)), dL[:, 2], -4 * L1, 4 * L1, 4 * (L0 - L2)])
    return N, np.stack([d1, d2], axis=1)


@dataclass(frozen=True)
class SelfContact:
    """The penalty of :mod:`.contact` (mm, MPa). Every value is assumed, none measured:

    - ``penalty_mpa_per_mm`` 10: contact pressure per mm of overlap. The fPN's walls meet at
      about the cavity pressure (under 0.15 MPa in a build), so they overlap by under
      0.015 mm, well under the 0.05 mm the overlap acceptance allows; 10 MPa/mm is ~10x the
      stiffness of a 1 mm Elastosil wall (E/t ~ 1-2 MPa/mm), so the tangent stays well scaled.
    - ``activation_mm`` 0.1: the force starts at this distance and grows smoothly (C2) to the
      full penalty at touch, so a wall approaching over a load step meets no kink; a tenth of
      the 1 mm wall, the gap it leaves between touching walls (``delta/2``) invisible at a
      build's resolution.
    - ``same_part_mm`` (1 mm, :data:`.overlap.SAME_PART_MM`): points and triangles closer than
      this in the reference shape never pair (the same wall), as the overlap is measured; it
      should exceed ``activation_mm``, or a surface would push on itself in a concave corner.
    - ``max_penetration_mm`` 0.5: half the 1 mm wall; a slave deeper behind a triangle is
      taken to be facing the wall's other side, not this triangle.
    - ``facing`` (0.25, 0.75): an edge or vertex pair is weighed by how squarely the slave faces
      the triangle, ``c = plane gap / distance`` (the cosine of the angle between the triangle's
      normal and the line from its nearest point to the slave): 0 up to ``c = 0.25`` (76 degrees:
      a point beside a triangle, on its plane past its edge, neither pushes nor is pushed along
      the surface), 1 from ``c = 0.75`` (41 degrees), a C2 quintic between, so a pair comes and
      goes without a jump in force or stiffness; a face pair has ``c = 1``. The band is set
      about the 60 degrees (0.5) of a hard cut, wide enough to span a load increment's turn.
    - ``stop_where_ends_meet``: a bending curve ends (stop ``tip_meets_base``) at the first
      converged state where a pair joins points more than half the body's length apart along x
      in the reference shape (:meth:`ContactSurface.ends_meet`): the free end pressed on the
      clamped end. Half the length is assumed: walls meeting across a chamber gap are a few mm
      apart, the two ends about the length.
    - ``predicted_closing`` 0.25: the path shortens an increment, before solving it, while its
      predicted state (extrapolated, blind to contact) brings a pair closer than this share of
      ``activation_mm``, or closer than the last converged state's closest pair less this share
      (:meth:`ContactSurface.closest_gap`, :mod:`.path`): walls driven into each other put spurious
      pressures into the first tangent, whose curvature terms turn the soft bending mode negative.
      Assumed, set by the fPN build: predicted closest pairs at 0.06 mm or more added no negative
      eigenvalue, those at 0.008 mm or less 1 to 31, every one from the contact's tangent.
    - ``predictor_order`` 2: from a converged state with pairs active the path extrapolates
      through the last three states at most (:func:`.states.predictor_order`), not the Newton
      options' 4th-order polynomial through five. On the fPN build (``benchmarks/contact.py``)
      orders 1 / 2 / 3 / 4 took 177 / 171 / 173 / 206 Newton iterations and 74 / 72 / 69 / 79
      factorisations to the same end; 2 is the fewest iterations, not tuned further.
    - ``hold_mm`` 0.002: a slave keeps the triangle of the last tangent while it lies over its face
      within this of the nearest. Over a valley, however shallow, the nearest swaps
      with a kink in the force's direction; Newton went back and forth across it and the path
      stalled (a random Elastosil fPN hanging chambers down at 0.927 g: two slaves swapping face
      pairs, the residual cycling 1.5e-4 / 4.8e-4). Assumed: a fiftieth of ``activation_mm``.
    """

    penalty_mpa_per_mm: float = 10.0
    activation_mm: float = 0.1
    same_part_mm: float = SAME_PART_MM
    max_penetration_mm: float = 0.5
    facing: tuple[float, float] = (0.25, 0.75)
    stop_where_ends_meet: bool = True
    predicted_closing: float = 0.25
    predictor_order: int = 2
    hold_mm: float = 0.002


@dataclass
class ContactTerms:
    """The contact's share at one state: per pair its 9 scalar dofs (the slave's facet, then the
    master triangle), its residual (27) and the upper triangle of its tangent (378, when asked);
    the energy, the total normal force (N, as meshed), and per pair the signed distance (mm), the
    slave point and the facing weight."""

    gdofs: np.ndarray
    residual: np.ndarray
    tangent: np.ndarray | None
    energy: float
    force_n: float
    gaps_mm: np.ndarray
    slaves: np.ndarray
    facing: np.ndarray

    @property
    def pairs(self) -> int:
        return int(self.gdofs.shape[0])


def penalty(g: np.ndarray, k: float, delta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``phi(g)``, ``phi'(g)``, ``phi''(g)`` of the C2 penalty (module notes), per unit area."""
    near = np.clip(delta - g, 0.0, delta)  # 0 beyond delta, delta at and below touch
    over = np.minimum(g, 0.0)  # the overlap (negative)
    phi = k * near ** 3 / (6 * delta) - k * delta * over / 2 + k * over ** 2 / 2
    dphi = -k * near ** 2 / (2 * delta) + k * over
    ddphi = k * near / delta
    return phi, dphi, ddphi


def facing_weight(c: np.ndarray, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The C2 weight of :attr:`SelfContact.facing` at ``c`` (0 up to ``lo``, 1 from ``hi``, the
    quintic smoothstep between), and its first and second derivatives in ``c``."""
    t = np.clip((c - lo) / (hi - lo), 0.0, 1.0)
    w = t ** 3 * (10 - 15 * t + 6 * t ** 2)
    dw = 30 * t ** 2 * (1 - t) ** 2 / (hi - lo)
    ddw = 60 * t * (1 - t) * (1 - 2 * t) / (hi - lo) ** 2
    return w, dw, ddw


def pair_energy(x: np.ndarray, feature: np.ndarray, options: SelfContact, want_hessian: bool = True
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray, np.ndarray]:
    """Per unit area, the energy ``w(c) phi(g)`` of each pair ``x`` (n, 4, 3: the slave, then the
    master triangle turned as :meth:`ContactSurface.pairs` turns it) by its ``feature``; its
    gradient (n, 12) and Hessian (n, 12, 12), the signed distance ``g`` and the weight ``w``.
    ``c = P / g`` with ``P`` the plane gap (:func:`.gap.gap`), 1 for a face pair."""
    opt = options
    g, dg, hg = signed_distance(x, feature, want_hessian)
    phi, dphi, ddphi = penalty(g, opt.penalty_mpa_per_mm, opt.activation_mm)
    grad = dphi[:, None] * dg
    hess = (ddphi[:, None, None] * dg[:, :, None] * dg[:, None, :] + dphi[:, None, None] * hg
            if want_hessian else None)
    w = np.ones(len(g))
    side = np.flatnonzero((feature != 3) & (np.abs(g) > 1e-12))
    if side.size:
        P, dP, hP = gap(x[side], want_hessian)
        gs, dgs = g[side], dg[side]
        c = P / gs
        w[side], dw, ddw = facing_weight(c, *opt.facing)
        dc = dP / gs[:, None] - (P / gs ** 2)[:, None] * dgs
        f, df = phi[side], dphi[side]
        grad[side] = w[side, None] * grad[side] + (dw * f)[:, None] * dc
        if want_hessian:
            hgs = hg[side]
            cross = dP[:, :, None] * dgs[:, None, :]
            hc = (hP / gs[:, None, None] - (cross + cross.transpose(0, 2, 1)) / (gs ** 2)[:, None, None]
                  - (P / gs ** 2)[:, None, None] * hgs
                  + (2 * P / gs ** 3)[:, None, None] * dgs[:, :, None] * dgs[:, None, :])
            mixed = dc[:, :, None] * dgs[:, None, :]
            hess[side] = (w[side, None, None] * hess[side] + (ddw * f)[:, None, None] * dc[:, :, None] * dc[:, None, :]
                          + (dw * df)[:, None, None] * (mixed + mixed.transpose(0, 2, 1))
                          + (dw * f)[:, None, None] * hc)
    return w * phi, grad, hess, g, w


class ContactSurface:
    """The slave points, master triangles and same-part pairs of a surface, fixed once.

    ``X`` the P2 node positions (mm), ``facets`` (K, 6) the surface's P2 facets oriented outward
    of the solid (corners, then midsides 01, 12, 02)."""

    def __init__(self, X: np.ndarray, facets: np.ndarray, options: SelfContact):
        self.options = options
        self.facets = np.asarray(facets, dtype=np.int64)
        self.triangles = self.facets[:, SUBTRIANGLES].reshape(-1, 3)
        self.N, dN = _p2_shape(_POINTS)
        Xf = X[self.facets]  # (K, 6, 3)
        jac = np.cross(np.einsum("qa,kai->kqi", dN[:, 0], Xf), np.einsum("qa,kai->kqi", dN[:, 1], Xf))
        #: reference area of each slave point (facet-major, 3 a facet)
        self.area = (np.linalg.norm(jac, axis=2) / 6).ravel()
        self._same = self._same_part(X, (jac / np.linalg.norm(jac, axis=2)[..., None]).reshape(-1, 3))
        #: how far a slave point moves at most per unit of its facet's largest node motion
        self._spread = float(np.abs(self.N).sum(axis=1).max())
        self._nodes = np.unique(self.facets)
        self._listed: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # (x, s, t)
        self._held = np.full(len(self.area), -1, dtype=np.int64)  # each slave's last nearest triangle
        #: the candidate lists made (:meth:`_candidates`)
        self.searches = 0

    def points(self, x: np.ndarray) -> np.ndarray:
        """(3 K, 3) positions of the slave points with the nodes at ``x``."""
        return np.einsum("qa,kai->kqi", self.N, x[self.facets]).reshape(-1, 3)

    def _same_part(self, X: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """Sorted keys ``point * n_triangles + triangle`` of the pairs within ``same_part_mm``, less
        those facing each other across air: the point squarely in front of the triangle (its plane
        gap at least :data:`FACING_ACROSS` of its distance) and its own outward normal (``normals``,
        per slave point) turned back at the triangle (cosine at most -:data:`FACING_ACROSS`), as the
        walls of a gap narrower than twice ``same_part_mm`` face each other; a concave corner's two
        faces (normals at right angles) and a face's own neighbours (in its plane) stay one part; so do,
        up to :data:`FLAT_FACE_MM` apart, a point in a triangle's plane or at most ``same_part_mm`` behind
        it (one flat face, a convex corner's two faces)."""
        p = X[self.triangles]
        centroid = p.mean(axis=1)
        radius = np.linalg.norm(p - centroid[:, None], axis=2).max(axis=1)
        points = self.points(X)
        tri_normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        tri_normal /= np.linalg.norm(tri_normal, axis=1)[:, None]
        s, t, apart = near_pairs(points, centroid, max(self.options.same_part_mm, FLAT_FACE_MM) + radius)
        plane = np.einsum("ij,ij->i", points[s] - centroid[t], tri_normal[t])
        # in the triangle's plane or behind it by at most ``same_part_mm`` (one flat face, a convex corner's two
        # faces, a thin wall's sides) and near: one part (a face pressed out into a dome puts points behind its
        # own triangles); farther behind, another body may lie beyond air (a block above another's bottom face)
        flat = (plane <= 1e-6) & (plane >= -self.options.same_part_mm) & (apart <= FLAT_FACE_MM + radius[t])
        keys = [s[flat] * len(self.triangles) + t[flat]]
        near = ~flat & (apart <= self.options.same_part_mm + radius[t])
        s, t, plane = s[near], t[near], plane[near]
        dist = point_triangle_distance(points[s], p[t])
        close = dist <= self.options.same_part_mm
        s, t, dist, plane = s[close], t[close], dist[close], plane[close]
        across = ((plane >= FACING_ACROSS * np.maximum(dist, 1e-12)) & (dist > 0)
                  & (np.einsum("ij,ij->i", normals[s], tri_normal[t]) <= -FACING_ACROSS))
        keys.append(s[~across] * len(self.triangles) + t[~across])
        return np.unique(np.concatenate(keys))

    def pairs(self, x: np.ndarray, hold: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each paired slave point, its master triangle's 3 nodes (turned, not flipped, to start
        with the feature nearest the point) and that feature: 3 the face, 2 an edge, 1 a vertex;
        ``hold``: these triangles are the ones kept next (a tangent's: :attr:`SelfContact.hold_mm`)."""
        from trimesh.triangles import closest_point, points_to_barycentric

        opt = self.options
        p, xs_all = x[self.triangles], self.points(x)
        reach = max(opt.activation_mm, opt.max_penetration_mm)
        centroid = p.mean(axis=1)
        radius = np.linalg.norm(p - centroid[:, None], axis=2).max(axis=1) + reach
        s, t = self._candidates(x, xs_all, centroid, radius)
        normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        d = xs_all[s] - centroid[t]
        near = np.einsum("ij,ij->i", d, d) <= radius[t] ** 2  # those a triangle's reach holds now
        s, t, d = s[near], t[near], d[near]
        plane = np.einsum("ij,ij->i", d, normal[t])  # the plane gap (:func:`.gap.plane_gap`): the centroid is on it
        keep = np.abs(plane) < reach  # the distance is at least the plane's
        s, t, plane = s[keep], t[keep], plane[keep]
        closest = closest_point(p[t], xs_all[s])
        dist = np.linalg.norm(xs_all[s] - closest, axis=1)
        signed = np.where(plane < 0, -dist, dist)
        weight = facing_weight(np.abs(plane) / np.maximum(dist, 1e-300), *opt.facing)[0]
        near = (dist < reach) & (weight > 0)
        s, t, dist, plane, closest, weight, signed = (a[near] for a in (s, t, dist, plane, closest, weight, signed))
        # per slave the nearest triangle it faces of all within reach (before the force window: a
        # point beside a wall, beyond the activation distance, is not pushed through the top face
        # whose edge is farther off behind it); of those as near (the triangles around the edge
        # or the vertex nearest it), the one it faces most squarely, so the energy stays continuous
        nearest = np.full(len(xs_all), np.inf)
        np.minimum.at(nearest, s, dist)
        # the last tangent's triangle (``hold``) while the slave lies over its face within ``hold_mm`` of the nearest
        held = (self._held[s] == t) & (dist - np.abs(plane) <= 1e-9 * np.maximum(dist, 1.0))
        tied = (dist <= nearest[s] * (1 + 1e-9) + 1e-12) | (held & (dist <= nearest[s] + opt.hold_mm))
        s, t, dist, plane, closest, weight, signed = (a[tied] for a in (s, t, dist, plane, closest, weight, signed))
        order = np.lexsort((~held[tied], -weight, s))
        first = order[np.r_[True, s[order][1:] != s[order][:-1]]] if order.size else order
        if hold:
            self._held[:] = -1
            self._held[s[first]] = t[first]
        ok = (signed[first] > -opt.max_penetration_mm) & (signed[first] < opt.activation_mm)
        first = first[ok]
        s, t, dist, plane, closest = s[first], t[first], dist[first], plane[first], closest[first]
        on = points_to_barycentric(p[t], closest) > 1e-9
        # where the face's plane is as near as the nearest point, the face (smooth across a flat
        # surface's edges); else the edge or the vertex the nearest point lies on
        on[dist - np.abs(plane) <= 1e-9 * np.maximum(dist, 1.0)] = True
        feature = on.sum(axis=1)
        start = np.where(feature == 2, (np.argmin(on, axis=1) + 1) % 3,
                         np.where(feature == 1, np.argmax(on, axis=1), 0))
        return s, self.triangles[t][np.arange(t.size)[:, None], (start[:, None] + np.arange(3)) % 3], feature

    def _candidates(self, x: np.ndarray, xs: np.ndarray, centroid: np.ndarray, reach: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
        """The (slave point, triangle) pairs of different parts whose point may lie within a
        triangle's ``reach`` of its ``centroid`` (its radius and the contact's reach) at the node
        positions ``x`` (slave points ``xs``): a list of those within ``reach`` plus
        :data:`CANDIDATE_SKIN_MM`, made at some positions ``x0`` and kept while no surface node has
        moved more than ``d`` from them, ``(3 + spread) d`` at most the skin. A slave point then moves at most
        ``spread d`` (its shape functions' absolute sum), a centroid ``d`` and a radius ``2 d``,
        so no pair within ``reach`` now was beyond the list's distance at ``x0``."""
        if self._listed is not None:
            x0, s, t = self._listed
            moved = float(np.sqrt(((x[self._nodes] - x0[self._nodes]) ** 2).sum(axis=1).max()))
            if (3 + self._spread) * moved <= CANDIDATE_SKIN_MM:
                return s, t
        s, t, _ = near_pairs(xs, centroid, reach + CANDIDATE_SKIN_MM)
        key = s * len(self.triangles) + t
        pos = np.clip(np.searchsorted(self._same, key), 0, max(self._same.size - 1, 0))
        keep = (self._same[pos] != key) if self._same.size else np.ones(key.size, bool)
        self._listed = (x.copy(), s[keep], t[keep])
        self.searches += 1
        return s[keep], t[keep]

    def listed_nodes(self) -> np.ndarray:
        """(n, 9) the nodes each candidate pair of the current list couples (its slave's facet, then the
        triangle), one row per facet and triangle: what the tangent's pattern is grown by at once, so that
        pairs meeting later need no new pattern (each new one costs the linear solver an analysis)."""
        if self._listed is None:
            return np.zeros((0, 9), dtype=np.int64)
        _, s, t = self._listed
        ft = np.unique((s // len(_POINTS)) * len(self.triangles) + t)
        return np.column_stack([self.facets[ft // len(self.triangles)], self.triangles[ft % len(self.triangles)]])

    def terms(self, x: np.ndarray, want_k: bool) -> ContactTerms:
        """The contact's energy, residual and tangent at the node positions ``x``."""
        opt = self.options
        s, master, feature = self.pairs(x, hold=want_k)
        phi, grad, hess, g, w = pair_energy(np.concatenate([self.points(x)[s][:, None], x[master]], axis=1),
                                            feature, opt, want_k)
        weight = 0.5 * self.area[s]  # two passes, half each
        # the slave point x_q = sum_a N_qa x_a: its 3 coordinates spread over the facet's 6 nodes
        N = self.N[s % len(_POINTS)]  # (n, 6)
        spread = np.zeros((len(s), 9, 4))
        spread[:, :6, 0] = N
        spread[:, 6:, 1:] = np.eye(3)
        grad = np.einsum("npa,nai->npi", spread, grad.reshape(-1, 4, 3)).reshape(-1, 27)
        residual = weight[:, None] * grad
        tangent = None
        if want_k:
            hess = np.einsum("npa,naibj,nqb->npiqj", spread, hess.reshape(-1, 4, 3, 4, 3), spread)
            full = weight[:, None, None] * hess.reshape(-1, 27, 27)
            tangent = np.ascontiguousarray(full[:, _UPPER[0], _UPPER[1]])
        gdofs = np.column_stack([self.facets[s // len(_POINTS)], master])
        pressure = -penalty(g, opt.penalty_mpa_per_mm, opt.activation_mm)[1]  # along the normal, weighed
        return ContactTerms(gdofs, np.ascontiguousarray(residual), tangent, float(weight @ phi),
                            float((weight * w) @ pressure), g, s, w)

    def closest_gap(self, x: np.ndarray) -> float:
        """The smallest signed distance (mm) of the pairs at the node positions ``x``;
        ``activation_mm`` where there are none."""
        s, master, feature = self.pairs(x)
        if not s.size:
            return self.options.activation_mm
        pair = np.concatenate([self.points(x)[s][:, None], x[master]], axis=1)
        return float(signed_distance(pair, feature, want_hessian=False)[0].min())

    def nodal_pressure(self, x: np.ndarray) -> np.ndarray:
        """The contact pressure (MPa) at each node with the nodes at ``x`` (n, 3), for field output:
        at each paired slave point ``-phi'(g)`` times its facing weight (the pressure either
        surface feels), averaged onto its facet's 6 nodes with the weights ``A_q |N_qa|`` over all
        the slave points around the node (0 where nothing touches; nodes off the surface 0)."""
        terms = self.terms(x, want_k=False)
        opt = self.options
        pressure = np.zeros(len(self.area))
        pressure[terms.slaves] = -penalty(terms.gaps_mm, opt.penalty_mpa_per_mm, opt.activation_mm)[1] * terms.facing
        weight = self.area.reshape(-1, len(_POINTS))[:, :, None] * np.abs(self.N)[None]  # (K, 3, 6)
        num, den = np.zeros(len(x)), np.zeros(len(x))
        np.add.at(num, self.facets, np.einsum("kqa,kq->ka", weight, pressure.reshape(-1, len(_POINTS))))
        np.add.at(den, self.facets, weight.sum(axis=1))
        return np.divide(num, den, out=np.zeros(len(x)), where=den > 0)

    def ends_meet(self, x: np.ndarray, X: np.ndarray) -> tuple[int, float]:
        """The pairs at the node positions ``x`` whose slave facet and master triangle lie more than
        half the body's length apart along x in the reference positions ``X`` (the free end on
        the clamped end, :attr:`SelfContact.stop_where_ends_meet`), and their normal force (N,
        as meshed)."""
        terms = self.terms(x, want_k=False)
        if not terms.pairs:
            return 0, 0.0
        apart = np.abs(X[terms.gdofs[:, :6], 0].mean(axis=1) - X[terms.gdofs[:, 6:], 0].mean(axis=1))
        far = apart > 0.5 * np.ptp(X[:, 0])
        opt = self.options
        pressure = -penalty(terms.gaps_mm[far], opt.penalty_mpa_per_mm, opt.activation_mm)[1]
        return int(far.sum()), float((0.5 * self.area[terms.slaves[far]] * terms.facing[far]) @ pressure)


def outer_faces(boundary: np.ndarray, named: Mapping[str, np.ndarray]) -> np.ndarray:
    """The ``boundary`` triangles (k, 3) less the ``cavity`` and ``symmetry`` facets of ``named``."""
    boundary = np.asarray(boundary, dtype=np.int64)
    held = [np.asarray(named[k], np.int64) for k in (CAVITY, SYMMETRY) if len(named.get(k, ()))]
    if not held:
        return boundary
    held = np.vstack(held)
    n = int(max(boundary.max(), held.max())) + 1

    def keys(f: np.ndarray) -> np.ndarray:
        f = np.sort(f, axis=1)
        return (f[:, 0] * n + f[:, 1]) * n + f[:, 2]

    return boundary[~np.isin(keys(boundary), keys(held))]
