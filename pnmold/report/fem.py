"""What a build writes of its quick FE (:func:`write_fe_section`): the ``fem`` section of
``report.json``, the blocked force, ``fem_field.npz``, ``bending.png`` and the ParaView files
``fem/bending.pvd``, ``fem/step_NNN.vtu``."""

from __future__ import annotations

import dataclasses
import io
import time
from pathlib import Path
from typing import Any

import numpy as np

from pnmold.design_fe import FeRun
from pnmold.errors import SolveError
from pnmold.fem import blocked_force_slope
from pnmold.fem.linsolve import choose_linear_solver
from pnmold.fsutil import write_bytes
from pnmold.tetmesh import TetMesh


def write_fe_section(run: FeRun, folder: Path) -> dict[str, Any]:
    """Write the quick FE's files of ``run`` into the build ``folder``; the report's ``fem`` section."""
    bending_figure(run, folder / "bending.png")
    write_field(run, folder / "fem_field.npz")
    section = fem_report(run)
    section["paraview"] = write_paraview(run, folder)
    section["blocked_force"] = blocked_force_report(run)
    section["timings_s"] = {**run.timings_s, "blocked_force": section["blocked_force"].get("seconds")}
    return section


def failed_fe_section(err: Exception) -> dict[str, Any]:
    """The ``fem`` section of a quick FE where nothing converged: no curve, the reason."""
    return {"full_bend_pressure_kpa": None, "reason": f"failed: {err}", "max_pressure_kpa": None,
            "stop": "failed", "steps": []}


def fem_report(run: FeRun) -> dict[str, Any]:
    """The ``fem`` section of ``report.json`` (docs/json-schemas.md)."""
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
        "stop": sol.stop,
        "pressure_maximum": (None if sol.pressure_maximum is None else
                             {k: round(float(v), 4) for k, v in dataclasses.asdict(sol.pressure_maximum).items()}),
        "max_pressure_kpa": round(sol.max_pressure_kpa, 4),
        "orientation": run.orientation,
        "mesh": {"nodes": run.quality.n_nodes, "tets": run.quality.n_tets, "half_model": run.size.half,
                 "wall_size_mm": run.size.wall_mm, "max_size_mm": run.size.max_mm,
                 "min_quality_gamma": round(run.quality.min_gamma, 4)},
        "solver": {"linear_solver": choose_linear_solver(),
                   **{k: (round(v, 3) if isinstance(v, float) else v) for k, v in sol.stats.items()}},
        "steps": steps,
        "self_contact": _self_contact_report(sol),
    }


def _self_contact_report(sol) -> dict[str, Any] | None:
    """``fem.self_contact``: None without self-contact; with it the largest contact pressure (kPa)
    at each step and the first pressure where the walls touch (None if they never do)."""
    if not sol.contact_pressure_mpa:
        return None
    peak = [round(1000.0 * float(np.max(c, initial=0.0)), 4) for c in sol.contact_pressure_mpa]
    first = next((s.pressure_kpa for s, c in zip(sol.steps, peak, strict=False) if c > 0), None)
    return {"max_contact_pressure_kpa": peak, "first_contact_kpa": None if first is None else round(first, 4)}


def blocked_force_report(run: FeRun, n_points: int = 9) -> dict[str, Any]:
    """``fem.blocked_force``: the tip force against a plane under the tip (supplement Fig. S6),
    to first order in pressure about the rest state on the plane, on the run's mesh and
    gravity, from 0 kPa to the free curve's last pressure."""
    t0 = time.perf_counter()
    try:
        slope = blocked_force_slope(run.mesh, run.problem.material, run.problem.membrane, gravity=run.gravity_g,
                                    regions=run.problem.regions)
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
    ``stretch``, ``pressure_kpa``, ``half``; with self-contact ``contact_kpa``, the contact
    pressure at the mesh's vertices, the first of the P2 nodes)."""
    mesh, u, sol = run.mesh, run.solution.displacement_mm, run.solution
    extra = {"contact_kpa": 1000.0 * sol.contact_pressure_mpa[-1][:mesh.n_nodes]} if sol.contact_pressure_mpa else {}
    buf = io.BytesIO()
    np.savez_compressed(buf, nodes_mm=mesh.nodes_mm, displacement_mm=u,
                        surface_tris=boundary_triangles(mesh), stretch=stretch_field(mesh, u),
                        pressure_kpa=sol.max_pressure_kpa, half=mesh.half, **extra)
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


def bending_figure(run: FeRun, path: str | Path, n_shapes: int = 6) -> Path:
    """``bending.png``: deformed shapes at several pressures, tip trajectory, angle, P-V."""
    from pnmold.plots import plot_bending

    sol = run.solution
    picks = sorted(set(np.linspace(0, len(sol.steps) - 1, min(n_shapes, len(sol.steps))).round().astype(int)))
    shapes = []
    for i in picks:
        if i < len(sol.shapes_mm):
            bottom, top = deformed_outline(run.mesh, sol.shapes_mm[i])
            shapes.append((sol.steps[i].pressure_kpa, bottom, top))
    name = run.design.name
    title = (f"{name}: full bend at {sol.full_bend_pressure_kpa:.1f} kPa" if sol.full_bend_pressure_kpa
             else f"{name}: {sol.reason}")
    plot_bending(title, fem_report(run)["steps"], shapes, path, sol.full_bend_pressure_kpa)
    return Path(path)


def write_paraview(run: FeRun, folder: str | Path) -> dict[str, Any]:
    """``fem/bending.pvd`` and ``fem/step_NNN.vtu`` in ``folder``: every converged step on the
    quadratic mesh (:mod:`pnmold.export.vtu`); the report's ``fem.paraview`` entry (``pvd``
    None with the ``reason`` when they could not be written: the build goes on)."""
    from pnmold.errors import ExportError
    from pnmold.export.vtu import write_vtu_series

    try:
        index = write_vtu_series(run.mesh, run.solution, Path(folder) / "fem")
    except ExportError as err:
        return {"pvd": None, "reason": str(err)}
    point_data = ["displacement_mm", "max_principal_stretch"] + (["contact_pressure_mpa"] if
                                                                   run.solution.contact_pressure_mpa else [])
    return {"pvd": f"fem/{index.name}", "steps": len(run.solution.steps), "point_data": point_data,
            "cells": "10-node tetrahedra"}
