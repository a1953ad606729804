"""What a solve reports: :class:`Step` per converged load, :class:`Solution` per curve.

Observables follow docs/frame-and-units.md: the tip is the mesh's ``tip_mm`` point followed
by the displacement field (P2-interpolated inside its tetrahedron); the bend angle is the
best-fit rotation about +y of the ``free_end`` face's nodes, positive when the actuator
curls toward -z (the paper side), unwrapped along the curve so a full circle is 360.
Forces and volumes of a half model are reported for the whole actuator.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from ..conventions import full_bend_crossing
from ..errors import MeshingError
from ..tetmesh import CLAMP, FREE_END
from .model import Evaluation, Model


def largest_stretch_squared(F: np.ndarray) -> np.ndarray:
    """The largest eigenvalue of ``C = F^T F`` for every (..., 3, 3) deformation gradient: the
    largest principal stretch squared, in closed form (Smith, Commun. ACM 4:168, 1961: the
    symmetric 3x3 eigenvalues as ``q + 2 p cos(phi)``), 4x faster than ``numpy.linalg.eigvalsh``
    and equal to it to 1e-12 relative, to 1e-8 where the largest eigenvalue is repeated (the
    arccos near its end; ``tests/test_fem.py``)."""
    C = np.matmul(np.swapaxes(F, -1, -2), F)
    a, b, c = C[..., 0, 0], C[..., 1, 1], C[..., 2, 2]
    d, e, f = C[..., 0, 1], C[..., 1, 2], C[..., 0, 2]
    q = (a + b + c) / 3.0
    aq, bq, cq = a - q, b - q, c - q
    p = np.sqrt((aq * aq + bq * bq + cq * cq + 2.0 * (d * d + e * e + f * f)) / 6.0)
    det = aq * (bq * cq - e * e) - d * (d * cq - e * f) + f * (d * e - bq * f)
    r = np.divide(det, 2.0 * p ** 3, out=np.zeros_like(p), where=p > 0)  # p = 0: C = q I
    return q + 2.0 * p * np.cos(np.arccos(np.clip(r, -1.0, 1.0)) / 3.0)


@dataclass(frozen=True)
class Step:
    """One converged load step (mm, degrees, mL, N; tip and stretch site in the frame)."""

    pressure_kpa: float
    tip_x_mm: float
    tip_z_mm: float
    bend_angle_deg: float
    cavity_volume_ml: float
    max_principal_stretch: float
    max_stretch_at_mm: tuple[float, float, float]
    clamp_reaction_n: tuple[float, float, float]
    force_n: float | None = None

    def as_dict(self) -> dict:
        """Plain values for JSON (``report.json`` ``fem.steps``)."""
        d = asdict(self)
        d["max_stretch_at_mm"] = list(self.max_stretch_at_mm)
        d["clamp_reaction_n"] = list(self.clamp_reaction_n)
        if self.force_n is None:
            del d["force_n"]
        return d


@dataclass(frozen=True)
class PressureMaximum:
    """The highest pressure along a volume-controlled curve (a limit point): past it the
    actuator inflates further at a falling pressure, so under a pressure regulator it
    would snap; a syringe follows it."""

    pressure_kpa: float
    bend_angle_deg: float
    cavity_volume_ml: float

    def describe(self) -> str:
        return (f"pressure maximum of {self.pressure_kpa:.4g} kPa at {self.bend_angle_deg:.1f} deg "
                f"bend and {self.cavity_volume_ml:.4g} mL")


#: why a curve ended: the physical stops, and a solver failure
STOPS = ("full_bend", "pressure_limit", "pressure_maximum", "stretch_limit", "tip_meets_base",
         "instability", "targets", "failed")


@dataclass(frozen=True, eq=False)
class Solution:
    """A pressure curve.

    Attributes
    ----------
    steps : converged steps, the first at 0 kPa (after gravity, if any).
    displacement_mm : (n_nodes, 3) displacement of the TetMesh nodes at the last step.
    full_bend_pressure_kpa : pressure at which the bend angle reaches 360 degrees
        (linearly interpolated between steps), or None; then ``reason`` says why.
    stats : unknowns, increments, factorisations, timings (s).
    shapes_mm : (n_nodes, 3) displacement at every step, for pictures of the bend.
    states : the full P2 displacement vector (mm) at every step, node-major ``3 s + c`` in the
        numbering of scikit-fem's ``ElementTetP2`` on ``MeshTet(mesh.nodes_mm.T, mesh.tets.T)``
        (vertices first, then edge nodes), for field output (:mod:`pnmold.export`).
    stop : why the curve ended, one of :data:`STOPS` ("failed" for a partial curve).
    pressure_maximum : the pressure maximum met along the curve, or None.
    contact_pressure_mpa : with self-contact, the contact pressure (MPa) at every P2 node at every
        step (:meth:`.contact.ContactSurface.nodal_pressure`); empty without.
    rest_weight_g : None when the 0 kPa step carries the whole weight; else the weight (g) it carries,
        the body having lost stability under its own weight before any pressure (``stop`` instability).
    """

    steps: tuple[Step, ...]
    displacement_mm: np.ndarray
    full_bend_pressure_kpa: float | None
    reason: str | None = None
    stats: dict = field(default_factory=dict)
    shapes_mm: tuple[np.ndarray, ...] = ()  # displacement of the mesh nodes at every step
    states: tuple[np.ndarray, ...] = ()  # the full P2 displacement vector at every step
    stop: str = "full_bend"
    pressure_maximum: PressureMaximum | None = None
    contact_pressure_mpa: tuple[np.ndarray, ...] = ()
    rest_weight_g: float | None = None

    @property
    def max_pressure_kpa(self) -> float:
        return self.steps[-1].pressure_kpa if self.steps else 0.0

    def to_dataframe(self):
        """The steps as a pandas DataFrame, one row per converged step, the columns of
        :meth:`Step.as_dict` (``pip install 'pnmold[pandas]'``; UsageError without pandas)."""
        from ..frames import dataframe

        return dataframe([s.as_dict() for s in self.steps])


def full_bend_pressure(steps: tuple[Step, ...] | list[Step]) -> tuple[float | None, str | None]:
    """Pressure where the bend angle first reaches 360 degrees, or (None, reason)."""
    return full_bend_crossing([s.pressure_kpa for s in steps], [s.bend_angle_deg for s in steps])


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class Observer:
    """Computes a :class:`Step` from a converged state; keeps the angle unwrapped."""

    def __init__(self, model: Model):
        self.model = model
        self.scale = 2.0 if model.mesh.half else 1.0
        self._tip_dofs, self._tip_w = self._locate(np.asarray(model.mesh.tip_mm, float))
        end = model.facet_dofs.get(FREE_END)
        if end is None:
            raise MeshingError(f"the mesh has no {FREE_END!r} facets for the bend angle")
        self._end = np.unique(end)
        self._end_ref = model.X[self._end][:, [0, 2]]
        self._end_ref = self._end_ref - self._end_ref.mean(axis=0)
        self._clamp = model.fixed_sets.get(CLAMP)
        self._xq = np.asarray(model.basis.global_coordinates())  # (3, nel, nq)
        self._angle = 0.0

    def _locate(self, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """P2 dofs and shape values at ``point`` (reference frame)."""
        m = self.model
        sk = m.skmesh
        p = sk.p.T[sk.t.T]  # (nel, 4, 3)
        T = np.transpose(p[:, 1:] - p[:, :1], (0, 2, 1))
        lam123 = np.linalg.solve(T, (point - p[:, 0])[:, :, None])[:, :, 0]
        lam = np.column_stack([1.0 - lam123.sum(axis=1), lam123])
        e = int(np.argmax(lam.min(axis=1)))
        if lam[e].min() < -1e-6:
            raise MeshingError(f"the tip {tuple(point)} lies outside the mesh")
        lam = np.clip(lam[e], 0.0, 1.0)
        lam /= lam.sum()
        verts = sk.t[:, e]
        pairs = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
        ii = np.array([i for i, _ in pairs])
        jj = np.array([j for _, j in pairs])
        edges = sk.nvertices + m._edge_ids(verts[ii], verts[jj])
        dofs = np.concatenate([verts, edges])
        w = np.concatenate([lam * (2.0 * lam - 1.0), 4.0 * lam[ii] * lam[jj]])
        return dofs, w

    def displacement_at_tip(self, u: np.ndarray) -> np.ndarray:
        return self._tip_w @ u.reshape(-1, 3)[self._tip_dofs]

    def bend_angle(self, u: np.ndarray) -> float:
        """Unwrapped rotation about +y of the free-end face, radians."""
        cur = (self.model.X + u.reshape(-1, 3))[self._end][:, [0, 2]]
        cur = cur - cur.mean(axis=0)
        ref = self._end_ref
        s = float(np.sum(cur[:, 0] * ref[:, 1] - cur[:, 1] * ref[:, 0]))
        c = float(np.sum(cur[:, 0] * ref[:, 0] + cur[:, 1] * ref[:, 1]))
        raw = math.atan2(s, c)
        self._angle += _wrap(raw - self._angle)
        return self._angle

    def max_stretch(self, u: np.ndarray) -> tuple[float, tuple[float, float, float]]:
        m = self.model
        ue = u.reshape(-1, 3)[m.edofs]  # (nel, 10, 3)
        lam2 = largest_stretch_squared(np.matmul(ue.transpose(0, 2, 1)[:, None], m.dN) + np.eye(3))
        e, q = np.unravel_index(int(np.argmax(lam2)), lam2.shape)
        where = tuple(float(v) for v in self._xq[:, e, q])
        return float(np.sqrt(lam2[e, q])), where

    def reaction(self, ev: Evaluation) -> tuple[float, float, float]:
        if self._clamp is None:
            return (0.0, 0.0, 0.0)
        r = ev.residual.reshape(-1, 3)[self._clamp].sum(axis=0) * self.scale
        if self.model.mesh.half:
            r[1] = 0.0
        return (float(r[0]), float(r[1]), float(r[2]))

    def step(self, pressure_kpa: float, u: np.ndarray, ev: Evaluation,
             force: bool = False) -> Step:
        """Observables of the converged state ``u`` (``ev`` evaluated at ``u``)."""
        tip = np.asarray(self.model.mesh.tip_mm, float) + self.displacement_at_tip(u)
        stretch, where = self.max_stretch(u)
        volume = ev.cavity_volume_mm3 * self.scale / 1000.0
        return Step(pressure_kpa=float(pressure_kpa), tip_x_mm=float(tip[0]),
                    tip_z_mm=float(tip[2]), bend_angle_deg=math.degrees(self.bend_angle(u)),
                    cavity_volume_ml=float(volume) if np.isfinite(volume) else 0.0,
                    max_principal_stretch=stretch, max_stretch_at_mm=where,
                    clamp_reaction_n=self.reaction(ev),
                    force_n=ev.contact_force_n * self.scale if force else None)
