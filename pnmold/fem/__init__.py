"""Large-deformation FE of PneuNet actuators: quadratic tets, Yeoh elastomer, paper membrane.

Takes a :class:`~pnmold.tetmesh.TetMesh`, a material and a load; never a design, never
gmsh. Units at the API: mm, N, MPa, kPa (pressures), mL, g/mL, degrees.

Formulation (details in the module docstrings):

- :mod:`.material` -- Yeoh with isochoric I1bar on P2 tetrahedra; near-incompressibility by
  a mean-dilatation (P2/P0, condensed) penalty K/mu = 200; the paper as a St.Venant-
  Kirchhoff membrane (E*t exact, no bending stiffness) that wrinkles in compression.
- :mod:`.model` -- scikit-fem mesh/element/quadrature/numbering, precomputed sparsity and
  scatter maps; follower cavity pressure in reference form (Nanson), gravity, clamp,
  y = 0 symmetry, a penalty contact plane for blocked force.
- :mod:`.kernels` -- compiled element kernels (energy, residual, tangent).
- :mod:`.surface` -- compiled kernels of the paper sheet (compression relaxed: it
  wrinkles) and of the cavity pressure.
- :mod:`.newton` -- Newton's iteration under load or cavity-volume control (convergence in
  the residual or the energy norm, a factorisation reused through GMRES); its options,
  result and counters in :mod:`.newton_types`.
- :mod:`.linesearch` -- the energy (merit) line search along the Newton step with a
  second-order correction.
- :mod:`.tangent` / :mod:`.linsolve` -- the tangent factored (inertia counted and
  corrected) or solved by GMRES preconditioned by the last factorisation, the bordered
  Newton step; PARDISO LDL^T with the analysis done once (SciPy's SuperLU where pypardiso
  is missing, or with ``PNMOLD_LINEAR_SOLVER=scipy``).
- :mod:`.path` / :mod:`.states` -- gravity ramped by load control, the pressure by volume
  control (passes pressure maxima); converged states, extrapolated predictors, step
  control on bend and iterations.
- :mod:`.failure` -- where a failed solve went wrong and what to try.
- :mod:`.contact` / :mod:`.gap` -- frictionless self-contact of the outer surface (opt-in,
  ``SolveOptions(self_contact=SelfContact())``): a C2 penalty on the signed distance of the
  P2 facets' quadrature points to the facing surface, pairs found on the deformed shape.
- :mod:`.overlap` -- where a deformed body passes through itself (boundary nodes inside
  another part of it, and how deep).
- :mod:`.solver` / :mod:`.results` -- :func:`solve_bending`, :func:`solve_blocked_force`,
  :class:`Step` and :class:`Solution`; :mod:`.blocked` -- :func:`blocked_force_slope` (the
  blocked force to first order in pressure).

    >>> from pnmold.fem import solve_bending
    >>> sol = solve_bending(mesh, max_pressure_kpa=80, gravity=(0, 0, -1))  # doctest: +SKIP
    >>> sol.full_bend_pressure_kpa, sol.steps[-1].bend_angle_deg            # doctest: +SKIP
"""

from .blocked import BlockedSlope, blocked_force_slope
from .contact import SelfContact
from .material import Membrane, Yeoh
from .model import Load, Model
from .newton import Newton, NewtonOptions
from .results import STOPS, PressureMaximum, Solution, Step, full_bend_pressure
from .solver import ELASTOSIL_M4601, PAPER, SolveOptions, solve_bending, solve_blocked_force

__all__ = [
    "ELASTOSIL_M4601",
    "BlockedSlope",
    "PAPER",
    "PressureMaximum",
    "STOPS",
    "SelfContact",
    "Load",
    "Membrane",
    "Model",
    "Newton",
    "NewtonOptions",
    "Solution",
    "SolveOptions",
    "Step",
    "Yeoh",
    "blocked_force_slope",
    "full_bend_pressure",
    "solve_bending",
    "solve_blocked_force",
]
