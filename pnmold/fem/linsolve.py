"""Sparse direct solves of the reduced tangent: PARDISO where MKL is, SciPy's SuperLU elsewhere.

The matrix is the upper triangle of the symmetric (indefinite) tangent in CSR, sorted
indices. Two solvers take it, with the same methods (``factor``, ``solve``, ``release``) and
counters (``n_analyses``, ``n_factorizations``, ``negative_pivots``):

- :class:`Pardiso` -- Intel MKL's PARDISO through pypardiso, LDL^T. The sparsity pattern never
  changes along a curve, so the symbolic analysis (reordering, phase 11) runs once and each
  Newton iteration does only the numerical factorisation (phase 22) and the solve (phase 33).
  pypardiso's ``factorize``/``solve`` always re-run the analysis, so we call MKL's ``pardiso``
  through pypardiso's handle directly, phase by phase, with the 1-based indices kept.
- :class:`SuperLU` -- SciPy's ``splu`` on the full symmetric matrix, for machines where MKL has
  no wheels (Apple Silicon, ARM Linux): the package installs pypardiso only on x86-64. On the
  fPN's quick FE (35k unknowns) a factorisation takes 3-5x PARDISO's time and the whole FE
  about 3x; the full-bend pressure is the same to 1e-5 (``benchmarks/linear_solver.py``).

:func:`linear_solver` picks one: ``PNMOLD_LINEAR_SOLVER`` (``pardiso`` or ``scipy``) when set,
else PARDISO when pypardiso imports, else SuperLU. :func:`choose_linear_solver` says which,
without building it (the build report names it).
"""

from __future__ import annotations

import ctypes
import functools
import glob
import logging
import os
import sys
from collections.abc import Callable
from typing import TypeVar

import numpy as np
import scipy.sparse as sp

from ..errors import SolveError, UsageError

log = logging.getLogger(__name__)
T = TypeVar("T")

#: environment variable that forces a linear solver
LINEAR_SOLVER_ENV = "PNMOLD_LINEAR_SOLVER"
#: the solvers by the name the environment variable and the report use
LINEAR_SOLVERS = ("pardiso", "scipy")

_REAL_SYMMETRIC_INDEFINITE = -2
_INT_P = ctypes.POINTER(ctypes.c_int32)
_DOUBLE_P = ctypes.POINTER(ctypes.c_double)


