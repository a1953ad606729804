"""The FE problem as an Abaqus/CalculiX input deck (``.inp``).

Units: mm, N, MPa (N/mm^2), tonne, s -- consistent for Abaqus and CalculiX; densities in
tonne/mm^3 (1 g/mL = 1e-9 tonne/mm^3), gravity 9806.65 mm/s^2.

What the deck holds, and how it differs from pnmold's own solve (:mod:`pnmold.fem`):

- **Mesh**: the quadratic tetrahedra pnmold solves on (:mod:`.p2`), as ``C3D10`` (node
  ``s + 1`` is the FE's P2 node ``s``; element ``e + 1`` its tetrahedron ``e``). ``C3D10H``
  (Abaqus' hybrid element) may be asked for Abaqus; CalculiX has no hybrid elements.
- **Named boundaries**: every facet set of the mesh (``cavity``, ``clamp``,
  ``strain_limiting_layer``, ``free_end``, ``symmetry``) as a node set ``NAME`` (its
  corner and midside nodes), element sets ``NAME_S1`` .. ``NAME_S4`` (the elements with a
  face in it, by face) and an element-face surface ``S_NAME``; ``TIP`` is the tip node,
  ``ELASTOMER`` the solid elements, ``PAPER`` the layer's elements. A body of two rubbers
  (``regions``, e.g. a bottom layer cast in another silicone) lists that region's elements
  in a set of its own (``BOTTOM_LAYER``) with its own material, section and gravity load;
  ``ELASTOMER`` is then the rest.
- **Elastomer**: ``*HYPERELASTIC, YEOH`` with C10, C20, C30 and D1 = 2/K (K = the FE's
  bulk modulus, 200 mu by default) and no higher terms (D2 = D3 = 1e30: CalculiX replaces a
  zero by a default of its own), i.e. U = (K/2)(J - 1)^2, the same function as pnmold's.
  But CalculiX (and Abaqus' C3D10) evaluate it at each of the four integration points (a
  pointwise penalty), where pnmold constrains each element's mean dilatation (P2/P0): with
  one quadratic element across a 1 mm wall the deck's body is stiffer (it locks a little).
  pnmold's ``Yeoh(volumetric="penalty")`` is the same discrete model as the deck's.
- **Paper** (``DeckOptions.layer``): by default ``M3D6`` membranes on the
  ``strain_limiting_layer`` facets (the 6-node triangles of the solid's faces, sharing its
  nodes) with ``*ELASTIC`` E, nu and ``*MEMBRANE SECTION`` t: stretching stiffness E t and
  no bending stiffness, pnmold's membrane (CalculiX expands them into thin wedges centred on
  the bottom face). ``S6`` shells add the sheet's own bending stiffness E t^3/12 (the
  supplement's STRI65 shells); ``C3D15`` is a conforming layer of 15-node wedges of the
  sheet's thickness under the facets (outside the solid; also bending-stiff).
- **Loads**: one ``*STEP, NLGEOM`` with the whole history in ``*AMPLITUDE`` s: gravity
  (``*DLOAD`` ``GRAV`` on ``ELASTOMER`` from its density) ramps over time 0-1 first, as pnmold
  ramps it, then the cavity pressure (``*DLOAD`` ``P1``..``P4`` on the ``CAVITY_S*`` element
  sets, MPa) reaches each target pressure one time unit after the previous. One step, not one
  per pressure: CalculiX 2.20 loses the equilibrium of its expanded membranes (M3D6, S6) when
  a load changes in a later step after large rotations. Pressure on element faces follows the
  deformed faces in a geometrically nonlinear step, in both solvers (a follower load, as
  pnmold's).
- **Supports**: ``CLAMP`` fixed (1-3), ``SYMMETRY`` u_y = 0 (half model).
- **Contact** (``DeckOptions.contact_mpa_per_mm``, off by default): the facing walls of each gap
  between neighbouring chambers (:mod:`.contact_pairs`) as element-face surfaces
  ``GAPk_SLAVE`` (the wall facing +x) and ``GAPk_MASTER`` (-x) in a frictionless ``*CONTACT
  PAIR, TYPE=SURFACE TO SURFACE`` each, a linear penalty (CalculiX) where pnmold's own is a
  smooth one that starts 0.1 mm before touch (:mod:`pnmold.fem.contact`).
- **Output** at the target times (``*TIME POINTS, NAME=TARGETS``: after gravity, then each
  pressure; the increments are cut to hit them): the ``TIP`` displacement (``*NODE PRINT``,
  ``.dat``), U and S, E (``.frd``). CalculiX takes ``TIME POINTS`` on each request; for
  Abaqus (``DeckOptions.solver = "abaqus"``) the deck asks ``*OUTPUT, FIELD, TIME POINTS``
  for the ODB and prints the tip at every increment.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pnmold.errors import ExportError, UsageError
from pnmold.fem import Membrane, Yeoh
from pnmold.fsutil import write_text
from pnmold.tetmesh import CAVITY, CLAMP, STRAIN_LIMITING_LAYER, SYMMETRY
from pnmold.version import __version__

from . import LAYER_ELEMENTS, SOLID_ELEMENTS, SOLVERS
from .p2 import QuadraticMesh

#: standard gravity in the deck's units (mm/s^2)
G_MM_PER_S2 = 9806.65
#: g/mL to tonne/mm^3
TONNE_PER_MM3_PER_G_PER_ML = 1e-9
#: D2, D3 of a Yeoh material without the (J - 1)^4, (J - 1)^6 terms: CalculiX replaces a zero
#: by a default of its own, so a huge value (1/D = 1e-30 MPa) stands for "none" in both solvers
NO_TERM = 1e30


@dataclass(frozen=True)
class DeckOptions:
    """The deck's dialect, its elements and the increments of its nonlinear step.

    Parameters
    ----------
    solver : ``calculix`` or ``abaqus``: the dialect of the output requests (CalculiX takes
        ``TIME POINTS`` on ``*NODE PRINT``/``*NODE FILE``/``*EL FILE``, Abaqus on ``*OUTPUT``).
    solid : ``C3D10`` (CalculiX and Abaqus) or ``C3D10H`` (Abaqus only, hybrid).
    layer : the paper: ``M3D6`` membranes (default), ``S6`` shells or ``C3D15`` wedges
        (a conforming layer of the sheet's thickness) on the strain-limiting facets.
    initial_increment, min_increment, max_increment : in time units of the load history
        (one unit per load stage: gravity, then each pressure).
    max_increments : ``INC`` of the step.
    contact_mpa_per_mm : the facing walls of each gap between neighbouring chambers as a
        frictionless contact pair (:mod:`.contact_pairs`), surface to surface, with this
        penalty (CalculiX: ``PRESSURE-OVERCLOSURE=LINEAR``; Abaqus: its default penalty of
        ``HARD``); None: no contact, the walls pass through each other.
    """

    solver: str = "calculix"
    solid: str = "C3D10"
    layer: str = "M3D6"
    initial_increment: float = 0.1
    min_increment: float = 1e-5
    max_increment: float = 0.25
    max_increments: int = 1000
    contact_mpa_per_mm: float | None = None

    def __post_init__(self) -> None:
        if self.solver not in SOLVERS:
            raise UsageError(f"solver: one of {', '.join(SOLVERS)}, got {self.solver!r}")
        if self.solid not in SOLID_ELEMENTS:
            raise UsageError(f"solid element: one of {', '.join(SOLID_ELEMENTS)}, got {self.solid!r}")
        if self.layer not in LAYER_ELEMENTS:
            raise UsageError(f"layer element: one of {', '.join(LAYER_ELEMENTS)}, got {self.layer!r}")
        if not 0 < self.min_increment <= self.initial_increment <= self.max_increment <= 1:
            raise UsageError("increments: need 0 < min <= initial <= max <= 1")
        if self.contact_mpa_per_mm is not None and not self.contact_mpa_per_mm > 0:
            raise UsageError(f"contact penalty: must be > 0 MPa/mm, got {self.contact_mpa_per_mm!r}")


def abaqus_deck(qmesh: QuadraticMesh, material: Yeoh, membrane: Membrane | None, *,
                pressures_kpa: Sequence[float], gravity_g: Sequence[float] | None = None,
                options: DeckOptions | None = None, title: str = "pnmold actuator",
                regions: Mapping[str, Yeoh] | None = None) -> str:
    """The input deck's text (see the module docstring for what it holds); ``regions``:
    element-set name -> its rubber where it is not ``material``."""
    o = options or DeckOptions()
    solids = _solid_sets(qmesh, material, regions or {})
    targets = sorted(float(p) for p in pressures_kpa if p > 0)
    if not targets:
        raise UsageError("the deck needs at least one pressure > 0 kPa")
    out: list[str] = [
        "*HEADING",
        f"{title} (pnmold {__version__})",
        "** units: mm, N, MPa, tonne, s; density tonne/mm^3; pressure MPa (1 kPa = 0.001 MPa)",
        f"** half model (y >= 0, u_y = 0 on SYMMETRY): {qmesh.mesh.half}",
        "*NODE, NSET=NALL",
    ]
    layer = qmesh.facet_nodes(STRAIN_LIMITING_LAYER) if membrane is not None else np.zeros((0, 6), int)
    wedges = paper_wedges(qmesh, layer, membrane.thickness_mm) if len(layer) and o.layer == "C3D15" else None
    nodes = qmesh.nodes_mm if wedges is None else np.vstack([qmesh.nodes_mm, wedges.nodes_mm])
    out += [f"{i + 1}, {x:.9g}, {y:.9g}, {z:.9g}" for i, (x, y, z) in enumerate(nodes)]
    for name, (cells, _) in solids.items():
        out.append(f"*ELEMENT, TYPE={o.solid}, ELSET={name}")
        out += _rows(qmesh.cells[cells], 1, cells)
    if len(layer):
        out.append(f"*ELEMENT, TYPE={o.layer}, ELSET=PAPER")
        out += _rows(layer if wedges is None else wedges.cells, len(qmesh.cells) + 1)
    out += _boundary_sets(qmesh)
    for name, (_, rubber) in solids.items():
        out += _material(name, rubber)
    if len(layer):
        out += _paper(membrane, o)
    out += ["*BOUNDARY", f"{CLAMP.upper()}, 1, 3"]
    if qmesh.mesh.half:
        out.append(f"{SYMMETRY.upper()}, 2, 2")
    if wedges is not None:  # the layer's own nodes under clamped / symmetry nodes
        for name, dofs in ((CLAMP, "1, 3"), *(((SYMMETRY, "2, 2"),) if qmesh.mesh.half else ())):
            held = wedges.hanging_from(np.unique(qmesh.facet_nodes(name)))
            if len(held):
                out += [f"*NSET, NSET=PAPER_{name.upper()}", *_ids(held + 1), "*BOUNDARY",
                        f"PAPER_{name.upper()}, {dofs}"]
    if o.contact_mpa_per_mm is not None:
        out += _contact(qmesh, o)
    out += _steps(qmesh, {name: rubber for name, (_, rubber) in solids.items()}, targets, gravity_g, o)
    return "\n".join(out) + "\n"


def write_abaqus(path: str | Path, qmesh: QuadraticMesh, material: Yeoh, membrane: Membrane | None,
                 **kwargs) -> Path:
    """Write :func:`abaqus_deck` to ``path`` atomically; return the path."""
    text = abaqus_deck(qmesh, material, membrane, **kwargs)
    try:
        return write_text(path, text)
    except OSError as err:
        raise ExportError(str(path), f"cannot write the deck: {err}") from err


@dataclass(frozen=True, eq=False)
class PaperWedges:
    """The paper as a layer of 15-node wedges (``C3D15``) on the strain-limiting facets.

    Each wedge's top face is a facet (the solid's own six nodes); its bottom face lies the
    sheet's thickness away along the outward normal (outside the solid), with a node row at
    mid-thickness. Conforming: no constraint equations. Nodes are numbered after the P2
    nodes: ``nodes_mm[k]`` is node ``n_p2 + k``.
    """

    nodes_mm: np.ndarray  # (2 k, 3): the k bottom nodes, then the k mid-thickness nodes
    cells: np.ndarray  # (f, 15) node indices (0-based, deck order)
    source: np.ndarray  # (2 k,) the P2 node each new node hangs from
    n_p2: int  # the number of P2 nodes before them

    def hanging_from(self, nodes: np.ndarray) -> np.ndarray:
        """Indices (0-based, deck numbering) of the new nodes under any of ``nodes``."""
        return self.n_p2 + np.flatnonzero(np.isin(self.source, nodes))


def paper_wedges(qmesh: QuadraticMesh, facets: np.ndarray, thickness_mm: float) -> PaperWedges:
    """:class:`PaperWedges` under ``facets`` ((f, 6) P2 facet nodes, outward of the solid)."""
    x = qmesh.nodes_mm
    a, b, c = (x[facets[:, i]] for i in range(3))
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    uniq, inverse = np.unique(facets, return_inverse=True)
    inverse = inverse.reshape(facets.shape)
    nodal = np.zeros((len(uniq), 3))
    np.add.at(nodal, inverse.ravel(), np.repeat(normal, 6, axis=0))
    nodal /= np.linalg.norm(nodal, axis=1)[:, None]
    k, n = len(uniq), qmesh.n_nodes
    new = np.vstack([x[uniq] + thickness_mm * nodal, x[uniq] + 0.5 * thickness_mm * nodal])
    top = facets[:, [0, 2, 1, 5, 4, 3]]  # corners a, c, b; midsides ac, cb, ba: normal into the solid
    itop = inverse[:, [0, 2, 1, 5, 4, 3]]
    cells = np.column_stack([n + itop[:, :3], top[:, :3], n + itop[:, 3:], top[:, 3:], n + k + itop[:, :3]])
    return PaperWedges(new, cells, np.concatenate([uniq, uniq]), n)


def _rows(cells: np.ndarray, first: int, ids: np.ndarray | None = None) -> list[str]:
    """Element lines numbered ``first + e``, or ``first + ids[e]``."""
    ids = np.arange(len(cells)) if ids is None else ids
    return [f"{first + int(e)}, " + ", ".join(str(int(v) + 1) for v in cell)
            for e, cell in zip(ids, cells, strict=True)]


def _solid_sets(qmesh: QuadraticMesh, material: Yeoh,
                regions: Mapping[str, Yeoh]) -> dict[str, tuple[np.ndarray, Yeoh]]:
    """Element set name -> (its cells, its rubber): ``ELASTOMER`` (every cell not in a region)
    and one set per region."""
    rest = np.ones(len(qmesh.cells), bool)
    sets = {}
    for name, rubber in regions.items():
        if name not in qmesh.mesh.regions:
            raise ExportError(name, "this element set of a second rubber is not in the mesh")
        cells = np.asarray(qmesh.mesh.regions[name])
        rest[cells] = False
        sets[name.upper()] = (cells, rubber)
    return {"ELASTOMER": (np.flatnonzero(rest), material), **sets}


def tip_node(qmesh: QuadraticMesh) -> int:
    """Index (0-based) of the P2 node at the mesh's tip point."""
    tip = np.asarray(qmesh.mesh.tip_mm, float)
    d = np.linalg.norm(qmesh.nodes_mm - tip, axis=1)
    k = int(np.argmin(d))
    if d[k] > 1e-6 * max(1.0, float(np.abs(qmesh.nodes_mm).max())):
        raise ExportError("TIP", f"the tip {tuple(tip)} is not a node of the mesh (nearest {d[k]:.3g} mm away)")
    return k


