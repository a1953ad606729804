"""A solved FE curve as VTU files with a ParaView collection (``.pvd``) index.

One ``step_NNN.vtu`` per converged step (meshio, XML binary, zlib-compressed) on the
quadratic mesh the FE solved on (:mod:`.p2`: 10-node tetrahedra, ``VTK_QUADRATIC_TETRA``,
reference coordinates in mm), with point data

- ``displacement_mm`` (3 components): the P2 displacement of every node (ParaView's
  *Warp By Vector* shows the deformed actuator);
- ``max_principal_stretch``: the largest principal stretch, from the P2 field evaluated
  at each node in every cell around it and averaged (:func:`.p2.nodal_stretch`);
- ``contact_pressure_mpa`` (with self-contact only): the pressure where the body's walls press
  on each other (:meth:`pnmold.fem.contact.ContactSurface.nodal_pressure`), 0 elsewhere;

``bending.pvd`` lists the steps with the pressure (kPa) as each dataset's ``timestep``
(ParaView's time). A half model (y >= 0) is written as solved; ParaView's *Reflect* filter
(plane Y, centre 0) shows the whole actuator.
"""

from __future__ import annotations

import logging
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from pnmold.errors import ExportError
from pnmold.fem import Solution
from pnmold.fsutil import atomic_path, write_text
from pnmold.tetmesh import TetMesh

from .p2 import QuadraticMesh, nodal_stretch, quadratic_mesh

log = logging.getLogger(__name__)

#: point-data names in every VTU
DISPLACEMENT = "displacement_mm"
STRETCH = "max_principal_stretch"
CONTACT = "contact_pressure_mpa"


def write_vtu_series(mesh: TetMesh, solution: Solution, folder: str | Path, *, name: str = "bending",
                     qmesh: QuadraticMesh | None = None) -> Path:
    """Write every converged step of ``solution`` as ``folder/step_NNN.vtu`` and the index
    ``folder/<name>.pvd``; return the index's path.

    Each file is written atomically, the index last. Files ``step_NNN.vtu`` left in
    ``folder`` by an earlier, longer curve are removed.

    Raises
    ------
    ExportError : the solution carries no states (a solver that does not keep them), or a
        file cannot be written.
    """
    import meshio

    folder = Path(folder)
    steps, states = solution.steps, solution.states
    if len(states) != len(steps):
        raise ExportError(str(folder), f"the solution keeps {len(states)} displacement states for "
                          f"{len(steps)} steps; the FE must keep one per step (Solution.states)")
    qmesh = qmesh or quadratic_mesh(mesh)
    contact = solution.contact_pressure_mpa if len(solution.contact_pressure_mpa) == len(steps) else None
    entries = []
    try:
        for i, (step, state) in enumerate(zip(steps, states, strict=True)):
            u = np.asarray(state, float).reshape(-1, 3)
            fields = {DISPLACEMENT: u, STRETCH: nodal_stretch(qmesh, state)}
            if contact is not None:
                fields[CONTACT] = np.asarray(contact[i], float)
            data = meshio.Mesh(qmesh.nodes_mm, [("tetra10", qmesh.cells)], point_data=fields)
            file = f"step_{i:03d}.vtu"
            with atomic_path(folder / file) as tmp:
                meshio.write(tmp, data, file_format="vtu", binary=True, compression="zlib")
            entries.append((step.pressure_kpa, file))
        index = write_text(folder / f"{name}.pvd", pvd_text(entries))
    except OSError as err:
        raise ExportError(str(folder), f"cannot write the VTU series: {err}") from err
    _remove_stale(folder, len(entries))
    log.info("wrote %d VTU steps and %s", len(entries), index)
    return index


@dataclass(frozen=True)
class VtuStep:
    """One step read back from a VTU series: the pressure (kPa, the index's ``timestep``), the
    reference nodes (mm), the 10-node cells (VTK order) and the displacement (mm)."""

    pressure_kpa: float
    nodes_mm: np.ndarray
    cells: np.ndarray
    displacement_mm: np.ndarray


def read_vtu_series(index: str | Path) -> list[VtuStep]:
    """The steps of a series written by :func:`write_vtu_series`, in the index's order
    (``index`` the ``.pvd`` file, or the folder holding one ``.pvd``)."""
    import meshio

    index = Path(index)
    if index.is_dir():
        found = sorted(index.glob("*.pvd"))
        if len(found) != 1:
            raise ExportError(str(index), f"expected one .pvd index, found {len(found)}")
        index = found[0]
    try:
        entries = [(float(d.get("timestep")), index.parent / d.get("file"))
                   for d in ET.parse(index).getroot().iter("DataSet")]
        steps = []
        for pressure, file in entries:
            data = meshio.read(file)
            steps.append(VtuStep(pressure, data.points, data.cells_dict["tetra10"],
                                 data.point_data[DISPLACEMENT]))
    except (OSError, ET.ParseError, KeyError, TypeError) as err:
        raise ExportError(str(index), f"cannot read the VTU series: {err}") from err
    return steps


def pvd_text(entries: list[tuple[float, str]]) -> str:
    """A ParaView collection: one ``DataSet`` per (timestep, relative file name)."""
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
             "  <Collection>"]
    lines += [f'    <DataSet timestep="{t:.9g}" group="" part="0" file={quoteattr(f)}/>' for t, f in entries]
    lines += ["  </Collection>", "</VTKFile>", ""]
    return "\n".join(lines)


def _remove_stale(folder: Path, n: int) -> None:
    for path in folder.glob("step_*.vtu"):
        m = re.fullmatch(r"step_(\d{3,})\.vtu", path.name)
        if m and int(m.group(1)) >= n:
            path.unlink(missing_ok=True)
