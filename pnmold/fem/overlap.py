"""Where a deformed body passes through itself: its boundary nodes inside another part of it.

The measurement behind "the walls do not pass through each other" (a solve without contact
lets them): a boundary node of the deformed body counts when it lies inside a tetrahedron of
*another part* of the body, and its depth is its distance to that part's nearest surface
vertex (and, tighter, to that part's surface itself).

*Another part*, relative to a node: a tetrahedron (or surface triangle) whose **reference**
position is farther than ``same_part_mm`` from the node's reference position. In the
reference shape no node lies inside any tetrahedron, so a node that ends up inside one whose
reference distance is ``d`` has closed a distance ``d`` of air or crushed ``d`` of rubber; the
FE keeps every element's volume positive, so for ``d`` above the size of an element's own
curvature it is air: the body overlaps itself. The default ``SAME_PART_MM = 1.0`` is assumed:
half the fPN's gap between chambers (2 mm), so the facing wall across a gap is always another part,
while the tetrahedra around a node (those that share it, at distance 0) never are; a design with a
narrower gap is measured with under half of its gap (:func:`same_part_for`).

*The surface* is the whole body's: of a half model (its reference nodes at y >= 0, the
symmetry plane y = 0 part of its boundary) the faces on that plane are left out, as the mirror
half lies beyond them; a node on the plane is measured to the other part's outer surface (its
walls), not to the plane's own faces, which it touches by construction.

Quadratic (10-node) cells are split into their 8 linear sub-tetrahedra on the corner and
midside nodes (the deformed P2 shape to second order); the surface is the sub-tetrahedra's
faces that belong to one of them only. A KD-tree on the sub-tetrahedra's deformed centroids
finds the candidates of each node, so the cost grows as n log n, not n^2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

#: reference distance (mm) beyond which a tetrahedron is another part of the body (module notes)
SAME_PART_MM = 1.0
#: the share of a narrow gap within which points are still one part (:func:`same_part_for`; assumed:
#: under half, so the wall across the gap is always another part, with a margin for its curvature)
NARROW_GAP_SHARE = 0.45
#: depth (mm) from which a node counts as overlapping (the acceptance's threshold)
OVERLAP_DEPTH_MM = 0.05
#: the 8 linear sub-tetrahedra of a 10-node cell in the VTK / Abaqus C3D10 node order (corners
#: 0-3, midsides of 01, 12, 02, 03, 13, 23): four corner tetrahedra, then the inner octahedron
#: split along its diagonal 02-13
SUBTETS = np.array([[0, 4, 6, 7], [4, 1, 5, 8], [6, 5, 2, 9], [7, 8, 9, 3],
                    [6, 8, 4, 5], [6, 8, 5, 9], [6, 8, 9, 7], [6, 8, 7, 4]])
_FACES = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])


@dataclass(frozen=True)
class Overlap:
    """The boundary nodes inside another part of the body at one state.

    ``nodes`` their indices; ``depth_mm`` each one's distance to the nearest surface vertex of
    the part it is inside (the issue's measure); ``surface_depth_mm`` to that part's surface
    (triangles; never more than ``depth_mm``)."""

    nodes: np.ndarray
    depth_mm: np.ndarray
    surface_depth_mm: np.ndarray

    def count(self, deeper_than_mm: float = OVERLAP_DEPTH_MM) -> int:
        return int(np.count_nonzero(self.depth_mm > deeper_than_mm))

    @property
    def max_depth_mm(self) -> float:
        return float(self.depth_mm.max()) if self.depth_mm.size else 0.0


def same_part_for(gap_mm: float) -> float:
    """The same-part distance for a body whose chambers stand ``gap_mm`` apart (0: none, an sPN):
    :data:`SAME_PART_MM`, or under half the gap (:data:`NARROW_GAP_SHARE` of it) where the gap is
    narrower than twice that, so the wall facing a node across the gap is always another part."""
    return NARROW_GAP_SHARE * gap_mm if 0 < gap_mm < 2 * SAME_PART_MM else SAME_PART_MM


def linear_tets(cells: np.ndarray) -> np.ndarray:
    """(m', 4) linear tetrahedra of ``cells``: themselves when (m, 4), the 8 sub-tetrahedra of each
    10-node cell (VTK order) when (m, 10)."""
    cells = np.asarray(cells, dtype=np.int64)
    if cells.shape[1] == 4:
        return cells
    if cells.shape[1] != 10:
        raise ValueError(f"cells must have 4 or 10 nodes, got {cells.shape[1]}")
    return cells[:, SUBTETS].reshape(-1, 4)


def boundary_triangles(tets: np.ndarray) -> np.ndarray:
    """(k, 3) faces of the linear ``tets`` that belong to one tetrahedron only."""
    faces = tets[:, _FACES].reshape(-1, 3)
    key = np.sort(faces, axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    return faces[first[counts == 1]]


def outer_triangles(X: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """The boundary triangles of the whole body: of a half model (no reference node below y = 0)
    those on its symmetry plane left out (module notes)."""
    triangles = boundary_triangles(tets)
    size = float(np.ptp(X, axis=0).max())
    if X[:, 1].min() < -1e-9 * size:
        return triangles  # a whole model
    return triangles[~np.all(np.abs(X[triangles, 1]) <= 1e-9 * size, axis=1)]


def point_triangle_distance(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Distance of each point (n, 3) to its triangle (n, 3, 3) (trimesh's closest point)."""
    from trimesh.triangles import closest_point

    if not len(points):
        return np.zeros(0)
    return np.linalg.norm(closest_point(triangles, points) - points, axis=1)


def _barycentric(x: np.ndarray, tet: np.ndarray) -> np.ndarray:
    """(n, 4) barycentric coordinates of points (n, 3) in tetrahedra (n, 4, 3); NaN where flat."""
    e = np.transpose(tet[:, 1:] - tet[:, :1], (0, 2, 1))  # (n, 3, 3) columns b-a, c-a, d-a
    det = np.linalg.det(e)
    ok = np.abs(det) > 1e-12 * np.einsum("nij,nij->n", e, e) ** 1.5
    lam = np.full((len(x), 3), np.nan)
    lam[ok] = np.linalg.solve(e[ok], (x - tet[:, 0])[ok][..., None])[..., 0]
    return np.column_stack([1.0 - lam.sum(axis=1), lam])


def _tet_distance(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Distance of each point (n, 3) outside or on its tetrahedron (n, 4, 3) to it."""
    faces = tets[:, _FACES]  # (n, 4, 3, 3)
    d = [point_triangle_distance(points, faces[:, k]) for k in range(4)]
    return np.min(d, axis=0) if len(points) else np.zeros(0)


def _inside_other_part(X: np.ndarray, x: np.ndarray, tets: np.ndarray, nodes: np.ndarray,
                       same_part_mm: float) -> np.ndarray:
    """The ``nodes`` whose deformed position is inside a tetrahedron of another part."""
    centroid = x[tets].mean(axis=1)
    radius = np.linalg.norm(x[tets] - centroid[:, None], axis=2).max(axis=1)
    tree = cKDTree(centroid)
    hits = tree.query_ball_point(x[nodes], r=float(radius.max()))
    counts = np.fromiter((len(h) for h in hits), dtype=np.int64, count=len(hits))
    node = np.repeat(nodes, counts)
    tet = np.concatenate([np.asarray(h, dtype=np.int64) for h in hits]) if counts.sum() else \
        np.zeros(0, np.int64)
    near = np.linalg.norm(x[node] - centroid[tet], axis=1) <= radius[tet]
    node, tet = node[near], tet[near]
    own = (tets[tet] == node[:, None]).any(axis=1)
    node, tet = node[~own], tet[~own]
    lam = _barycentric(x[node], x[tets[tet]])
    inside = np.all(lam >= 0.0, axis=1)  # NaN (a flat tetrahedron) compares False
    node, tet = node[inside], tet[inside]
    other = _tet_distance(X[node], X[tets[tet]]) > same_part_mm
    return np.unique(node[other])


def _vertex_depth(X: np.ndarray, x: np.ndarray, surface: np.ndarray, nodes: np.ndarray,
                  same_part_mm: float) -> np.ndarray:
    """Distance of each node to the nearest surface vertex of another part (deformed)."""
    tree = cKDTree(x[surface])
    depth = np.full(len(nodes), np.inf)
    todo = np.arange(len(nodes))
    k = 32
    while todo.size:
        k = min(k, surface.size)
        dist, idx = tree.query(x[nodes[todo]], k=k)
        dist, idx = dist.reshape(len(todo), -1), idx.reshape(len(todo), -1)
        far = np.linalg.norm(X[surface[idx]] - X[nodes[todo]][:, None], axis=2) > same_part_mm
        found = far.any(axis=1)
        depth[todo[found]] = np.where(far, dist, np.inf)[found].min(axis=1)
        if k == surface.size:
            break
        todo, k = todo[~found], 4 * k
    return depth


def _surface_depth(X: np.ndarray, x: np.ndarray, triangles: np.ndarray, nodes: np.ndarray,
                   bound: np.ndarray, same_part_mm: float) -> np.ndarray:
    """Distance of each node to the surface triangles of another part, at most ``bound``."""
    centroid = x[triangles].mean(axis=1)
    radius = float(np.linalg.norm(x[triangles] - centroid[:, None], axis=2).max())
    tree = cKDTree(centroid)
    depth = bound.copy()
    for i, (v, b) in enumerate(zip(nodes, bound, strict=True)):
        cand = np.asarray(tree.query_ball_point(x[v], r=b + radius), dtype=np.int64)
        if not cand.size:
            continue
        far = point_triangle_distance(np.repeat(X[v][None], cand.size, 0), X[triangles[cand]]) > same_part_mm
        if far.any():
            cand = cand[far]
            d = point_triangle_distance(np.repeat(x[v][None], cand.size, 0), x[triangles[cand]])
            depth[i] = min(b, float(d.min()))
    return depth


def measure_overlap(nodes_mm: np.ndarray, cells: np.ndarray, displacement_mm: np.ndarray, *,
                    same_part_mm: float = SAME_PART_MM) -> Overlap:
    """The boundary nodes of the deformed body inside another part of it (module notes).

    ``nodes_mm`` (n, 3) reference positions, ``cells`` (m, 4) or (m, 10) in the VTK order (a
    ``step_NNN.vtu``'s, or :func:`pnmold.export.p2.quadratic_mesh`'s), ``displacement_mm``
    (n, 3) or flat (a :class:`~.results.Solution` state).
    """
    X = np.asarray(nodes_mm, float)
    x = X + np.asarray(displacement_mm, float).reshape(X.shape)
    tets = linear_tets(cells)
    triangles = outer_triangles(X, tets)
    surface = np.unique(triangles)
    inside = _inside_other_part(X, x, tets, surface, same_part_mm)
    if not inside.size:
        return Overlap(inside, np.zeros(0), np.zeros(0))
    depth = _vertex_depth(X, x, surface, inside, same_part_mm)
    return Overlap(inside, depth, _surface_depth(X, x, triangles, inside, depth, same_part_mm))


#: :func:`near_pairs` searches the triangles up to this many times the median radius at once
_RADIUS_SPREAD = 3.0


def near_pairs(points: np.ndarray, centroids: np.ndarray, radius: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(point, centroid) index pairs within each centroid's ``radius`` of each other, and their distance
    (KD-trees). The triangles up to :data:`_RADIUS_SPREAD` times the median radius are searched at
    once at their largest radius; the few larger ones (a ballooned wall's stretched triangles) one
    by one at their own, so one huge triangle cannot make every point a candidate of every other
    (on an Ecoflex fPN past its stretch at break the search at one radius took 12 GB)."""
    tree = cKDTree(points)
    cap = min(float(radius.max()), _RADIUS_SPREAD * float(np.median(radius)))
    small = np.flatnonzero(radius <= cap)
    found = tree.sparse_distance_matrix(cKDTree(centroids[small]), cap, output_type="ndarray")
    s, t, apart = found["i"].astype(np.int64), small[found["j"]], found["v"]
    keep = apart <= radius[t]
    s, t, apart = [s[keep]], [t[keep]], [apart[keep]]
    for j in np.flatnonzero(radius > cap):
        near = np.asarray(tree.query_ball_point(centroids[j], radius[j]), dtype=np.int64)
        s.append(near)
        t.append(np.full(near.size, j, dtype=np.int64))
        apart.append(np.linalg.norm(points[near] - centroids[j], axis=1))
    return np.concatenate(s), np.concatenate(t), np.concatenate(apart)
