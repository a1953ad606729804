"""Discretisation: P2 tetrahedra from a :class:`TetMesh`, DOF numbering and the assembly of
the reduced (free-DOF, upper-triangular) system into the sparsity pattern of :mod:`.pattern`.

scikit-fem supplies the mesh, the P2 element, the quadrature, the reference gradients and
the DOF numbering (scalar P2 dof ``s`` -> vector dofs ``3 s + i``; vertex ``v`` is dof
``v``, edge ``k`` is dof ``n_vertices + k``). The compiled kernels in :mod:`.kernels`
evaluate the element quantities; this module gathers and scatters.

Sign convention: facets are oriented with the outward normal of the SOLID, so the cavity
facets' normals point into the air; the cavity volume is ``-(1/3) int x . n da`` over them.
The total potential is ``Pi = W_elastomer + W_membrane - p V_cavity - f_g . u + W_contact``
and the residual is its gradient, ``R = f_int - f_ext``.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from skfem import Basis, ElementTetP2, ElementTriP2, LinearForm, MeshTet
from skfem.quadrature import get_quadrature
from skfem.refdom import RefTri

from ..errors import MeshingError
from ..tetmesh import BOTTOM_LAYER, CAVITY, FREE_END, STRAIN_LIMITING_LAYER, TetMesh
from . import kernels, surface
from .contact import ContactSurface, ContactTerms, SelfContact, outer_faces
from .material import Membrane, Yeoh
from .pattern import Pattern

log = logging.getLogger(__name__)

_CHUNK = 4096
_TRI_EDGES = ((0, 1), (1, 2), (0, 2))  # ElementTriP2 edge dofs 3, 4, 5


@dataclass(frozen=True)
class Load:
    """One load state: pressure (MPa), gravity force density (N/mm^3), contact plane."""

    pressure_mpa: float = 0.0
    gravity_n_per_mm3: tuple[float, float, float] = (0.0, 0.0, 0.0)
    plane_z_mm: float | None = None
    plane_stiffness_n_per_mm: float = 0.0


@dataclass
class Stresses:
    """The stresses the tangent is built with in the mixed-integration-point Newton:
    the element pressures of the mean dilatation (MPa, one per tet) and the sheet's
    stress (N/mm, (facet, quadrature point, S11/S22/S12); None without a sheet)."""

    pbar: np.ndarray
    sheet: np.ndarray | None

    def combine(self, weights: list[float], others: list[Stresses]) -> Stresses:
        """``sum_i weights[i] * others[i]`` (this one is a template only)."""
        pbar = sum(w * o.pbar for w, o in zip(weights, others, strict=True))
        sheet = (None if self.sheet is None else
                 sum(w * o.sheet for w, o in zip(weights, others, strict=True)))
        return Stresses(pbar, sheet)


@dataclass
class Evaluation:
    """Residual (full length), energy and optionally the reduced tangent at one state.

    ``volume_gradient`` is dV_cavity/du (full length; None without a cavity);
    ``inverted`` the indices of the tetrahedra with J <= 0 somewhere (then ``ok`` is False);
    ``wrinkled`` the fraction of the sheet's quadrature points that are wrinkled or slack;
    ``self_contact_n`` the self-contact's total normal force (N, as meshed) on ``contact_pairs``.
    """

    residual: np.ndarray
    energy: float
    ok: bool
    external_norm: float
    cavity_volume_mm3: float
    contact_force_n: float
    matrix: sp.csr_matrix | None = None
    volume_gradient: np.ndarray | None = None
    inverted: np.ndarray | None = None
    wrinkled: float = 0.0
    self_contact_n: float = 0.0
    contact_pairs: int = 0


def _element_constants(mesh: TetMesh, material: Yeoh,
                       regions: Mapping[str, Yeoh]) -> tuple[np.ndarray, np.ndarray]:
    """Per element: (4, n_tets) rows C10, C20, C30, bulk modulus (MPa), and the density
    relative to ``material``'s."""
    def row(m: Yeoh) -> list[float]:
        return [m.c10_mpa, m.c20_mpa, m.c30_mpa, m.bulk_modulus_mpa]

    constants = np.repeat(np.array(row(material))[:, None], mesh.n_tets, axis=1)
    ratio = np.ones(mesh.n_tets)
    for name, rubber in regions.items():
        if name not in mesh.regions:
            raise MeshingError(f"element set {name!r} of a second rubber is not in the mesh")
        if rubber.volumetric != material.volumetric:
            raise MeshingError(f"element set {name!r}: volumetric treatment "
                               f"{rubber.volumetric!r} differs from the body's {material.volumetric!r}")
        idx = mesh.regions[name]
        constants[:, idx] = np.array(row(rubber))[:, None]
        ratio[idx] = rubber.density_g_per_ml / material.density_g_per_ml
    return np.ascontiguousarray(constants), ratio