def _ids(values: Iterable[int], per_line: int = 16) -> list[str]:
    v = [str(int(x)) for x in values]
    return [", ".join(v[i:i + per_line]) for i in range(0, len(v), per_line)]


def _boundary_sets(qmesh: QuadraticMesh) -> list[str]:
    out: list[str] = []
    for name, facets in qmesh.mesh.facets.items():
        if not len(facets):
            continue
        label = name.upper()
        out.append(f"*NSET, NSET={label}")
        out += _ids(np.unique(qmesh.facet_nodes(name)) + 1)
        out += _surface(f"S_{label}", label, *qmesh.facet_faces(name))
    out += ["*NSET, NSET=TIP", str(tip_node(qmesh) + 1)]
    return out


def _surface(name: str, label: str, cells: np.ndarray, faces: np.ndarray) -> list[str]:
    """An element-face surface ``name`` over element sets ``LABEL_S1`` .. ``LABEL_S4`` (the
    elements with face k in it)."""
    out, surface = [], []
    for k in range(1, 5):
        sel = np.unique(cells[faces == k]) + 1
        if len(sel):
            out.append(f"*ELSET, ELSET={label}_S{k}")
            out += _ids(sel)
            surface.append(f"{label}_S{k}, S{k}")
    return out + [f"*SURFACE, NAME={name}, TYPE=ELEMENT", *surface]


