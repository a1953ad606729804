"""The walls that may meet, as contact pairs of an Abaqus/CalculiX deck (:mod:`.abaqus`).

pnmold's own FE finds its self-contact pairs anywhere on the outer surface as the shape moves
(:mod:`pnmold.fem.contact`); a deck names them beforehand. A PneuNet's chambers stand in a row
along x, so the walls that meet first are the two faces of each gap between neighbouring
chambers: the outer facets whose outward normal points along +x (the back of a chamber) and
those along -x (the front of the next one), no more than ``max_gap_mm`` apart in x. Each gap is
one pair, its +x wall the slave and its -x wall the master, where the two walls' extents overlap
by at least ``MIN_FACING_MM`` both across y and along z (the slivers of a step in the bottom face do not
count). The clamped end (x = 0) and the free end wall are left out: no wall faces them across a
gap. The tip meeting the base at full bend is not among them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pnmold.fem.contact import outer_faces
from pnmold.fem.overlap import point_triangle_distance
from pnmold.tetmesh import TetMesh

#: a facet counts as facing along x where its normal is within ~25 degrees of it
ALONG_X = 0.9
#: the widest gap paired (mm): the fPN's is 2 mm (supplement, Fig. S1); assumed headroom
MAX_GAP_MM = 5.0
#: facets whose centroids lie within this of one another in x belong to one wall (mm, assumed)
WALL_BAND_MM = 0.5
#: the least overlap of two walls' extents across y and along z to pair them (mm, assumed; a
#: gap's walls overlap by their whole ~8 x 9 mm on the fPN's half model)
MIN_FACING_MM = 1.0

_TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


@dataclass(frozen=True)
class GapPair:
    """One gap's two walls: ``slave`` the facets facing +x, ``master`` those facing -x ((k, 3)
    corners of the linear mesh, outward); ``x_mm`` the two walls' positions."""

    slave: np.ndarray
    master: np.ndarray
    x_mm: tuple[float, float]


def outward_boundary(mesh: TetMesh) -> np.ndarray:
    """(k, 3) boundary triangles of the mesh, each turned to face out of its tetrahedron."""
    tets = np.asarray(mesh.tets, dtype=np.int64)
    faces = tets[:, _TET_FACES].reshape(-1, 3)
    key = np.sort(faces, axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    keep = first[counts == 1]
    tri, opposite = faces[keep], tets[keep // 4, np.arange(4)[keep % 4]]
    x = mesh.nodes_mm
    normal = np.cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]])
    inward = np.einsum("ij,ij->i", normal, x[opposite] - x[tri[:, 0]]) > 0
    tri[inward] = tri[inward][:, [0, 2, 1]]
    return tri


def gap_pairs(mesh: TetMesh, max_gap_mm: float = MAX_GAP_MM) -> list[GapPair]:
    """The facing walls of each gap between neighbouring chambers (module notes), by x."""
    tri = outer_faces(outward_boundary(mesh), mesh.facets)  # less the cavity and the symmetry plane
    x = mesh.nodes_mm
    normal = np.cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]])
    nx = normal[:, 0] / np.linalg.norm(normal, axis=1)
    cx = x[tri].mean(axis=1)[:, 0]
    lo, hi = float(x[:, 0].min()), float(x[:, 0].max())
    inside = (cx > lo + WALL_BAND_MM) & (cx < hi - WALL_BAND_MM)
    backs, fronts = _walls(tri, cx, inside & (nx > ALONG_X)), _walls(tri, cx, inside & (nx < -ALONG_X))
    pairs = []
    for xb, fb in backs:
        ahead = [(xf, ff) for xf, ff in fronts if 0 < xf - xb <= max_gap_mm]
        if ahead:
            xf, ff = min(ahead, key=lambda w: w[0])
            if np.all(_facing_mm(x[fb], x[ff]) >= MIN_FACING_MM):
                pairs.append(GapPair(fb, ff, (xb, xf)))
    return pairs


def closest_walls_mm(pairs: list[GapPair], x: np.ndarray) -> np.ndarray:
    """Per gap, the smallest distance (mm) from a corner of its slave wall's facets to its master
    wall's facets with the linear mesh's nodes at ``x`` (n, 3): how near the walls have come (the
    facets are flat on their corners; a quadratic face's midside may lie nearer, by its bulge)."""
    out = np.full(len(pairs), np.inf)
    for k, pair in enumerate(pairs):
        points, tri = x[np.unique(pair.slave)], x[pair.master]
        pt = np.repeat(points, len(tri), axis=0)
        out[k] = point_triangle_distance(pt, np.tile(tri, (len(points), 1, 1))).min()
    return out


def _facing_mm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The overlaps (y, z) of the extents of two walls' facets ((k, 3, 3) corners), mm."""
    lo = np.maximum(a[..., 1:].reshape(-1, 2).min(axis=0), b[..., 1:].reshape(-1, 2).min(axis=0))
    hi = np.minimum(a[..., 1:].reshape(-1, 2).max(axis=0), b[..., 1:].reshape(-1, 2).max(axis=0))
    return np.clip(hi - lo, 0.0, None)


def _walls(tri: np.ndarray, cx: np.ndarray, sel: np.ndarray) -> list[tuple[float, np.ndarray]]:
    """The selected facets grouped into walls by their centroids' x (runs closer than
    :data:`WALL_BAND_MM`): (the wall's mean x, its facets), by x."""
    idx = np.flatnonzero(sel)
    if not idx.size:
        return []
    idx = idx[np.argsort(cx[idx])]
    breaks = np.flatnonzero(np.diff(cx[idx]) > WALL_BAND_MM) + 1
    return [(float(cx[g].mean()), tri[g]) for g in np.split(idx, breaks)]
