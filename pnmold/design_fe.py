"""The design's FE: the one door from a design to an FE problem and its solved curve.

:func:`fe_problem` makes the problem of a design: the design as solved (catalogued effects the FE
carries put into its rubber and paper), the rubber(s), the paper membrane, gravity of the test
orientation (docs/frame-and-units.md) and the mesh size (the whole body where gravity leaves the
bending plane). :func:`run_fe` solves it: the actuator's STEP (the build's own file, or the actuator
alone exported for the purpose: no molds, no gate, no pictures) -> :func:`pnmold.mesh.mesh_actuator`
(gmsh) -> :func:`pnmold.fem.solve_bending` or :func:`pnmold.fem.solve_blocked_force` (scikit-fem) ->
:class:`FeRun`. The build, ``pnmold simulate --model fe``, the reduced model's characterisation, the
pneumatic chamber law and ``pnmold export`` all come through here. The build's quick solve assumes
the actuator lies chambers up (gravity along -z), as on a bench.
"""

from __future__ import annotations

import dataclasses
import logging
import tempfile
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from pnmold.conventions import gravity_direction
from pnmold.design import Design
from pnmold.effects import check_effects, value_of
from pnmold.errors import DesignError, SolveError
from pnmold.fem import Membrane, SelfContact, Solution, SolveOptions, Yeoh, solve_bending, solve_blocked_force
from pnmold.tetmesh import BOTTOM_LAYER, MeshSize, TetMesh

log = logging.getLogger(__name__)

#: the build's quick solve stops here if the actuator has not closed into a circle (assumed)
QUICK_MAX_PRESSURE_KPA = 150.0
#: the build's preview mesh: coarser than the default MeshSize (2.5/5 mm). With gravity the
#: fPN's full-bend pressure was 48.0 kPa here (35k unknowns) and 47.5 kPa at 2.5/5 mm
#: (47k unknowns); benchmarks/fem.py prints the tip on this mesh and a finer one.
BUILD_MESH = MeshSize(3.2, 6.4)
#: the build's load stepping: bend increments of up to 70 degrees instead of 40 (a preview)
BUILD_OPTIONS = SolveOptions(max_angle_step_deg=70.0)
FE_KINDS = ("bending", "force")


def build_options(self_contact: bool = False) -> SolveOptions:
    """The build's quick solve (:data:`BUILD_OPTIONS`), with the FE's self-contact at its defaults
    when ``self_contact`` (``pnmold build --self-contact``)."""
    return dataclasses.replace(BUILD_OPTIONS, self_contact=SelfContact()) if self_contact else BUILD_OPTIONS


def _yeoh(m) -> Yeoh:
    """A design's :class:`~pnmold.design.Material` as the FE's rubber; a library material's
    elongation at break ends the curve where the largest stretch passes it
    (``Solution.stop == "stretch_limit"``)."""
    from pnmold.errors import UsageError
    from pnmold.materials.library import get_material

    try:
        stretch = 1.0 + get_material(m.name).elongation_at_break
    except UsageError:  # not a library material: no stretch stop
        stretch = None
    return Yeoh(c10_mpa=m.c10_mpa, c20_mpa=m.c20_mpa, c30_mpa=m.c30_mpa,
                density_g_per_ml=m.density_g_per_ml, stretch_at_break=stretch)


def material_of(design: Design) -> Yeoh:
    """The FE's elastomer (the top layer's, and the body's wherever no other is named)."""
    return _yeoh(design.material)


def regions_of(design: Design) -> dict[str, Yeoh]:
    """Element sets of another rubber: the bottom layer when ``[layer_material]`` names one
    (the mesh then has the ``bottom_layer`` region)."""
    return {BOTTOM_LAYER: _yeoh(design.bottom_material)} if design.layer_material.name else {}


def membrane_of(design: Design) -> Membrane | None:
    """The paper sheet as a membrane on the bottom face; None in a design without paper."""
    p = design.paper
    if not p.present:
        return None
    return Membrane(modulus_mpa=p.modulus_mpa, poisson=p.poisson, thickness_mm=p.thickness_mm)


def design_for_fe(design: Design, effects: Mapping[str, float]) -> tuple[Design, float]:
    """The design the FE solves with the material and layer effects in it, and the gravity factor."""
    values = check_effects(effects, model="fe")
    c20 = value_of(values, "strain_stiffening")
    c30 = value_of(values, "strain_stiffening.c30_mpa")
    if c20 or c30:
        m = design.material
        design = design.replace("material", c20_mpa=m.c20_mpa + c20, c30_mpa=m.c30_mpa + c30)
    compliance = value_of(values, "layer_compliance")
    if compliance and design.paper.present:  # the paper's E*t in series with the compliance
        p = design.paper
        stiffness = 1.0 / (1.0 / (p.modulus_mpa * p.thickness_mm) + compliance)
        design = design.replace("paper", modulus_mpa=stiffness / p.thickness_mm)
    elif compliance:  # the layer's rubber alone limits the strain: its 6 C10 t in series, every constant alike
        m = design.bottom_material
        rubber = 6.0 * m.c10_mpa * design.bottom_layer.thickness_mm
        factor = 1.0 / (1.0 + compliance * rubber)
        design = design.replace("layer_material", c10_mpa=m.c10_mpa * factor, c20_mpa=m.c20_mpa * factor,
                                c30_mpa=m.c30_mpa * factor)
    return design, value_of(values, "gravity")