class Model:
    """P2 discretisation of an elastomer body with membrane, pressure and supports.

    Parameters
    ----------
    mesh : the linear-tet mesh with named facet sets.
    material : the elastomer.
    membrane : the strain-limiting sheet on ``strain_limiting_layer`` (None: no sheet).
    fixed : facet-set name -> displacement components held at their prescribed values
        (e.g. ``{"clamp": (0, 1, 2), "symmetry": (1,)}``).
    contact_set : facet set whose nodes may touch the rigid plane of a :class:`Load`.
    regions : element-set name -> the rubber of those elements instead of ``material``
        (e.g. a strain-limiting layer cast in a stiffer silicone); same volumetric treatment.
    self_contact : the outer surface's frictionless self-contact (:mod:`.contact`); None: none.
    """

    def __init__(self, mesh: TetMesh, material: Yeoh, membrane: Membrane | None,
                 fixed: Mapping[str, Sequence[int]], contact_set: str = FREE_END,
                 regions: Mapping[str, Yeoh] | None = None, self_contact: SelfContact | None = None):
        self.mesh, self.material = mesh, material
        self.constants, self.density_ratio = _element_constants(mesh, material, regions or {})
        #: the rubber the sheet lies on (its wrinkling and solved stiffness depend on it)
        self.substrate = (regions or {}).get(BOTTOM_LAYER, material)
        #: the sheet as solved (:meth:`Membrane.solved_on`)
        self.membrane = membrane.solved_on(self.substrate) if membrane is not None else None
        tets = np.ascontiguousarray(mesh.tets, dtype=np.int64)
        self.skmesh = MeshTet(np.asarray(mesh.nodes_mm, float).T.copy(), tets.T.copy())
        self.basis = Basis(self.skmesh, ElementTetP2(), intorder=2)
        b = self.basis
        self.n_scalar = int(b.N)
        self.ndof = 3 * self.n_scalar
        self.X = np.ascontiguousarray(b.doflocs.T)
        self.edofs = np.ascontiguousarray(b.element_dofs.T, dtype=np.int64)
        grads = np.stack([b.basis[a][0].grad for a in range(10)])  # (10, 3, nel, nq)
        self.dN = np.ascontiguousarray(grads.transpose(2, 3, 0, 1))
        self.wq = np.ascontiguousarray(b.dx)
        self._edge_keys, self._edge_order = self._edge_lookup()
        self.facet_dofs = {name: self._facet_dofs(name, f) for name, f in mesh.facets.items()
                           if len(f)}
        self.fixed = np.zeros(self.ndof, bool)
        used = np.zeros(self.n_scalar, bool)
        used[self.edofs] = True
        self.fixed[np.repeat(~used, 3)] = True
        self.fixed_sets: dict[str, np.ndarray] = {}
        for name, comps in fixed.items():
            if name not in self.facet_dofs:
                raise MeshingError(f"facet set {name!r} to hold is missing or empty")
            nodes = np.unique(self.facet_dofs[name])
            self.fixed_sets[name] = nodes
            for c in comps:
                self.fixed[3 * nodes + c] = True
        self.free = np.flatnonzero(~self.fixed)
        self.free_index = np.full(self.ndof, -1, dtype=np.int64)
        self.free_index[self.free] = np.arange(self.free.size)
        #: the reduced tangent's sparsity pattern and each term's map into it (:mod:`.pattern`)
        self.pattern = Pattern(self.edofs, self.free_index, self.free.size)
        self._build_membrane()
        self._build_pressure()
        ratio = np.repeat(self.density_ratio[:, None], self.wq.shape[1], axis=1)
        scalar_load = LinearForm(lambda v, w: w.rho * v).assemble(b, rho=ratio)
        #: int N_s rho/rho_material dV per scalar dof (the weight of every region's rubber)
        self.volume_load = np.asarray(scalar_load)
        cnodes = self.facet_dofs.get(contact_set)
        self.contact_nodes = np.unique(cnodes) if cnodes is not None else np.zeros(0, int)
        self.contact = self._contact_surface(self_contact) if self_contact is not None else None
        log.info("P2 model: %d tets, %d unknowns, %d nonzeros (upper)", self.edofs.shape[0],
                 self.free.size, self.pattern.indices.size)

    @property
    def diag_pos(self) -> np.ndarray:
        """Position of each free dof's diagonal entry in the tangent's data."""
        return self.pattern.diag_pos

    # -- numbering ----------------------------------------------------------------------
    def _edge_lookup(self) -> tuple[np.ndarray, np.ndarray]:
        e = np.sort(self.skmesh.edges, axis=0)
        keys = e[0].astype(np.int64) * self.skmesh.nvertices + e[1]
        order = np.argsort(keys)
        return keys[order], order

    def _edge_ids(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        lo, hi = np.minimum(i, j), np.maximum(i, j)
        keys = lo.astype(np.int64) * self.skmesh.nvertices + hi
        pos = np.clip(np.searchsorted(self._edge_keys, keys), 0, self._edge_keys.size - 1)
        if np.any(self._edge_keys[pos] != keys):
            raise MeshingError("a facet edge is not an edge of the tetrahedra")
        return self._edge_order[pos]

    def _facet_dofs(self, name: str, facets: np.ndarray, warn: bool = True) -> np.ndarray:
        """(K, 6) scalar P2 dofs of a facet set, re-oriented outward of the solid."""
        f = np.array(facets, dtype=np.int64, copy=True)
        if f.max() >= self.skmesh.nvertices:
            raise MeshingError(f"facet set {name!r} refers to a node not in the mesh")
        sk = self.skmesh
        skf = np.sort(sk.facets, axis=0).astype(np.int64)
        n = sk.nvertices
        skeys = (skf[0] * n + skf[1]) * n + skf[2]
        order = np.argsort(skeys)
        fs = np.sort(f, axis=1)
        keys = (fs[:, 0] * n + fs[:, 1]) * n + fs[:, 2]
        pos = np.clip(np.searchsorted(skeys[order], keys), 0, order.size - 1)
        if np.any(skeys[order][pos] != keys):
            raise MeshingError(f"facet set {name!r} has triangles that are not tet faces")
        tet = sk.f2t[0, order[pos]]
        p = self.X[:sk.nvertices]
        normal = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])
        opposite = p[sk.t[:, tet].T].mean(axis=1) - p[f].mean(axis=1)
        flip = np.einsum("ij,ij->i", normal, opposite) > 0
        outer = sk.f2t[1, order[pos]] < 0  # an inner face (an embedded sheet's) has no outward side
        if warn and (flip & outer).any():
            log.warning("facet set %r: %d of %d triangles re-oriented outward", name,
                        int((flip & outer).sum()), len(f))
        f[flip] = f[flip][:, [0, 2, 1]]
        edges = [n + self._edge_ids(f[:, i], f[:, j]) for i, j in _TRI_EDGES]
        return np.ascontiguousarray(np.column_stack([f, *edges]))

    def _contact_surface(self, options: SelfContact) -> ContactSurface:
        """The outer surface (:func:`.contact.outer_faces`) as a :class:`ContactSurface`."""
        faces = outer_faces(self.skmesh.facets[:, self.skmesh.boundary_facets()].T, self.mesh.facets)
        return ContactSurface(self.X, self._facet_dofs("contact surface", faces, warn=False), options)

    def _build_membrane(self) -> None:
        fd = self.facet_dofs.get(STRAIN_LIMITING_LAYER)
        if self.membrane is None or fd is None:
            self.mem_dofs = None
            return
        pts, wts = get_quadrature(RefTri, 4)
        el = ElementTriP2()
        dref = np.stack([el.lbasis(pts, a)[1] for a in range(6)])  # (6, 2, nq)
        Xe = self.X[fd]  # (K, 6, 3)
        G = np.einsum("kai,adq->kqdi", Xe, dref)  # (K, nq, 2, 3) covariant base vectors
        t1 = G[:, :, 0] / np.linalg.norm(G[:, :, 0], axis=-1, keepdims=True)
        nrm = np.cross(G[:, :, 0], G[:, :, 1])
        area = np.linalg.norm(nrm, axis=-1)
        t2 = np.cross(nrm / area[..., None], t1)
        M = np.stack([np.einsum("kqdi,kqi->kqd", G, t) for t in (t1, t2)], axis=-1)
        dNs = np.einsum("adq,kqbd->kqab", dref, np.linalg.inv(M))
        self.mem_dofs = fd
        self.mem_nc = self.membrane.wrinkling_force_n_per_mm(self.substrate)
        self.mem_dNs = np.ascontiguousarray(dNs)
        self.mem_w = np.ascontiguousarray(area * wts)
        self.pattern.add("mem", fd)

    def _build_pressure(self) -> None:
        fd = self.facet_dofs.get(CAVITY)
        if fd is None:
            self.cav_dofs = None
            return
        pts, wts = get_quadrature(RefTri, 4)
        el = ElementTriP2()
        self.cav_N = np.ascontiguousarray(np.stack([el.lbasis(pts, a)[0] for a in range(6)]).T)
        dref = np.stack([el.lbasis(pts, a)[1] for a in range(6)])  # (6, 2, nq)
        self.cav_dN = np.ascontiguousarray(dref.transpose(2, 0, 1))
        self.cav_w = np.ascontiguousarray(wts)
        self.cav_dofs = fd
        self.pattern.add("cav", fd)

    # -- evaluation ---------------------------------------------------------------------
    def gravity_vector(self, gravity_n_per_mm3: Sequence[float]) -> np.ndarray:
        """Consistent nodal forces of a uniform force density (full length)."""
        return (self.volume_load[:, None] * np.asarray(gravity_n_per_mm3, float)).ravel()

    def stresses(self, u: np.ndarray, d: np.ndarray | None = None) -> Stresses:
        """Element pressures and sheet stresses at ``u``, plus their first-order change
        along the displacement ``d`` (full length) when given."""
        u = np.ascontiguousarray(u, dtype=float)
        d = np.zeros_like(u) if d is None else np.ascontiguousarray(d, dtype=float)
        pbar = np.zeros(self.edofs.shape[0])
        kernels.element_pressure(u, d, self.edofs, self.dN, self.wq, self.constants[3], pbar)
        sheet = None
        if self.mem_dofs is not None:
            mb = self.membrane
            sheet = np.zeros((*self.mem_w.shape, 3))
            surface.membrane_stress(u, d, self.X, self.mem_dofs, self.mem_dNs,
                                    mb.plane_stress_stiffness_n_per_mm, mb.poisson,
                                    self.mem_nc, mb.wrinkles, sheet)
        return Stresses(pbar, sheet)

    def evaluate(self, u: np.ndarray, load: Load, want_k: bool = False,
                 mixed: Stresses | None = None) -> Evaluation:
        """Residual, energy (and the reduced upper-triangular tangent) at ``u``; with
        ``mixed``, the tangent's stress terms use those stresses (see :mod:`.newton`)."""
        u = np.ascontiguousarray(u, dtype=float)
        R = np.zeros(self.ndof)
        Rext = np.zeros(self.ndof)
        touch = self.contact.terms(self.X + u.reshape(-1, 3), want_k) if self.contact is not None else None
        if want_k and touch is not None and self.pattern.lacks(touch.gdofs):
            self.pattern.positions(self.contact.listed_nodes())  # growing anyway: by every candidate's couplings
        kmap_touch = self.pattern.positions(touch.gdofs) if want_k and touch is not None else None
        data = np.zeros(self.pattern.indices.size) if want_k else None
        energy, inverted = self._solid(u, want_k, R, data, mixed)
        if inverted.size:
            return Evaluation(R, np.inf, False, 0.0, np.nan, 0.0, inverted=inverted)
        wrinkled = 0.0
        if self.mem_dofs is not None:
            w, wrinkled = self._membrane(u, want_k, R, data, mixed)
            energy += w
        volume, dvdu = np.nan, None
        if self.cav_dofs is not None:
            volume, dvdu = self._pressure(u, load.pressure_mpa, want_k, Rext, data)
            energy -= load.pressure_mpa * volume
        if any(load.gravity_n_per_mm3):
            fg = self.gravity_vector(load.gravity_n_per_mm3)
            Rext -= fg
            energy -= float(fg @ u)
        force = 0.0
        if load.plane_z_mm is not None and self.contact_nodes.size:
            k = load.plane_stiffness_n_per_mm
            zdofs = 3 * self.contact_nodes + 2
            gap = self.X[self.contact_nodes, 2] + u[zdofs] - load.plane_z_mm
            pen = np.minimum(gap, 0.0)
            energy += 0.5 * k * float(pen @ pen)
            np.add.at(Rext, zdofs, k * pen)
            force = float(-k * pen.sum())
            if want_k:
                fi = self.free_index[zdofs]
                sel = (gap <= 0) & (fi >= 0)  # touching counts as closed: the tip starts on the plane
                np.add.at(data, self.pattern.diag_pos[fi[sel]], k)
        if touch is not None:
            energy += self._self_contact(touch, kmap_touch, R, data)
        R += Rext
        ext = float(np.linalg.norm(Rext[self.free]))
        mtx = None
        if want_k:
            n = self.free.size
            mtx = sp.csr_matrix((data, self.pattern.indices, self.pattern.indptr), shape=(n, n))
        return Evaluation(R, energy, True, ext, volume, force, mtx, dvdu, np.zeros(0, np.int64),
                          wrinkled, touch.force_n if touch else 0.0, touch.pairs if touch else 0)

    @staticmethod
    def _self_contact(touch: ContactTerms, kmap: np.ndarray | None, R: np.ndarray,
                      data: np.ndarray | None) -> float:
        """Adds the self-contact's residual (and tangent, at ``kmap``); its energy."""
        kernels.scatter_vector(touch.residual, touch.gdofs, R)
        if data is not None:
            kernels.scatter_matrix(touch.tangent, kmap, data)
        return touch.energy

    def _solid(self, u: np.ndarray, want_k: bool, R: np.ndarray, data: np.ndarray | None,
               mixed: Stresses | None) -> tuple[float, np.ndarray]:
        """Elastomer energy; adds its residual (and tangent); indices of inverted tets."""
        mat = self.material
        mean_dil = mat.volumetric == "mean_dilatation"
        nel = self.edofs.shape[0]
        ntri = 465 if want_k else 1
        energy, bad_all = 0.0, []
        use = mixed is not None and want_k
        pbar = mixed.pbar if use else np.zeros(nel)
        for s in range(0, nel, _CHUNK):
            sl = slice(s, min(s + _CHUNK, nel))
            m = sl.stop - sl.start
            W, Re, bad = np.empty(m), np.empty((m, 30)), np.zeros(m, np.int8)
            Ke = np.empty((m, ntri))
            c10, c20, c30, kappa = self.constants[:, sl]
            kernels.solid(u, self.edofs[sl], self.dN[sl], self.wq[sl], c10, c20, c30, kappa,
                          mean_dil, want_k, use, pbar[sl], W, Re, Ke, bad)
            if bad.any():
                bad_all.append(s + np.flatnonzero(bad))
                continue
            if bad_all:
                continue
            energy += W.sum()
            kernels.scatter_vector(Re, self.edofs[sl], R)
            if want_k:
                kernels.scatter_matrix(Ke, self.pattern.maps["solid"][sl], data)
        inverted = np.concatenate(bad_all) if bad_all else np.zeros(0, np.int64)
        return energy, inverted

    def _membrane(self, u: np.ndarray, want_k: bool, R: np.ndarray, data: np.ndarray | None,
                  mixed: Stresses | None) -> tuple[float, float]:
        """Sheet energy and the wrinkled fraction; adds its residual (and tangent)."""
        mb = self.membrane
        nf = self.mem_dofs.shape[0]
        W, Re, Ke = np.empty(nf), np.empty((nf, 18)), np.empty((nf, 171 if want_k else 1))
        regime = np.zeros(nf, np.int64)
        use = mixed is not None and want_k and mixed.sheet is not None
        sheet = mixed.sheet if use else np.zeros((1, 1, 3))
        surface.membrane(u, self.X, self.mem_dofs, self.mem_dNs, self.mem_w,
                         mb.plane_stress_stiffness_n_per_mm, mb.poisson, self.mem_nc,
                         mb.wrinkles, want_k, use, sheet, W, Re, Ke, regime)
        kernels.scatter_vector(Re, self.mem_dofs, R)
        if want_k:
            kernels.scatter_matrix(Ke, self.pattern.maps["mem"], data)
        return float(W.sum()), float(regime.sum()) / self.mem_w.size

    def _pressure(self, u: np.ndarray, p: float, want_k: bool, Rext: np.ndarray,
                  data: np.ndarray | None) -> tuple[float, np.ndarray]:
        """Cavity volume and dV/du; adds the pressure's load (and its tangent) at ``p``."""
        nf = self.cav_dofs.shape[0]
        V, Re, Ke = np.empty(nf), np.empty((nf, 18)), np.empty((nf, 171 if want_k else 1))
        surface.pressure(u, self.X, self.cav_dofs, self.cav_N, self.cav_dN, self.cav_w, 1.0,
                         want_k and p != 0.0, V, Re, Ke)
        unit = np.zeros(self.ndof)  # the load of 1 MPa: -dV/du
        kernels.scatter_vector(Re, self.cav_dofs, unit)
        if p != 0.0:
            Rext += p * unit
            if want_k:
                Ke *= p
                kernels.scatter_matrix(Ke, self.pattern.maps["cav"], data)
        return float(V.sum()), -unit
