"""Each exported part is a clean closed solid: the checks a slicer would otherwise hide."""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from pnmold.checks import measure
from pnmold.checks.context import BuildFiles
from pnmold.checks.findings import Finding, at_least, at_most, equal
from pnmold.checks.stlio import load_stl

_DEGENERATE_AREA_MM2 = 1e-9


def edge_counts(faces: np.ndarray) -> tuple[int, int]:
    """(edges not shared by exactly two faces, edges two faces traverse the same way)."""
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    undirected = np.sort(directed, axis=1)
    _, counts = np.unique(undirected, axis=0, return_counts=True)
    _, dcounts = np.unique(directed, axis=0, return_counts=True)
    return int(np.sum(counts != 2)), int(np.sum(dcounts > 1))


def surface_pieces(mesh) -> int:
    """Connected pieces of the surface (faces joined through shared corners)."""
    faces = np.asarray(mesh.faces)
    n = len(mesh.vertices)
    rows = np.repeat(faces[:, 0], 2)
    cols = faces[:, 1:].reshape(-1)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return int(len(np.unique(labels[faces[:, 0]])))


def check_part(files: BuildFiles, name: str) -> list[Finding]:
    path = files.path(name)
    if not path.is_file():
        return [Finding(f"mesh.exists.{name}", False, None, None, f"{path.name} is missing")]
    mesh = load_stl(path)
    bad_edges, same_way = edge_counts(np.asarray(mesh.faces))
    degenerate = int(np.sum(np.asarray(mesh.area_faces) <= _DEGENERATE_AREA_MM2))
    solid = files.solid(name)
    n_bodies = measure.bodies(solid) if solid is not None else surface_pieces(mesh)
    return [
        at_most(f"mesh.watertight.{name}", bad_edges, 0,
                f"{name}: edges not shared by exactly two faces"),
        at_most(f"mesh.winding.{name}", same_way, 0,
                f"{name}: edges whose two faces are wound the same way (flipped faces)"),
        at_least(f"mesh.volume.{name}", float(mesh.volume), 1e-6,
                 f"{name}: enclosed volume (negative when the faces point inward)", " mm3"),
        equal(f"mesh.bodies.{name}", n_bodies, 1, f"{name}: separate bodies"),
        at_most(f"mesh.degenerate.{name}", degenerate, 0, f"{name}: faces of zero area"),
    ]


def check_meshes(files: BuildFiles) -> list[Finding]:
    return [f for name in files.design.part_names for f in check_part(files, name)]