def _cores() -> int:
    """The cores this process may run on (the affinity mask where the system has one)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


#: PARDISO iparm (1-based): own settings; METIS ordering; no iterative refinement (Newton
#: corrects the rare inaccurate solve, and refinement costs more than a solve); 1e-8 pivot
#: perturbation and Bunch-Kaufman 1x1/2x2 pivoting (the symmetric-indefinite defaults);
#: the two-level factorisation (iparm 24 = 1), whose forward and backward substitutions run on
#: both cores (fPN build mesh: 16-19 ms a solve instead of 30-36 ms, the factorisation as fast);
#: conditional numerical reproducibility (iparm 34) for this machine's cores: without it MKL
#: may factor on fewer threads when the machine is busy, in another order of summation, and
#: the adaptive load stepping turns that round-off into another curve (a characterisation
#: rerun gave 35 steps instead of 34). With it, 1 and 2 threads give the same bits.
_IPARM = {1: 1, 2: 2, 8: 0, 10: 8, 11: 0, 13: 0, 21: 1, 24: 1, 34: _cores()}


def _point_pypardiso_at_mkl() -> None:
    """Where ``libmkl_rt`` lies in this Python's ``lib`` (MKL's wheel), tell pypardiso so
    (``PYPARDISO_MKL_RT``): otherwise its import and every new solver search the whole
    environment for the library (0.7 s each)."""
    if "PYPARDISO_MKL_RT" not in os.environ:
        found = sorted(glob.glob(os.path.join(sys.prefix, "lib", "libmkl_rt.so*")), key=len)
        if found:
            os.environ["PYPARDISO_MKL_RT"] = found[0]


def _threads() -> int:
    """The threads MKL may use: ``MKL_NUM_THREADS`` or ``OMP_NUM_THREADS`` when set, else the cores."""
    for name in ("MKL_NUM_THREADS", "OMP_NUM_THREADS"):
        value = os.environ.get(name, "").split(",")[0].strip()
        if value.isdigit() and int(value) > 0:
            return int(value)
    return _cores()


def _pardiso_solver():
    """pypardiso's solver object (it loads MKL), with MKL's own thread count set.

    Set, not left to OpenMP: gmsh's HXT mesher on ``General.NumThreads = 1`` (:mod:`pnmold.mesh`)
    sets the process's OpenMP thread count to 1 (MKL's OpenMP runtime serves gmsh's calls too), and every
    PARDISO call after a mesh in the same process ran on one core (a build's factorisations
    1.5x slower, its solves 1.8x)."""
    _point_pypardiso_at_mkl()
    from pypardiso import PyPardisoSolver

    solver = PyPardisoSolver(mtype=_REAL_SYMMETRIC_INDEFINITE)
    solver.libmkl.MKL_Set_Num_Threads(_threads())
    return solver


class Pardiso:
    """LDL^T of a symmetric matrix given by its upper triangle; analysis done once.

    MKL is called directly with the pattern's 1-based indices kept from the analysis (pypardiso's
    own call converts them again at every solve)."""

    name = "pardiso"

    def __init__(self) -> None:
        self._solver = _pardiso_solver()
        for i, value in _IPARM.items():
            self._solver.set_iparm(i, value)
        self._pattern: tuple[np.ndarray, np.ndarray] | None = None
        self._ia = self._ja = self._data = None
        self.n_analyses = 0
        self.n_factorizations = 0
        self.negative_pivots = 0

    def _phase(self, phase: int, b: np.ndarray) -> np.ndarray:
        s = self._solver
        x = np.empty_like(b)
        error = ctypes.c_int32(0)

        def ref(value: int):
            return ctypes.byref(ctypes.c_int32(value))

        s._mkl_pardiso(s.pt.ctypes.data_as(ctypes.POINTER(s._pt_type[0])), ref(1), ref(1), ref(s.mtype),
                       ref(phase), ref(b.shape[0]), self._data.ctypes.data_as(_DOUBLE_P),
                       self._ia.ctypes.data_as(_INT_P), self._ja.ctypes.data_as(_INT_P),
                       s.perm.ctypes.data_as(_INT_P), ref(1 if b.ndim == 1 else b.shape[1]),
                       s.iparm.ctypes.data_as(_INT_P), ref(0), b.ctypes.data_as(_DOUBLE_P),
                       x.ctypes.data_as(_DOUBLE_P), ctypes.byref(error))
        if error.value != 0:
            raise SolveError(f"PARDISO phase {phase} failed: error {error.value}")
        return x

    def factor(self, matrix: sp.csr_matrix) -> None:
        """Numerically factor ``matrix`` (upper-triangular CSR, sorted indices)."""
        # compare contents, not identity: scipy's csr_matrix may hand back new index arrays
        # for the same pattern, and a needless analysis costs more than the factorisation
        same = (self._pattern is not None and np.array_equal(self._pattern[0], matrix.indptr)
                and np.array_equal(self._pattern[1], matrix.indices))
        self._data = np.ascontiguousarray(matrix.data, dtype=float)
        self._solver.set_iparm(12, 0)  # CSR, not transposed
        dummy = np.zeros((matrix.shape[0], 1), order="F")
        if not same:
            if self._pattern is not None:  # MKL keeps an earlier analysis's memory unless told to free it:
                self._solver.free_memory(everything=True)  # 150 MB each on the fPN as self-contact grows the pattern
            self._pattern = (matrix.indptr.copy(), matrix.indices.copy())
            self._ia = (matrix.indptr + 1).astype(np.int32)
            self._ja = (matrix.indices + 1).astype(np.int32)
            self._phase(11, dummy)
            self.n_analyses += 1
        self._phase(22, dummy)
        self.n_factorizations += 1
        self.negative_pivots = int(self._solver.iparm[22])

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve with the last factorisation."""
        return np.ascontiguousarray(self._phase(33, np.asfortranarray(rhs, dtype=float)))

    def release(self) -> None:
        """Free PARDISO's memory."""
        if self._data is not None:
            self._solver.free_memory(everything=True)
            self._data = None
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


def one_blas_thread(solve: Callable[..., T]) -> Callable[..., T]:
    """Run ``solve`` with numpy's and SciPy's OpenBLAS on one thread (threadpoolctl), restored after.

    A curve's vector products (norms, dots of 35k unknowns) are too short to share, but each one
    woke OpenBLAS's second thread, which then spun waiting for more and took a core from the
    factorisations, the back-substitutions and the compiled assembly running on both: on the fPN's
    build curve the back-substitutions took 33-48 ms instead of 16 ms, the whole curve 80 s instead
    of 45 s."""

    @functools.wraps(solve)
    def wrapper(*args, **kwargs):
        from threadpoolctl import ThreadpoolController

        with ThreadpoolController().select(internal_api="openblas").limit(limits=1):
            return solve(*args, **kwargs)

    return wrapper


@functools.cache
def _pardiso_importable() -> str | None:
    """None when pypardiso (and MKL behind it) loads, else why not."""
    _point_pypardiso_at_mkl()
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
