"""Sparse direct solves of the reduced tangent: PARDISO where MKL is, SciPy's SuperLU elsewhere.

The matrix is the upper triangle of the symmetric (indefinite) tangent in CSR, sorted
indices. Two solvers take it, with the same methods (``factor``, ``solve``, ``release``) and
counters (``n_analyses``, ``n_factorizations``, ``negative_pivots``):

- :class:`Pardiso` -- Intel MKL's PARDISO through pypardiso, LDL^T. The sparsity pattern never
  changes along a curve, so the symbolic analysis (reordering, phase 11) runs once and each
  Newton iteration does only the numerical factorisation (phase 22) and the solve (phase 33).
  pypardiso exposes the phases through ``set_phase``; its ``factorize``/``solve`` always re-run
  the analysis, so we call its ``_call_pardiso`` directly.
- :class:`SuperLU` -- SciPy's ``splu`` on the full symmetric matrix, for machines where MKL has
  no wheels (Apple Silicon, ARM Linux): the package installs pypardiso only on x86-64. On the
  fPN's quick FE (35k unknowns) a factorisation takes 3-5x PARDISO's time and the whole FE
  about 3x; the full-bend pressure is the same to 1e-5 (``benchmarks/linear_solver.py``).

:func:`linear_solver` picks one: ``PNMOLD_LINEAR_SOLVER`` (``pardiso`` or ``scipy``) when set,
else PARDISO when pypardiso imports, else SuperLU. :func:`choose_linear_solver` says which,
without building it (the build report names it).
"""

from __future__ import annotations

import functools
import logging
import os

import numpy as np
import scipy.sparse as sp

from ..errors import SolveError, UsageError

log = logging.getLogger(__name__)

#: environment variable that forces a linear solver
LINEAR_SOLVER_ENV = "PNMOLD_LINEAR_SOLVER"
#: the solvers by the name the environment variable and the report use
LINEAR_SOLVERS = ("pardiso", "scipy")

_REAL_SYMMETRIC_INDEFINITE = -2


def _cores() -> int:
    """The cores this process may run on (the affinity mask where the system has one)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


#: PARDISO iparm (1-based): own settings; METIS ordering; no iterative refinement (Newton
#: corrects the rare inaccurate solve, and refinement costs more than a solve); 1e-8 pivot
#: perturbation and Bunch-Kaufman 1x1/2x2 pivoting (the symmetric-indefinite defaults);
#: conditional numerical reproducibility (iparm 34) for this machine's cores: without it MKL
#: may factor on fewer threads when the machine is busy, in another order of summation, and
#: the adaptive load stepping turns that round-off into another curve (a characterisation
#: rerun gave 35 steps instead of 34). With it, 1 and 2 threads give the same bits.
_IPARM = {1: 1, 2: 2, 8: 0, 10: 8, 11: 0, 13: 0, 21: 1, 34: _cores()}


class Pardiso:
    """LDL^T of a symmetric matrix given by its upper triangle; analysis done once."""

    name = "pardiso"

    def __init__(self) -> None:
        from pypardiso import PyPardisoSolver

        self._solver = PyPardisoSolver(mtype=_REAL_SYMMETRIC_INDEFINITE)
        for i, value in _IPARM.items():
            self._solver.set_iparm(i, value)
        self._pattern: tuple[np.ndarray, np.ndarray] | None = None
        self._matrix: sp.csr_matrix | None = None
        self.n_analyses = 0
        self.n_factorizations = 0
        self.negative_pivots = 0

    def _phase(self, phase: int, b: np.ndarray) -> np.ndarray:
        from pypardiso.pardiso_wrapper import PyPardisoError

        self._solver.set_phase(phase)
        try:
            return self._solver._call_pardiso(self._matrix, b)
        except PyPardisoError as err:
            raise SolveError(f"PARDISO phase {phase} failed: {err}") from err

    def factor(self, matrix: sp.csr_matrix) -> None:
        """Numerically factor ``matrix`` (upper-triangular CSR, sorted indices)."""
        # compare contents, not identity: scipy's csr_matrix may hand back new index arrays
        # for the same pattern, and a needless analysis costs more than the factorisation
        same = (self._pattern is not None and np.array_equal(self._pattern[0], matrix.indptr)
                and np.array_equal(self._pattern[1], matrix.indices))
        self._matrix = matrix
        self._solver.set_iparm(12, 0)  # CSR, not transposed
        dummy = np.zeros((matrix.shape[0], 1))
        if not same:
            self._phase(11, dummy)
            self._pattern = (matrix.indptr.copy(), matrix.indices.copy())
            self.n_analyses += 1
        self._phase(22, dummy)
        self.n_factorizations += 1
        self.negative_pivots = int(self._solver.iparm[22])

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve with the last factorisation."""
        b = np.asfortranarray(rhs, dtype=float)
        return self._phase(33, b)

    def release(self) -> None:
        """Free PARDISO's memory."""
        if self._matrix is not None:
            self._solver.free_memory(everything=True)
            self._matrix = None
            self._pattern = None


