"""The quadratic (10-node) tetrahedral mesh the FE solves on, as plain arrays for writers.

The FE (:mod:`pnmold.fem`) carries its fields on scikit-fem's P2 element over the linear
:class:`~pnmold.tetmesh.TetMesh`: scalar dof ``s`` sits at ``doflocs[s]`` (the mesh's
vertices first, with their indices, then one node per edge at its midpoint), and
``Solution.states[i][3 s + c]`` is component ``c`` of node ``s``'s displacement. This module
builds that numbering with scikit-fem itself (the same ``MeshTet`` and ``ElementTetP2`` as
:mod:`pnmold.fem.model`), so a writer's node ``s`` is the solver's node ``s``.

Cells are in the node order VTK (``VTK_QUADRATIC_TETRA``), Abaqus and CalculiX (``C3D10``)
share: corners 0-3, then the midside nodes of edges (0,1), (1,2), (2,0), (0,3), (1,3),
(2,3); each cell positively oriented (corner 3 on the side the normal of 0-1-2 points to).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from pnmold.errors import MeshingError
from pnmold.fem.results import largest_stretch_squared
from pnmold.tetmesh import TetMesh

#: the corner pairs of the six midside nodes, in the VTK / Abaqus C3D10 order
EDGES = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))
#: the node permutation that swaps corners 1 and 2 (turns a cell inside out and back)
_FLIP = np.array([0, 2, 1, 3, 6, 5, 4, 7, 9, 8])
#: facet (corners a, b, c, midsides ab, bc, ca) of each C3D10 face S1..S4: the local nodes
FACES = (
    (0, 1, 2, 4, 5, 6),  # S1: 1-2-3
    (0, 3, 1, 7, 8, 4),  # S2: 1-4-2
    (1, 3, 2, 8, 9, 5),  # S3: 2-4-3
    (2, 3, 0, 9, 7, 6),  # S4: 3-4-1
)


@dataclass(frozen=True, eq=False)
class QuadraticMesh:
    """10-node tetrahedra over a :class:`TetMesh`, numbered as the FE's P2 field.

    Attributes
    ----------
    nodes_mm : (n, 3) node coordinates (the TetMesh's vertices first, same indices).
    cells : (m, 10) node indices, VTK/Abaqus order, positively oriented; cell ``e`` is the
        TetMesh's tetrahedron ``e``.
    mesh : the linear mesh it was built from (facet sets, tip, half model).
    gradients : (m, 10, 10, 3) shape-function gradients (1/mm): cell, at which of its
        nodes, of which node's function, component (for strains at the nodes).
    """

    nodes_mm: np.ndarray
    cells: np.ndarray
    mesh: TetMesh
    gradients: np.ndarray = field(repr=False)

    @property
    def n_nodes(self) -> int:
        return int(self.nodes_mm.shape[0])

    def edge_node(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """The midside node of each linear edge (vertex ``i``, vertex ``j``)."""
        keys, nodes = self._edges
        n = self.mesh.n_nodes
        want = np.minimum(i, j).astype(np.int64) * n + np.maximum(i, j)
        pos = np.clip(np.searchsorted(keys, want), 0, keys.size - 1)
        if np.any(keys[pos] != want):
            raise MeshingError("a facet edge is not an edge of the tetrahedra")
        return nodes[pos]

    @cached_property
    def _edges(self) -> tuple[np.ndarray, np.ndarray]:
        c = self.cells
        i = np.concatenate([c[:, a] for a, _ in EDGES])
        j = np.concatenate([c[:, b] for _, b in EDGES])
        keys = np.minimum(i, j).astype(np.int64) * self.mesh.n_nodes + np.maximum(i, j)
        mid = np.concatenate([c[:, 4 + k] for k in range(6)])
        keys, first = np.unique(keys, return_index=True)
        return keys, mid[first]

    def facet_nodes(self, name: str) -> np.ndarray:
        """(k, 6) nodes of a named facet set: corners as in the TetMesh (outward of the solid),
        then the midside nodes of (0,1), (1,2), (2,0) (the S6/M3D6/STRI65 order)."""
        f = np.asarray(self.mesh.facets.get(name, np.zeros((0, 3), int)), dtype=np.int64)
        if not len(f):
            return np.zeros((0, 6), dtype=np.int64)
        mids = [self.edge_node(f[:, a], f[:, b]) for a, b in ((0, 1), (1, 2), (2, 0))]
        return np.column_stack([f, *mids])

    def facet_faces(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(cell index, face number 1..4) of each facet of a named set (C3D10 faces S1..S4)."""
        return self.faces_of(self.mesh.facets.get(name, np.zeros((0, 3), int)), name)

    def faces_of(self, facets: np.ndarray, name: str = "facets") -> tuple[np.ndarray, np.ndarray]:
        """(cell index, face number 1..4) of each of ``facets`` ((k, 3) linear corners)."""
        f = np.asarray(facets, dtype=np.int64).reshape(-1, 3)
        n = self.mesh.n_nodes
        corners = self.cells[:, :4]
        keys, where = [], []
        for k, face in enumerate(FACES):
            tri = np.sort(corners[:, face[:3]], axis=1)
            keys.append((tri[:, 0] * n + tri[:, 1]) * n + tri[:, 2])
            where.append(np.column_stack([np.arange(len(corners)), np.full(len(corners), k + 1)]))
        keys_all, where_all = np.concatenate(keys), np.concatenate(where)
        order = np.argsort(keys_all)
        fs = np.sort(f, axis=1)
        want = (fs[:, 0] * n + fs[:, 1]) * n + fs[:, 2]
        pos = np.clip(np.searchsorted(keys_all[order], want), 0, order.size - 1)
        if len(f) and np.any(keys_all[order][pos] != want):
            raise MeshingError(f"facet set {name!r} has triangles that are not tet faces")
        hit = where_all[order][pos]
        return hit[:, 0], hit[:, 1]


def quadratic_mesh(mesh: TetMesh) -> QuadraticMesh:
    """The P2 nodes and 10-node cells of ``mesh`` in the FE's numbering (scikit-fem)."""
    from skfem import Basis, ElementTetP2, MeshTet

    element = ElementTetP2()
    sk = MeshTet(np.asarray(mesh.nodes_mm, float).T.copy(),
                 np.ascontiguousarray(mesh.tets, dtype=np.int64).T.copy())
    at_nodes = np.asarray(element.doflocs, float).T.copy()  # (3, 10) reference node positions
    basis = Basis(sk, element, quadrature=(at_nodes, np.full(10, 1.0 / 60.0)))
    nodes = np.ascontiguousarray(basis.doflocs.T)
    local = np.ascontiguousarray(basis.element_dofs.T, dtype=np.int64)  # (m, 10), scikit-fem's order
    order = _vtk_order(nodes, local)
    cells = local[:, order]
    grads = np.stack([basis.basis[a][0].grad for a in range(10)])  # (10 funcs, 3, m, 10 points)
    grads = grads.transpose(2, 3, 0, 1)[:, order][:, :, order]  # (m, point, func, 3), VTK order
    p = nodes[cells[:, :4]]
    det = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    flip = det < 0
    cells[flip] = cells[flip][:, _FLIP]
    grads[flip] = grads[flip][:, _FLIP][:, :, _FLIP]
    return QuadraticMesh(nodes, cells, mesh, np.ascontiguousarray(grads))


def _vtk_order(nodes: np.ndarray, local: np.ndarray) -> np.ndarray:
    """The permutation of scikit-fem's local nodes into the VTK order, found from where the
    midside nodes lie (so a change of scikit-fem's convention is caught, not mis-written)."""
    order = [0, 1, 2, 3]
    for a, b in EDGES:
        mid = 0.5 * (nodes[local[:, a]] + nodes[local[:, b]])
        hits = [k for k in range(4, 10) if np.allclose(nodes[local[:, k]], mid, atol=1e-9)]
        if len(hits) != 1:
            raise MeshingError(f"no unique P2 node at the midpoint of edge {a}-{b} of every tetrahedron")
        order.append(hits[0])
    return np.array(order)


def nodal_stretch(qmesh: QuadraticMesh, state: np.ndarray) -> np.ndarray:
    """Largest principal stretch at each P2 node: sqrt of the largest eigenvalue of F^T F
    with F from the P2 displacement evaluated at the node in every cell that has it, then
    averaged over those cells (nodal averaging).

    ``state`` is the FE's full displacement vector (3 per node, node-major, mm).
    """
    u = np.asarray(state, float).reshape(-1, 3)
    if u.shape[0] != qmesh.n_nodes:
        raise MeshingError(f"a state of {u.shape[0]} nodes does not fit a P2 mesh of {qmesh.n_nodes}")
    ue = u[qmesh.cells]  # (m, 10 funcs, 3)
    F = np.matmul(ue.transpose(0, 2, 1)[:, None], qmesh.gradients) + np.eye(3)  # (m, 10 points, 3, 3)
    lam = np.sqrt(largest_stretch_squared(F))
    cells = qmesh.cells.ravel()
    total = np.bincount(cells, lam.ravel(), qmesh.n_nodes)
    return total / np.maximum(np.bincount(cells, minlength=qmesh.n_nodes), 1)