@dataclass(frozen=True, eq=False)
class FeProblem:
    """What the FE solves for a design: the design as solved (effects in it), its rubber (and a second
    rubber's element sets), the paper, gravity in g along the actuator frame (None: none) and the mesh size."""

    design: Design
    material: Yeoh
    membrane: Membrane | None
    regions: dict[str, Yeoh]
    gravity_g: tuple[float, float, float] | None
    size: MeshSize


def fe_problem(design: Design, *, orientation: str = "chambers_up", effects: Mapping[str, float] | None = None,
               size: MeshSize | None = None) -> FeProblem:
    """The FE problem of ``design`` tested in ``orientation`` (or ``none``) with the catalogued ``effects``
    the FE carries; ``size`` (default :class:`MeshSize`) turns into a whole model where gravity leaves the
    bending plane (a half model cannot carry it)."""
    solved, g = design_for_fe(design, effects or {})
    direction = gravity_direction(orientation, solved.material.density_g_per_ml)
    gravity = None if direction is None or g == 0 else tuple(g * v for v in direction)
    size = size or MeshSize()
    if gravity is not None and gravity[1] != 0 and size.half:
        size = dataclasses.replace(size, half=False)  # out of the bending plane: the whole body
    return FeProblem(solved, material_of(solved), membrane_of(solved), regions_of(solved), gravity, size)


@dataclass(frozen=True, eq=False)
class FeRun:
    """A solved curve with its problem and the mesh it was solved on (``size``: that mesh's)."""

    problem: FeProblem
    mesh: TetMesh
    quality: object  # pnmold.mesh.MeshQuality
    solution: Solution
    size: MeshSize
    orientation: str
    timings_s: dict[str, float]

    @property
    def design(self) -> Design:
        """The design as solved (effects in it)."""
        return self.problem.design

    @property
    def gravity_g(self) -> tuple[float, float, float] | None:
        return self.problem.gravity_g


def run_fe(design: Design, *, orientation: str = "chambers_up", effects: Mapping[str, float] | None = None,
           pressures_kpa: Sequence[float] | None = None, max_pressure_kpa: float | None = None,
           kind: str = "bending", size: MeshSize | None = None, options: SolveOptions | None = None,
           step_path: str | Path | None = None, mesh_of: FeRun | None = None,
           keep_partial: bool = False) -> FeRun:
    """Solve ``design``'s pressure curve in the FE.

    Parameters
    ----------
    orientation : where gravity points (docs/recording-format.md), or ``none`` for no gravity.
    effects : catalogued effects the FE carries (``gravity`` = its factor, default 1;
        ``strain_stiffening``; ``layer_compliance``), by name (and ``NAME.PARAM``).
    pressures_kpa, max_pressure_kpa : the curve's pressures, or up to full bend or the maximum
        (default :data:`QUICK_MAX_PRESSURE_KPA`).
    kind : ``bending`` (free) or ``force`` (blocked tip, supplement Fig. S6).
    size : the mesh (default :class:`MeshSize`); a whole model where gravity leaves the plane.
    step_path : the actuator's STEP to mesh (a build's own file); default: the actuator alone,
        exported to a temporary folder.
    mesh_of : solve on the mesh of an earlier run of the same geometry instead (no meshing).
    keep_partial : on a solver failure return the curve up to the last converged step (its
        ``reason`` names the failure) instead of raising :class:`SolveError`.
    """
    if kind not in FE_KINDS:
        raise DesignError("kind", f"the FE solves {', '.join(FE_KINDS)}, got {kind!r}")
    problem = fe_problem(design, orientation=orientation, effects=effects, size=size)
    t0 = time.perf_counter()
    if mesh_of is not None:
        mesh, quality, size = mesh_of.mesh, mesh_of.quality, mesh_of.size
    else:
        size = problem.size
        mesh, quality = _mesh(problem.design, size, step_path)
    t1 = time.perf_counter()
    if pressures_kpa is not None:
        loads = {"pressures_kpa": list(pressures_kpa)}
    else:
        loads = {"max_pressure_kpa": QUICK_MAX_PRESSURE_KPA if max_pressure_kpa is None else max_pressure_kpa}
    solve = solve_blocked_force if kind == "force" else solve_bending
    try:
        solution = solve(mesh, problem.material, problem.membrane, gravity=problem.gravity_g, options=options,
                         regions=problem.regions, **loads)
    except SolveError as err:
        if not keep_partial or err.partial is None:
            raise
        log.warning("FE stopped: %s", err)
        solution = err.partial
    t2 = time.perf_counter()
    timings = {"mesh": round(t1 - t0, 3), "solve": round(t2 - t1, 3)}
    return FeRun(problem, mesh, quality, solution, size, orientation, timings)


def _mesh(design: Design, size: MeshSize, step_path: str | Path | None):
    from pnmold.mesh import mesh_actuator

    if step_path is not None:
        return mesh_actuator(step_path, design, size)
    from pnmold.cad import export_actuator_step

    with tempfile.TemporaryDirectory(prefix="pnmold-fe-") as tmp:
        return mesh_actuator(export_actuator_step(design, tmp), design, size)
