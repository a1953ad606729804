"""gmsh meshes the exported ``actuator.step`` into a :class:`~pnmold.tetmesh.TetMesh`.

The very file the printer's molds were checked against is read back; the tube seated in
the inlet bore is modelled by filling the bore up to the channel's start, so the cavity
(chambers, channel and the bore's tail) is closed and the pressure load conservative.
By default only the half y >= 0 is meshed (the ``symmetry`` plane carries u_y = 0).

Boundary facets are found from the tetrahedra (each facet oriented outward) and named by
where they lie, using the design's layout: ``cavity`` inside the cores' closure,
``clamp`` on the top and bottom faces of the proximal chamber (supplement: "zero
displacements at the top and bottom face of the proximal pneu-net chamber"), or of the first
``clamp.length_mm``,
``strain_limiting_layer`` on the bottom face under the paper sheet (or, for a sheet inside the body --
embedded ``paper.depth_mm`` above the bottom layer's face, or over a passive side -- the tetrahedra's
inner faces on its plane, which the mesh is made to conform to), ``free_end`` at x = L,
``symmetry`` on y = 0. No gmsh state leaves this module.
"""

from __future__ import annotations

import logging
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import gmsh
import numpy as np

from pnmold.design import Design
from pnmold.errors import MeshingError
from pnmold.tetmesh import (
    BOTTOM_LAYER,
    CAVITY,
    CLAMP,
    ELASTOMER,
    FREE_END,
    STRAIN_LIMITING_LAYER,
    SYMMETRY,
    MeshSize,
    TetMesh,
)

log = logging.getLogger(__name__)
_TOL = 1e-3


@dataclass(frozen=True)
class MeshQuality:
    n_nodes: int
    n_tets: int
    min_gamma: float  # gmsh's inscribed/circumscribed radius ratio, 1 = regular
    mean_gamma: float
    min_volume_mm3: float


def _cores(design: Design):
    """Axis-aligned boxes of the air cavity (chambers and channel), with the bore tail."""
    boxes = [*design.chamber_boxes_mm, design.channel_box_mm]
    r = design.inlet.diameter_mm / 2
    zc = design.inlet_axis_z_mm
    boxes.append(((design.channel_x_mm[0], design.inlet_depth_mm), (-r, r), (zc - r, zc + r)))
    return boxes


def _inside(points: np.ndarray, boxes, tol: float = _TOL) -> np.ndarray:
    mask = np.zeros(len(points), bool)
    for (x0, x1), (y0, y1), (z0, z1) in boxes:
        mask |= ((points[:, 0] >= x0 - tol) & (points[:, 0] <= x1 + tol) & (points[:, 1] >= y0 - tol)
                 & (points[:, 1] <= y1 + tol) & (points[:, 2] >= z0 - tol) & (points[:, 2] <= z1 + tol))
    return mask