def _contact(qmesh: QuadraticMesh, o: DeckOptions) -> list[str]:
    """Each gap's facing walls as a frictionless surface-to-surface contact pair."""
    from .contact_pairs import gap_pairs

    pairs = gap_pairs(qmesh.mesh)
    if not pairs:
        raise UsageError("--contact-mpa-per-mm: the body has no facing walls across a gap between chambers "
                         "to pair (an sPN's chambers share their walls); export it without contact")
    out = [f"** self-contact: the facing walls of {len(pairs)} gaps (slave: the wall facing +x, master: -x)"]
    for k, pair in enumerate(pairs, start=1):
        out += _surface(f"GAP{k}_SLAVE", f"GAP{k}_SL", *qmesh.faces_of(pair.slave))
        out += _surface(f"GAP{k}_MASTER", f"GAP{k}_MA", *qmesh.faces_of(pair.master))
    behaviour = (["*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=HARD"] if o.solver == "abaqus" else
                 ["*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", f"{o.contact_mpa_per_mm:.9g}"])
    out += ["*SURFACE INTERACTION, NAME=WALLS", *behaviour]
    for k in range(1, len(pairs) + 1):
        out += ["*CONTACT PAIR, INTERACTION=WALLS, TYPE=SURFACE TO SURFACE", f"GAP{k}_SLAVE, GAP{k}_MASTER"]
    return out


