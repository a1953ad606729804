"""Sparse direct solves with PARDISO (Intel MKL, via pypardiso), symmetric indefinite.

The matrix is the upper triangle of the reduced tangent in CSR (what PARDISO wants for a
symmetric type). The sparsity pattern never changes along a curve, so the symbolic
analysis (reordering, phase 11) runs once and each Newton iteration does only the
numerical factorisation (phase 22) and the solve (phase 33). pypardiso exposes the phases
through ``set_phase``; its ``factorize``/``solve`` always re-run the analysis, so we call
its ``_call_pardiso`` directly.
"""

from __future__ import annotations

import logging
import os

import numpy as np
import scipy.sparse as sp
from pypardiso import PyPardisoSolver
from pypardiso.pardiso_wrapper import PyPardisoError

from ..errors import SolveError

log = logging.getLogger(__name__)

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

    def __init__(self) -> None:
        self._solver = PyPardisoSolver(mtype=_REAL_SYMMETRIC_INDEFINITE)
        for i, value in _IPARM.items():
            self._solver.set_iparm(i, value)
        self._pattern: tuple[np.ndarray, np.ndarray] | None = None
        self._matrix: sp.csr_matrix | None = None
        self.n_analyses = 0
        self.n_factorizations = 0
        self.negative_pivots = 0

    def _phase(self, phase: int, b: np.ndarray) -> np.ndarray:
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
