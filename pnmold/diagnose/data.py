"""Recordings as one standardised data set: observables, noise, branches and blocks.

Every recording contributes its observables (bending: tip x and z; pv: volume; force:
force; step: the inlet pressure and, when recorded, the bend angle, the metered flow, the far
chamber's pressure and the cavity's volume change). Each observable of each
recording gets a noise level estimated from the data itself, so residuals of different
units can be pooled as z-scores. Rows are grouped into *branches* (one cycle's inflation
or deflation of one recording) and branches into short contiguous *blocks*; held-out
error is computed by leaving out whole blocks, never single rows (DIAGNOSE.md: samples
next to each other are correlated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pnmold.recording import Recording

#: observables a diagnosis compares, per recording kind (in the recording's units)
OBSERVABLES = {
    "bending": ("tip_x_mm", "tip_z_mm"),
    "pv": ("volume_ml",),
    "force": ("force_n",),
    "step": ("pressure_kpa", "bend_angle_deg", "flow_slpm", "pressure_far_kpa", "volume_ml"),
}
#: rows per held-out block (at least); a branch of 30 rows gives 5 blocks
BLOCK_ROWS = 6
FOLDS = 5


@dataclass(frozen=True, eq=False)
class Series:
    """One observable of one recording."""

    recording: int  # index into the list of recordings
    observable: str
    y: np.ndarray  # measured values, in the recording's units
    sigma: float  # noise estimated from the data (same units)
    branch: np.ndarray  # (n,) branch id of each row (global over the data set)
    block: np.ndarray  # (n,) block id of each row (global over the data set)
    rows: np.ndarray  # (n,) row indices in the recording

    @property
    def name(self) -> str:
        return f"{self.observable}[{self.recording}]"


@dataclass(frozen=True, eq=False)
class DataSet:
    """All series with their block structure."""

    recordings: tuple[Recording, ...]
    series: tuple[Series, ...]

    @property
    def n(self) -> int:
        return int(sum(s.y.size for s in self.series))

    @property
    def blocks(self) -> np.ndarray:
        return np.concatenate([s.block for s in self.series])

    @property
    def folds(self) -> np.ndarray:
        """Fold id of every row: blocks dealt round-robin, so each fold spans every regime."""
        return self.blocks % FOLDS


def branches_of(rec: Recording) -> np.ndarray:
    """Branch index per row: a new branch where cycle or phase changes, or pressure turns."""
    n = len(rec)
    keys = []
    cycle = rec.columns.get("cycle")
    phase = rec.columns.get("phase")
    for i in range(n):
        keys.append((None if cycle is None else cycle[i], None if phase is None else phase[i]))
    out = np.zeros(n, dtype=int)
    b = 0
    if rec.kind == "step":
        return out
    p = np.asarray(rec.columns["pressure_kpa"], float)
    direction = 0.0
    for i in range(1, n):
        dp = p[i] - p[i - 1]
        turned = direction != 0 and dp != 0 and np.sign(dp) != direction
        if keys[i] != keys[i - 1] or turned:
            b += 1
            direction = 0.0
        if dp != 0:
            direction = float(np.sign(dp))
        out[i] = b
    return out


def noise_sigma(residual: np.ndarray, branch: np.ndarray, floor: float) -> float:
    """Noise from the scatter of second differences of ``residual`` within branches:
    for white noise of level s, y[i-1] - 2 y[i] + y[i+1] has standard deviation s sqrt(6);
    the median absolute deviation keeps a few outliers or a knee from inflating it."""
    d2 = []
    for b in np.unique(branch):
        r = residual[branch == b]
        if r.size >= 3:
            d2.append(r[:-2] - 2.0 * r[1:-1] + r[2:])
    if not d2:
        return floor
    d = np.concatenate(d2)
    mad = float(np.median(np.abs(d - np.median(d))))
    return max(1.4826 * mad / np.sqrt(6.0), floor)


def observables_of(rec: Recording) -> tuple[str, ...]:
    return tuple(c for c in OBSERVABLES[rec.kind] if c in rec.columns)


def build_dataset(recordings: list[Recording], baseline: list[dict[str, np.ndarray]]) -> DataSet:
    """Series for every observable of every recording; noise from the residual against
    ``baseline`` (a first prediction per recording), which removes the curve's own shape
    from the second differences."""
    series: list[Series] = []
    branch0 = block0 = 0
    for i, rec in enumerate(recordings):
        branch = branches_of(rec)
        block = np.zeros(len(rec), dtype=int)
        nxt = 0
        for b in np.unique(branch):
            idx = np.where(branch == b)[0]
            nblocks = max(1, idx.size // BLOCK_ROWS)
            block[idx] = nxt + np.arange(idx.size) * nblocks // idx.size
            nxt += nblocks
        for name in observables_of(rec):
            y = np.asarray(rec.columns[name], float)
            span = float(np.ptp(y)) if y.size else 1.0
            sigma = noise_sigma(y - baseline[i][name], branch, floor=1e-4 * max(span, 1e-9))
            series.append(Series(i, name, y, sigma, branch + branch0, block + block0, np.arange(len(rec))))
        branch0 += int(branch.max(initial=0)) + 1
        block0 += int(block.max(initial=0)) + 1
    return DataSet(tuple(recordings), tuple(series))