def _material(name: str, material: Yeoh) -> list[str]:
    """A rubber's material and solid section on element set ``name``."""
    d1 = 2.0 / material.bulk_modulus_mpa
    return [
        "** Yeoh: W = sum Ci0 (I1b - 3)^i + (1/D1)(J - 1)^2, D1 = 2/K, "
        f"K = {material.bulk_ratio:g} mu = {material.bulk_modulus_mpa:.6g} MPa (pointwise here; "
        "pnmold: mean dilatation per element)",
        f"*MATERIAL, NAME={name}",
        "*HYPERELASTIC, YEOH",
        f"{material.c10_mpa:.9g}, {material.c20_mpa:.9g}, {material.c30_mpa:.9g}, {d1:.9g}, {NO_TERM:g}, {NO_TERM:g}",
        "*DENSITY",
        f"{material.density_g_per_ml * TONNE_PER_MM3_PER_G_PER_ML:.9g}",
        f"*SOLID SECTION, ELSET={name}, MATERIAL={name}",
    ]


def _paper(membrane: Membrane, o: DeckOptions) -> list[str]:
    """The paper's material and section on element set ``PAPER``."""
    section = {"C3D15": [], "M3D6": ["MEMBRANE SECTION"], "S6": ["SHELL SECTION"]}[o.layer]
    return [
        f"** paper: E t = {membrane.stiffness_n_per_mm:.6g} N/mm on the strain-limiting facets",
        "*MATERIAL, NAME=PAPER",
        "*ELASTIC",
        f"{membrane.modulus_mpa:.9g}, {membrane.poisson:.9g}",
        *([f"*{section[0]}, ELSET=PAPER, MATERIAL=PAPER", f"{membrane.thickness_mm:.9g}"] if section
          else ["*SOLID SECTION, ELSET=PAPER, MATERIAL=PAPER"]),
    ]


