"""The quick FE stage of a build: mesh the exported STEP, bend it, report and plot.

design -> :func:`pnmold.mesh.mesh_actuator` (gmsh, the same ``actuator.step``) ->
:func:`pnmold.fem.solve_bending` (scikit-fem) -> the ``fem`` section of ``report.json``
and ``bending.png``. Gravity follows the test orientation (CONTRACTS.md §4); the build's
quick solve assumes the actuator lies chambers up (gravity along -z), as on a bench.
"""

from __future__ import annotations

import io
import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pnmold.design import Design
from pnmold.errors import SolveError
from pnmold.fem import Membrane, Solution, SolveOptions, Yeoh, blocked_force_slope, solve_bending
from pnmold.fsutil import write_bytes
from pnmold.mesh import MeshQuality, MeshSize, mesh_actuator
from pnmold.tetmesh import TetMesh

log = logging.getLogger(__name__)

WATER_DENSITY_G_PER_ML = 0.998  # at 20 °C
#: the build's quick solve stops here if the actuator has not closed into a circle (assumed)
QUICK_MAX_PRESSURE_KPA = 150.0
#: the build's preview mesh: coarser than the default MeshSize (2.5/5 mm). With gravity the
#: fPN's full-bend pressure was 48.0 kPa here (35k unknowns) and 47.5 kPa at 2.5/5 mm
#: (47k unknowns); benchmarks/fem.py prints the tip on this mesh and a finer one.
BUILD_MESH = MeshSize(3.2, 6.4)
#: the build's load stepping: bend increments of up to 70 degrees instead of 40 (a preview)
BUILD_OPTIONS = SolveOptions(max_angle_step_deg=70.0)
ORIENTATIONS = ("chambers_up", "chambers_down", "horizontal", "submerged", "none")


def gravity_vector(design: Design, orientation: str) -> tuple[float, float, float] | None:
    """Gravity in units of g in the actuator frame, net of buoyancy when submerged."""
    if orientation == "chambers_up":
        return (0.0, 0.0, -1.0)
    if orientation == "chambers_down":
        return (0.0, 0.0, 1.0)
    if orientation == "horizontal":
        return (0.0, -1.0, 0.0)  # out of the bending plane: needs the full (not half) model
    if orientation == "submerged":
        net = 1.0 - WATER_DENSITY_G_PER_ML / design.material.density_g_per_ml
        return (0.0, 0.0, -net)
    if orientation == "none":
        return None
    raise ValueError(f"unknown orientation {orientation!r}; one of {', '.join(ORIENTATIONS)}")


def material_of(design: Design) -> Yeoh:
    """The FE's elastomer; a library material's elongation at break ends the curve where
    the largest stretch passes it (``Solution.stop == "stretch_limit"``)."""
    from pnmold.errors import UsageError
    from pnmold.materials.library import get_material

    m = design.material
    try:
        stretch = 1.0 + get_material(m.name).elongation_at_break
    except UsageError:  # not a library material: no stretch stop
        stretch = None
    return Yeoh(c10_mpa=m.c10_mpa, c20_mpa=m.c20_mpa, c30_mpa=m.c30_mpa,
                density_g_per_ml=m.density_g_per_ml, stretch_at_break=stretch)


def membrane_of(design: Design) -> Membrane:
    p = design.paper
    return Membrane(modulus_mpa=p.modulus_mpa, poisson=p.poisson, thickness_mm=p.thickness_mm)


@dataclass(frozen=True, eq=False)
class FeRun:
    """A solved curve with the mesh it was solved on."""

    mesh: TetMesh
    quality: MeshQuality
    solution: Solution
    size: MeshSize
    orientation: str
    timings_s: dict[str, float]


def run_fe(design: Design, step_path: str | Path, *, size: MeshSize | None = None,
           orientation: str = "chambers_up", max_pressure_kpa: float = QUICK_MAX_PRESSURE_KPA,
           pressures_kpa: list[float] | None = None, options: SolveOptions | None = None,
           keep_partial: bool = False) -> FeRun:
    """Mesh ``step_path`` and bend it under cavity pressure (and gravity).

    With ``keep_partial``, a solver failure returns the curve up to the last converged
    step, its ``reason`` naming the failure; otherwise :class:`SolveError` propagates."""
    gravity = gravity_vector(design, orientation)
    size = size or MeshSize()
    if gravity is not None and abs(gravity[1]) > 0 and size.half:
        size = MeshSize(size.wall_mm, size.max_mm, size.band_mm, half=False)
    t0 = time.perf_counter()
    mesh, quality = mesh_actuator(step_path, design, size)
    t1 = time.perf_counter()
    kwargs = {"pressures_kpa": pressures_kpa} if pressures_kpa else {"max_pressure_kpa": max_pressure_kpa}
    try:
        solution = solve_bending(mesh, material_of(design), membrane_of(design), gravity=gravity,
                                 options=options, **kwargs)
    except SolveError as err:
        if not keep_partial or getattr(err, "partial", None) is None:
            raise
        log.warning("FE stopped: %s", err)
        solution = err.partial
    t2 = time.perf_counter()
    return FeRun(mesh, quality, solution, size, orientation, {"mesh": round(t1 - t0, 3), "solve": round(t2 - t1, 3)})