class SuperLU:
    """LU of the same matrix with SciPy's SuperLU, the fallback where pypardiso is missing.

    Symmetric mode: a minimum-degree ordering of A + A^T applied to rows and columns alike,
    and the diagonal taken as pivot unless it is below 0.001 of its column's largest entry
    (UMFPACK's symmetric default): on the fPN tangents no off-diagonal pivot was needed and
    the fill is that of a Cholesky factor. SuperLU has no separate analysis, so every
    factorisation orders again (``n_analyses`` counts them), and it does not give the
    inertia: ``negative_pivots`` is -1 (not counted).
    """

    name = "scipy"

    def __init__(self) -> None:
        self._lu = None
        self.n_analyses = 0
        self.n_factorizations = 0
        self.negative_pivots = -1

    def factor(self, matrix: sp.csr_matrix) -> None:
        """Factor the symmetric matrix whose upper triangle is ``matrix`` (CSR)."""
        from scipy.sparse.linalg import splu

        upper = sp.csr_matrix(matrix)
        # the CSR arrays of the upper triangle are the CSC arrays of the lower one
        lower = sp.csc_matrix((upper.data, upper.indices, upper.indptr), shape=upper.shape)
        full = (upper.tocsc() + lower - sp.diags(upper.diagonal(), format="csc")).tocsc()
        try:
            self._lu = splu(full, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=1e-3,
                            options={"SymmetricMode": True})
        except RuntimeError as err:  # "Factor is exactly singular"
            self._lu = None
            raise SolveError(f"SuperLU factorisation failed: {err}") from err
        self.n_analyses += 1
        self.n_factorizations += 1

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve with the last factorisation."""
        if self._lu is None:
            raise SolveError("SuperLU: solve before a successful factorisation")
        return self._lu.solve(np.asarray(rhs, dtype=float))

    def release(self) -> None:
        """Drop the factors."""
        self._lu = None


@functools.cache
def _pardiso_importable() -> str | None:
    """None when pypardiso (and MKL behind it) loads, else why not."""
    try:
        import pypardiso  # noqa: F401
    except (ImportError, OSError) as err:  # no wheel for this machine, or MKL's library fails to load
        return f"{type(err).__name__}: {err}"
    return None


def choose_linear_solver() -> str:
    """The name of the solver :func:`linear_solver` builds: ``$PNMOLD_LINEAR_SOLVER`` when set
    (:class:`~pnmold.errors.UsageError` for an unknown name, or ``pardiso`` without pypardiso),
    else ``pardiso`` when pypardiso imports, else ``scipy``."""
    wanted = os.environ.get(LINEAR_SOLVER_ENV, "").strip().lower()
    if wanted and wanted not in LINEAR_SOLVERS:
        raise UsageError(f"{LINEAR_SOLVER_ENV}={wanted}: one of {', '.join(LINEAR_SOLVERS)}")
    missing = _pardiso_importable() if wanted != "scipy" else None
    if wanted == "pardiso" and missing:
        raise UsageError(f"{LINEAR_SOLVER_ENV}=pardiso, but pypardiso cannot be loaded ({missing}); "
                         f"pypardiso needs Intel MKL (x86-64 only): unset {LINEAR_SOLVER_ENV} to use SciPy's solver")
    if wanted:
        return wanted
    if missing:
        log.info("pypardiso unavailable (%s): SciPy's SuperLU solves the FE", missing)
        return "scipy"
    return "pardiso"


def linear_solver() -> Pardiso | SuperLU:
    """A new linear solver, the one :func:`choose_linear_solver` names."""
    return Pardiso() if choose_linear_solver() == "pardiso" else SuperLU()