def _pairs(points: list[tuple[float, float]]) -> list[str]:
    """``*AMPLITUDE`` data lines: (time, value) pairs, four per line."""
    flat = [f"{v:.9g}" for point in points for v in point]
    return [", ".join(flat[i:i + 8]) for i in range(0, len(flat), 8)]


def load_history(targets: Sequence[float], gravity: bool) -> tuple[list[float], list[tuple[float, float]]]:
    """(the output times, the pressure amplitude's (time, fraction of the largest) points) of
    the deck's one step: gravity (if any) ramps over time 0 -> 1, then each pressure is
    reached one time unit after the previous one."""
    start = 1.0 if gravity else 0.0
    top = max(targets)
    points = [(0.0, 0.0)] + ([(start, 0.0)] if gravity else [])
    points += [(start + k, p / top) for k, p in enumerate(targets, start=1)]
    return [start] * gravity + [start + k for k in range(1, len(targets) + 1)], points


def _steps(qmesh: QuadraticMesh, rubbers: Mapping[str, Yeoh], targets: list[float],
           gravity_g: Sequence[float] | None, o: DeckOptions) -> list[str]:
    """The whole load history in one ``*STEP, NLGEOM`` through amplitudes, with output at each
    target (``*TIME POINTS``): CalculiX 2.20 loses its membranes' (M3D6, S6) equilibrium when a
    load changes in a step after the first at large rotations; one step avoids that."""
    g = np.zeros(3) if gravity_g is None else np.asarray(gravity_g, float)
    norm = float(np.linalg.norm(g))
    gravity = norm > 0 and any(m.density_g_per_ml > 0 for m in rubbers.values())
    times, points = load_history(targets, gravity)
    total = times[-1]
    _, faces = qmesh.facet_faces(CAVITY)
    labels = [k for k in range(1, 5) if np.any(faces == k)]
    if not labels:
        raise ExportError(CAVITY, "the mesh has no cavity facets to load")
    out = [f"** load history: {'gravity over time 0-1, then ' if gravity else ''}the cavity pressure through "
           + ", ".join(f"{p:g}" for p in targets) + " kPa, one time unit each; output at each of them",
           "*AMPLITUDE, NAME=PRESSURE", *_pairs(points)]
    loads = []
    if gravity:
        d = g / norm
        out += ["*AMPLITUDE, NAME=GRAVITY", *_pairs([(0.0, 0.0), (1.0, 1.0), (total, 1.0)])]
        loads += ["*DLOAD, AMPLITUDE=GRAVITY",
                  *(f"{name}, GRAV, {G_MM_PER_S2 * norm:.9g}, {d[0]:.9g}, {d[1]:.9g}, {d[2]:.9g}"
                    for name in rubbers)]
    loads += ["*DLOAD, AMPLITUDE=PRESSURE",
              *(f"{CAVITY.upper()}_S{j}, P{j}, {max(targets) / 1000.0:.9g}" for j in labels)]
    out += ["*TIME POINTS, NAME=TARGETS", *_ids_float(times),
            f"*STEP, NLGEOM, INC={o.max_increments}", "*STATIC",
            f"{o.initial_increment:g}, {total:g}, {o.min_increment:g}, {o.max_increment:g}", *loads,
            *_output(o.solver), "*END STEP"]
    return out


def _output(solver: str) -> list[str]:
    """The tip into the ``.dat`` and U, S, E into the results file at each target time."""
    if solver == "abaqus":  # Abaqus: the ODB at the time points; the .dat at every increment
        return ["*OUTPUT, FIELD, TIME POINTS=TARGETS", "*NODE OUTPUT", "U", "*ELEMENT OUTPUT", "S, E",
                "*NODE PRINT, NSET=TIP", "U"]
    return ["*NODE PRINT, NSET=TIP, TIME POINTS=TARGETS", "U", "*NODE FILE, TIME POINTS=TARGETS", "U",
            "*EL FILE, TIME POINTS=TARGETS", "S, E"]


def _ids_float(values: Sequence[float]) -> list[str]:
    v = [f"{x:.9g}" for x in values]
    return [", ".join(v[i:i + 8]) for i in range(0, len(v), 8)]