def fem_report(run: FeRun) -> dict[str, Any]:
    """The ``fem`` section of ``report.json`` (CONTRACTS.md §3)."""
    sol = run.solution
    keys = ("pressure_kpa", "tip_x_mm", "tip_z_mm", "bend_angle_deg", "cavity_volume_ml", "max_principal_stretch")
    steps = []
    for s in sol.steps:
        d = s.as_dict()
        steps.append({**{k: round(float(d[k]), 6) for k in keys},
                      "max_stretch_at_mm": [round(float(v), 3) for v in d["max_stretch_at_mm"]],
                      "clamp_reaction_n": [round(float(v), 6) for v in d["clamp_reaction_n"]]})
    return {
        "full_bend_pressure_kpa": None if sol.full_bend_pressure_kpa is None else round(sol.full_bend_pressure_kpa, 4),
        "reason": sol.reason,
        "max_pressure_kpa": round(sol.max_pressure_kpa, 4),
        "orientation": run.orientation,
        "mesh": {"nodes": run.quality.n_nodes, "tets": run.quality.n_tets, "half_model": run.size.half,
                 "wall_size_mm": run.size.wall_mm, "max_size_mm": run.size.max_mm,
                 "min_quality_gamma": round(run.quality.min_gamma, 4)},
        "solver": {k: (round(v, 3) if isinstance(v, float) else v) for k, v in sol.stats.items()},
        "steps": steps,
    }


def blocked_force_report(design: Design, run: FeRun, n_points: int = 9) -> dict[str, Any]:
    """``fem.blocked_force``: the tip force against a plane under the tip (supplement Fig. S6),
    to first order in pressure about the rest state on the plane, on the run's mesh and
    gravity, from 0 kPa to the free curve's last pressure."""
    t0 = time.perf_counter()
    try:
        slope = blocked_force_slope(run.mesh, material_of(design), membrane_of(design),
                                    gravity=gravity_vector(design, run.orientation))
    except SolveError as err:
        return {"reason": f"blocked-force solve failed: {err}", "steps": []}
    top = run.solution.max_pressure_kpa
    steps = [{"pressure_kpa": round(float(p), 4), "force_n": round(slope.force_n(p), 6)}
             for p in np.linspace(0.0, top, n_points)]
    return {"method": "linearised in pressure about the unpressurised actuator resting on the plane "
                      "(gravity applied); the nonlinear curve: pnmold simulate --model fe --kind force",
            "force0_n": round(slope.force0_n, 6), "slope_n_per_kpa": round(slope.slope_n_per_kpa, 8),
            "steps": steps, "seconds": round(time.perf_counter() - t0, 3)}


def boundary_triangles(mesh: TetMesh) -> np.ndarray:
    """(m, 3) node indices of the faces that belong to one tetrahedron only."""
    faces = mesh.tets[:, [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]].reshape(-1, 3)
    key = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return faces[counts[inverse.ravel()] == 1]


def stretch_field(mesh: TetMesh, displacement_mm: np.ndarray) -> np.ndarray:
    """Largest principal stretch per node: the largest over the tets around it, from the
    vertex displacements (linear interpolation: for pictures, not for the report's figure,
    which the P2 solution gives at its quadrature points)."""
    x0 = mesh.nodes_mm[mesh.tets]
    x1 = x0 + displacement_mm[mesh.tets]
    d0 = np.transpose(x0[:, 1:] - x0[:, :1], (0, 2, 1))
    d1 = np.transpose(x1[:, 1:] - x1[:, :1], (0, 2, 1))
    F = d1 @ np.linalg.inv(d0)
    lam = np.sqrt(np.linalg.eigvalsh(np.transpose(F, (0, 2, 1)) @ F)[:, -1])
    out = np.zeros(mesh.n_nodes)
    np.maximum.at(out, mesh.tets.ravel(), np.repeat(lam, 4))
    return out


def write_field(run: FeRun, path: str | Path) -> Path:
    """``fem_field.npz``: the last converged shape and its stretch on the boundary, for the
    report's strain picture (keys ``nodes_mm``, ``displacement_mm``, ``surface_tris``,
    ``stretch``, ``pressure_kpa``, ``half``)."""
    mesh, u = run.mesh, run.solution.displacement_mm
    buf = io.BytesIO()
    np.savez_compressed(buf, nodes_mm=mesh.nodes_mm, displacement_mm=u,
                        surface_tris=boundary_triangles(mesh), stretch=stretch_field(mesh, u),
                        pressure_kpa=run.solution.max_pressure_kpa, half=mesh.half)
    return write_bytes(path, buf.getvalue())


def deformed_outline(mesh: TetMesh, displacement: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(bottom, top): deformed x-z polylines of the bottom face and the roof along y = 0."""
    x0 = mesh.nodes_mm
    on_plane = np.abs(x0[:, 1]) < 1e-6
    z_top = x0[on_plane, 2].max()
    lines = []
    for z in (0.0, z_top):
        sel = np.where(on_plane & (np.abs(x0[:, 2] - z) < 1e-6))[0]
        sel = sel[np.argsort(x0[sel, 0])]
        lines.append((x0[sel] + displacement[sel])[:, [0, 2]])
    return lines[0], lines[1]


def bending_figure(design: Design, run: FeRun, path: str | Path, n_shapes: int = 6) -> Path:
    """``bending.png``: deformed shapes at several pressures, tip trajectory, angle, P-V."""
    from pnmold.plots import plot_bending

    sol = run.solution
    picks = sorted(set(np.linspace(0, len(sol.steps) - 1, min(n_shapes, len(sol.steps))).round().astype(int)))
    shapes = []
    for i in picks:
        if i < len(sol.shapes_mm):
            bottom, top = deformed_outline(run.mesh, sol.shapes_mm[i])
            shapes.append((sol.steps[i].pressure_kpa, bottom, top))
    title = (f"{design.name}: full bend at {sol.full_bend_pressure_kpa:.1f} kPa" if sol.full_bend_pressure_kpa
             else f"{design.name}: {sol.reason}")
    return plot_bending(title, fem_report(run)["steps"], shapes, path, sol.full_bend_pressure_kpa)