#: the faces of a positively oriented tetrahedron (0, 1, 2, 3), wound with the outward normal
_TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _distinct_faces(tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each distinct triangle of the tetrahedra (as first wound) and how many tetrahedra share it."""
    faces = tets[:, _TET_FACES].reshape(-1, 3)
    _, index, counts = np.unique(np.sort(faces, axis=1), axis=0, return_index=True, return_counts=True)
    return faces[index], counts


def boundary_facets(tets: np.ndarray) -> np.ndarray:
    """Facets that belong to one tetrahedron only, wound with the outward normal."""
    faces, counts = _distinct_faces(tets)
    return faces[counts == 1]


def _in_paper_outline(centre: np.ndarray, design: Design) -> np.ndarray:
    px, py = design.paper_size_mm
    i = design.paper.inset_mm
    x = centre[:, 0]
    return (x >= i - _TOL) & (x <= i + px + _TOL) & (np.abs(centre[:, 1]) <= py / 2 + _TOL)


def embedded_sheet(nodes: np.ndarray, tets: np.ndarray, design: Design) -> np.ndarray:
    """The inner faces on the plane of a sheet inside the body (``Design.sheet_z_mm`` above the bottom
    face), within its outline (none for a sheet on the bottom face or no sheet)."""
    if not design.paper.present or design.sheet_z_mm <= 0:
        return np.zeros((0, 3), np.int64)
    faces, _ = _distinct_faces(tets)
    p = nodes[faces]
    flat = np.all(np.abs(p[:, :, 2] - design.sheet_z_mm) < _TOL, axis=1)
    return faces[flat & _in_paper_outline(p.mean(axis=1), design)]


def name_facets(nodes: np.ndarray, facets: np.ndarray, design: Design, half: bool) -> dict[str, np.ndarray]:
    p = nodes[facets]
    centre = p.mean(axis=1)
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    x, z = centre[:, 0], centre[:, 2]
    on_symmetry = (np.abs(centre[:, 1]) < _TOL) & (normal[:, 1] < -0.99) if half else np.zeros(len(p), bool)
    cavity = _inside(centre, _cores(design)) & ~on_symmetry
    proximal = x <= design.clamp_end_mm + _TOL
    top = (np.abs(z - design.height_mm) < _TOL) & (normal[:, 2] > 0.99)
    bottom = (np.abs(z) < _TOL) & (normal[:, 2] < -0.99)
    under_paper = bottom & _in_paper_outline(centre, design) & design.paper.present & (design.sheet_z_mm <= 0)
    free_end = (np.abs(x - design.length_mm) < _TOL) & (normal[:, 0] > 0.99)
    named = {CAVITY: cavity, CLAMP: proximal & (top | bottom), STRAIN_LIMITING_LAYER: under_paper,
             FREE_END: free_end}
    if half:
        named[SYMMETRY] = on_symmetry
    return {k: facets[v] for k, v in named.items()}


def _geometry(step: Path, design: Design, half: bool) -> list[int]:
    occ = gmsh.model.occ
    entities = occ.importShapes(str(step))
    solids = [t for d, t in entities if d == 3]
    if len(solids) != 1:
        raise MeshingError(f"{step}: expected one solid, found {len(solids)}")
    r = design.inlet.diameter_mm / 2 * 1.001
    tube = occ.addCylinder(0, 0, design.inlet_axis_z_mm, design.channel_x_mm[0], 0, 0, r)
    out, _ = occ.fuse([(3, solids[0])], [(3, tube)])
    if half:
        L, W, H = design.length_mm, design.width_mm, design.height_mm
        keep = occ.addBox(-1, 0, -1, L + 2, W / 2 + 1, H + 2)
        out, _ = occ.intersect(out, [(3, keep)])
    occ.synchronize()
    if len(gmsh.model.getEntities(3)) != 1:
        raise MeshingError(f"{step}: filling the inlet gave {len(gmsh.model.getEntities(3))} solids")
    # imprint the paper's outline on the bottom face and the clamp's end on the top and
    # bottom faces, so that the mesh conforms to both; a bottom layer of its own rubber is cut
    # off at its top face, so that every element is one rubber or the other
    tools = []
    if design.paper.present:
        px, py = design.paper_size_mm
        y0 = 0.0 if half else -py / 2
        tools.append((2, occ.addRectangle(design.paper.inset_mm, y0, design.sheet_z_mm, px,
                                          py / 2 if half else py)))
    x_clamp = design.clamp_end_mm
    cut = occ.addRectangle(-2.0, -design.width_mm, 0.0, design.height_mm + 4, 2 * design.width_mm)
    occ.rotate([(2, cut)], 0, 0, 0, 0, 1, 0, -np.pi / 2)
    occ.translate([(2, cut)], x_clamp, 0, 0)
    tools.append((2, cut))
    if design.layer_material.name:
        for z in {design.bottom_z0_mm, design.top_z0_mm} - {0.0}:
            tools.append((2, occ.addRectangle(-1.0, -design.width_mm, z, design.length_mm + 2, 2 * design.width_mm)))
    occ.fragment(gmsh.model.occ.getEntities(3), tools)
    occ.synchronize()
    loose = [(2, t) for _, t in gmsh.model.getEntities(2) if len(gmsh.model.getAdjacencies(2, t)[0]) == 0]
    occ.remove(loose, recursive=True)
    occ.synchronize()
    return [t for _, t in gmsh.model.getEntities(3)]


def _size_field(design: Design, size: MeshSize) -> None:
    """Fine within the band around the cavity faces, coarse elsewhere."""
    surfaces = gmsh.model.getEntities(2)
    cores = _cores(design)
    near = []
    for _, tag in surfaces:
        c = np.asarray(gmsh.model.occ.getCenterOfMass(2, tag))[None, :]
        if _inside(c, cores)[0]:
            near.append(tag)
    field = gmsh.model.mesh.field
    dist = field.add("Distance")
    field.setNumbers(dist, "SurfacesList", near)
    thr = field.add("Threshold")
    field.setNumber(thr, "InField", dist)
    field.setNumber(thr, "SizeMin", size.wall_mm)
    field.setNumber(thr, "SizeMax", size.max_mm)
    field.setNumber(thr, "DistMin", size.band_mm)
    field.setNumber(thr, "DistMax", size.band_mm + 3 * size.max_mm)
    field.setAsBackgroundMesh(thr)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


@contextmanager
def gmsh_session() -> Iterator[None]:
    """gmsh initialised, quiet, and finalised on leaving.

    ``gmsh.initialize`` resets SIGPIPE to its default action (kill the process), undoing
    Python's SIG_IGN; a later write to a pipe whose reader has died -- a sweep's process
    pool after a worker crashed -- then killed the whole process (exit 141) instead of
    raising BrokenPipeError. Python's disposition is put back at once (where there is a
    SIGPIPE: not on Windows)."""
    sigpipe = getattr(signal, "SIGPIPE", None)
    before = None if sigpipe is None else signal.getsignal(sigpipe)
    gmsh.initialize(interruptible=False)
    if threading.current_thread() is threading.main_thread() and before is not None:
        signal.signal(sigpipe, before)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        yield
    finally:
        gmsh.finalize()


def mesh_actuator(step: str | Path, design: Design, size: MeshSize | None = None) -> tuple[TetMesh, MeshQuality]:
    """Tetrahedral mesh of the actuator STEP with named boundaries, and its quality."""
    size = size or MeshSize()
    step = Path(step)
    if not step.is_file():
        raise MeshingError(f"{step}: no such STEP file")
    with gmsh_session():
        # one thread: HXT with two gave a different mesh on every run (2086-2088 nodes on the
        # fPN), so FE results and sweep rows were not repeatable; one thread is repeatable
        # bit for bit and no slower at this size (about 1 s)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("actuator")
        try:
            volumes = _geometry(step, design, size.half)
            _size_field(design, size)
            gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT
            gmsh.option.setNumber("Mesh.Optimize", 1)
            gmsh.model.mesh.generate(3)
        except MeshingError:
            raise
        except Exception as err:
            raise MeshingError(f"{step}: gmsh failed: {err}") from err
        tags, coords, _ = gmsh.model.mesh.getNodes()
        etypes, etags, enodes = gmsh.model.mesh.getElements(3)
        if list(etypes) != [4]:
            raise MeshingError(f"{step}: expected linear tetrahedra, got element types {list(etypes)}")
        gamma = np.asarray(gmsh.model.mesh.getElementQualities(etags[0], "gamma"))
        del volumes
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags] = np.arange(len(tags))
    nodes = np.asarray(coords, float).reshape(-1, 3)
    tets = index[np.asarray(enodes[0], dtype=np.int64).reshape(-1, 4)]
    used = np.unique(tets)
    remap = np.full(len(nodes), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    nodes, tets = nodes[used], remap[tets]
    p = nodes[tets]
    vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    facets = name_facets(nodes, boundary_facets(tets), design, size.half)
    if design.sheet_z_mm > 0:
        facets[STRAIN_LIMITING_LAYER] = embedded_sheet(nodes, tets, design)
    for name in (CAVITY, CLAMP, FREE_END):
        if len(facets[name]) == 0:
            raise MeshingError(f"{step}: no facets found for the boundary {name!r}")
    regions = {ELASTOMER: np.arange(len(tets))}
    if design.layer_material.name:
        z = nodes[tets][:, :, 2].mean(axis=1)
        regions[BOTTOM_LAYER] = np.flatnonzero((z > design.bottom_z0_mm) & (z < design.top_z0_mm))
    mesh = TetMesh(nodes, tets, facets, regions, tip_mm=(design.length_mm, 0.0, 0.0), half=size.half)
    quality = MeshQuality(len(nodes), len(tets), float(gamma.min()), float(gamma.mean()),
                          float(np.abs(vol).min()))
    log.info("meshed %s: %d nodes, %d tets, min gamma %.3f", step.name, len(nodes), len(tets), quality.min_gamma)
    return mesh, quality
