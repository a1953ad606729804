"""The actuator for SOFA (SoftRobots): a tet mesh, the cavity surface, the named node sets.

SOFA models are usually whole bodies with linear tetrahedra
(``TetrahedronFEMForceField``) and a cavity surface for ``SurfacePressureConstraint``, so a
half model (y >= 0) is mirrored into the whole actuator first (the y = 0 nodes merged).

- ``actuator.vtk``: legacy VTK 4.2 (ASCII) of the linear tetrahedra, mm (``MeshVTKLoader``);
- ``cavity.stl``: the cavity as a closed triangulated surface (binary STL, mm) on the same
  nodes, oriented outward of the air (normals into the elastomer; its signed volume is the
  cavity's volume);
- ``boundaries.json``: 0-based indices into ``actuator.vtk``'s points: ``clamp`` nodes (to
  fix), ``free_end`` nodes, the ``tip`` node, and the triangles of ``cavity`` and
  ``strain_limiting_layer`` (the paper, e.g. for a ``TriangularFEMForceField`` of E t);
- ``material.json`` (:func:`.constants.material_constants`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pnmold.errors import ExportError
from pnmold.fsutil import write_bytes, write_json, write_text
from pnmold.tetmesh import CAVITY, CLAMP, FREE_END, STRAIN_LIMITING_LAYER, SYMMETRY, TetMesh

_ON_PLANE_MM = 1e-9


def whole(mesh: TetMesh) -> TetMesh:
    """The whole body of a half model (mirrored in y = 0, the plane's nodes shared); a whole
    model as it is."""
    if not mesh.half:
        return mesh
    p = np.asarray(mesh.nodes_mm, float)
    mirrored = np.flatnonzero(np.abs(p[:, 1]) > _ON_PLANE_MM)
    image = np.arange(len(p))
    image[mirrored] = len(p) + np.arange(mirrored.size)
    nodes = np.vstack([p, p[mirrored] * [1.0, -1.0, 1.0]])
    tets = np.vstack([mesh.tets, image[mesh.tets][:, [0, 2, 1, 3]]])
    facets = {name: np.vstack([f, image[f][:, [0, 2, 1]]]) for name, f in mesh.facets.items() if name != SYMMETRY}
    return TetMesh(nodes, tets, facets, {}, mesh.tip_mm, False)


def cavity_surface(mesh: TetMesh) -> np.ndarray:
    """(k, 3) cavity triangles oriented outward of the air (into the elastomer)."""
    return np.asarray(mesh.facets.get(CAVITY, np.zeros((0, 3), int)))[:, [0, 2, 1]]


def open_edges(triangles: np.ndarray) -> int:
    """How many edges of ``triangles`` are not shared by exactly two of them (0: closed)."""
    edges = np.sort(triangles[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int(np.sum(counts != 2))


def enclosed_volume_mm3(nodes: np.ndarray, triangles: np.ndarray) -> float:
    """Signed volume enclosed by ``triangles`` (positive when their normals point outward)."""
    a, b, c = (nodes[triangles[:, i]] for i in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def legacy_vtk(mesh: TetMesh) -> str:
    """The linear tetrahedra as a legacy VTK 4.2 ASCII unstructured grid (the layout SOFA's
    ``MeshVTKLoader`` reads: ``CELLS`` with counts, ``CELL_TYPES`` 10)."""
    lines = ["# vtk DataFile Version 4.2", "pnmold actuator, linear tetrahedra, mm", "ASCII",
             "DATASET UNSTRUCTURED_GRID", f"POINTS {mesh.n_nodes} double"]
    lines += [f"{x:.9g} {y:.9g} {z:.9g}" for x, y, z in mesh.nodes_mm]
    lines.append(f"CELLS {mesh.n_tets} {5 * mesh.n_tets}")
    lines += [f"4 {a} {b} {c} {d}" for a, b, c, d in mesh.tets]
    lines.append(f"CELL_TYPES {mesh.n_tets}")
    lines += ["10"] * mesh.n_tets
    return "\n".join(lines) + "\n"


def write_sofa(folder: str | Path, mesh: TetMesh, material_doc: dict[str, Any]) -> list[Path]:
    """Write the SOFA files of ``mesh`` into ``folder``; return their paths.

    Raises
    ------
    ExportError : the cavity surface is not closed (SOFA's pressure needs a closed cavity).
    """
    import trimesh

    folder = Path(folder)
    body = whole(mesh)
    cavity = cavity_surface(body)
    if not len(cavity) or open_edges(cavity):
        raise ExportError(str(folder / "cavity.stl"), f"the cavity surface is not closed "
                          f"({open_edges(cavity) if len(cavity) else 'no'} open edges)")
    written = [write_text(folder / "actuator.vtk", legacy_vtk(body))]
    stl = trimesh.Trimesh(body.nodes_mm, cavity, process=False, validate=False).export(file_type="stl")
    written.append(write_bytes(folder / "cavity.stl", stl))
    tip = int(np.argmin(np.linalg.norm(body.nodes_mm - np.asarray(body.tip_mm), axis=1)))
    sets = {
        "schema": "pnmold.sofa-sets/1",
        "units": "mm; indices are 0-based into actuator.vtk's points",
        "whole_body": True,
        "clamp_nodes": _nodes(body, CLAMP),
        "free_end_nodes": _nodes(body, FREE_END),
        "tip_node": tip,
        "cavity_triangles": cavity.tolist(),
        "cavity_volume_mm3": enclosed_volume_mm3(body.nodes_mm, cavity),
        "strain_limiting_layer_triangles": np.asarray(body.facets.get(STRAIN_LIMITING_LAYER, [])).tolist(),
    }
    written.append(write_json(folder / "boundaries.json", sets))
    written.append(write_json(folder / "material.json", material_doc))
    return written


def _nodes(mesh: TetMesh, name: str) -> list[int]:
    return np.unique(np.asarray(mesh.facets.get(name, np.zeros((0, 3), int)))).astype(int).tolist()
