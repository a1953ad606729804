"""``pnmold export DIR``: a build folder's FE problem for Abaqus/CalculiX or SOFA.

The mesh is made again from the build's own ``actuator.step`` and ``design.toml``, the way
the build's quick FE made it (:func:`pnmold.mesh.mesh_actuator` with the size recorded in
``report.json`` ``fem.mesh``, else :data:`pnmold.design_fe.BUILD_MESH`; gmsh runs on one
thread, so the mesh is the same node for node). The loads default to the build's: its
orientation (chambers up, gravity on) and the pressures of its converged FE steps.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pnmold.errors import UsageError
from pnmold.fsutil import read_json, staged_dir, write_json
from pnmold.tetmesh import MeshSize

from . import FORMATS

log = logging.getLogger(__name__)

DECK_NAME = "actuator.inp"


@dataclass(frozen=True)
class Exported:
    """What :func:`export_build` wrote, and the problem it describes."""

    format: str
    folder: Path
    files: tuple[Path, ...]
    pressures_kpa: tuple[float, ...]
    gravity_g: tuple[float, float, float] | None
    size: MeshSize
    nodes: int
    elements: int


def _read_build(build_dir: Path) -> tuple[Any, dict[str, Any]]:
    from pnmold.design import load_design

    if not (build_dir / "design.toml").is_file() or not (build_dir / "actuator.step").is_file():
        raise UsageError(f"{build_dir}: not a build folder (needs design.toml and actuator.step; "
                         "run `pnmold build` first)")
    report_path = build_dir / "report.json"
    report = read_json(report_path, "build report") if report_path.is_file() else {}
    return load_design(build_dir / "design.toml"), report.get("fem") or {}


def build_mesh_size(fem: dict[str, Any]) -> MeshSize:
    """The mesh size a build's FE used (``report.json`` ``fem.mesh``), else the build default."""
    from pnmold.design_fe import BUILD_MESH

    m = fem.get("mesh") or {}
    if m.get("wall_size_mm") and m.get("max_size_mm"):
        return MeshSize(float(m["wall_size_mm"]), float(m["max_size_mm"]), BUILD_MESH.band_mm,
                        bool(m.get("half_model", True)))
    return BUILD_MESH


def export_build(build_dir: str | Path, fmt: str = "abaqus", *, out_dir: str | Path | None = None,
                 pressures_kpa: Sequence[float] | None = None, orientation: str | None = None,
                 size: MeshSize | None = None, options=None) -> Exported:
    """Write the build folder's FE problem as ``fmt`` into ``out_dir`` (default ``DIR/<fmt>/``).

    Parameters
    ----------
    pressures_kpa : the deck's pressure steps (default: the build's converged FE pressures).
    orientation : where gravity points, or ``none`` (default: the build's, chambers up).
    size : the mesh (default: the build's, :func:`build_mesh_size`).
    options : :class:`.abaqus.DeckOptions` of the deck.
    """
    from pnmold.design_fe import fe_problem
    from pnmold.mesh import mesh_actuator

    from .abaqus import write_abaqus
    from .constants import material_constants
    from .p2 import quadratic_mesh
    from .sofa import whole, write_sofa

    if fmt not in FORMATS:
        raise UsageError(f"--format: one of {', '.join(FORMATS)}, got {fmt!r}")
    build_dir = Path(build_dir)
    design, fem = _read_build(build_dir)
    orientation = orientation or fem.get("orientation") or "chambers_up"
    problem = fe_problem(design, orientation=orientation, size=size or build_mesh_size(fem))
    design, size, direction = problem.design, problem.size, problem.gravity_g
    steps = fem.get("steps") or []
    pressures = tuple(float(p) for p in (pressures_kpa if pressures_kpa is not None
                                         else [s["pressure_kpa"] for s in steps]) if float(p) > 0)
    if fmt == "abaqus" and not pressures:
        raise UsageError(f"{build_dir}: the build has no FE curve (built with --no-fem?); give --pressures A:B:STEP")
    stretches = [s.get("max_principal_stretch") for s in steps if s.get("max_principal_stretch")]
    material, membrane = problem.material, problem.membrane
    doc = material_constants(material, membrane, max_stretch=max(stretches) if stretches else None,
                             stretch_source="largest principal stretch of the build's FE curve (report.json)"
                             if stretches else None)
    regions = problem.regions
    for name, rubber in regions.items():  # a second rubber: its constants beside the body's
        doc.setdefault("regions", {})[name] = {
            **{k: v for k, v in material_constants(rubber, None).items() if k not in ("schema", "units")},
            "elements": f"the deck's element set {name.upper()}; in SOFA's mesh the tetrahedra whose centroid "
                        f"lies between z = {design.bottom_z0_mm:g} and {design.top_z0_mm:g} mm"}
    mesh, _ = mesh_actuator(build_dir / "actuator.step", design, size)
    out = Path(out_dir) if out_dir is not None else build_dir / fmt
    with staged_dir(out, f"{fmt} export") as tmp:
        if fmt == "sofa":
            written = write_sofa(tmp, mesh, doc)
            body = whole(mesh)
            nodes, elements = body.n_nodes, body.n_tets
        else:
            qmesh = quadratic_mesh(mesh)
            deck = write_abaqus(tmp / DECK_NAME, qmesh, material, membrane, pressures_kpa=pressures,
                                gravity_g=direction, options=options,
                                title=f"pnmold {design.name}: the build's quick FE", regions=regions)
            written = [deck, write_json(tmp / "material.json", doc)]
            nodes, elements = qmesh.n_nodes, len(qmesh.cells)
    files = [out / Path(f).relative_to(tmp) for f in written]
    log.info("exported %s of %s to %s", fmt, build_dir, out)
    return Exported(fmt, out, tuple(files), pressures, direction, size, nodes, elements)
