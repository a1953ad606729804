"""Long recordings reduced to the rows a diagnosis needs, by a stated rule (docs/diagnosis.md#long-recordings).

A logger at 1 kHz on a slow quasi-static ramp writes thousands of rows per kPa: neighbouring rows carry
the same state and differ only by their noise. A diagnosis compares every row with the model many
hundreds of times (calibration, every candidate effect, held-out folds, bootstrap resamples), so its
time and memory grow with the rows, not with what they say. A recording longer than :data:`MAX_ROWS`
is therefore reduced as it is read:

- **bending, pv, force** (quasi-static): the rows are cut into *stretches* that a block may never
  cross: a change of ``cycle`` or ``phase``, and a turn of the pressure (it comes back from its
  running extreme by more than :data:`TURN_SHARE` of the recording's pressure span and more than
  :data:`TURN_NOISE` times its own noise, so a transducer's noise does not make turns). Each stretch
  is cut into the fewest consecutive blocks (in recording order) of at most k rows, as equal as can
  be, k the smallest with at most :data:`MAX_ROWS` blocks in all (k = ceil(n / MAX_ROWS) unless
  stretches end blocks early). Each block becomes one row: the mean of every numeric column
  (pressure, tip, angle, volume, force, time), its cycle and phase. :data:`MAX_ROWS` is 500 rows for
  these kinds.
- **step**: the dynamics are fastest just after a valve switches, so a block never crosses a switch
  (the supply crossing half its peak, where :class:`pnmold.pneumatics.StepProtocol` reads one) and
  blocks widen with the time since it: the first M rows after each switch are kept as recorded, and
  after that a block starting j rows after the switch spans floor(j / M) rows (a share 1/M of the
  time since the switch, for a steady logger); M the largest that leaves at most :data:`MAX_ROWS` rows
  (2000 for a step recording).

Every kept row carries how many recorded rows it averages (column :data:`AVERAGED`): the diagnosis
takes its measurement noise as the recorded rows' noise over sqrt(k), with the noise estimated from
the kept rows themselves (:func:`pnmold.diagnose.data.noise_sigma`), so noise that does not average
down (correlated in time, or the scatter between cycles) is not taken for less than it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from pnmold.errors import RecordingError

from .format import Recording

#: most rows of one recording a diagnosis reads as recorded, by kind. Quasi-static: every row is a rod
#: solve in each of the diagnosis's 1500-2600 model runs (about 50 us a row of its own pressure, measured:
#: 950 rows with a Mullins softening to name took 96 s, benchmarks/big_recording.py), and a curve has no
#: more shape than a few hundred rows resolve (assumed). Step: the step model's cost is the time it
#: integrates, not its rows; its own recordings hold 2000 rows a second (0.5 s by default). The
#: benchmarks' recordings hold 16-300 rows a ramp or pulse, a real rig's 15-40 a ramp.
MAX_ROWS = {"bending": 500, "pv": 500, "force": 500, "step": 2000}
#: a recording with more lines than this is refused before it is read (reading a row of CSV costs about
#: 1 kB of memory at its peak, measured on 1M rows: benchmarks/big_recording.py)
MAX_READ_ROWS = 2_000_000
#: the column of a reduced recording: how many recorded rows each kept row averages
AVERAGED = "averaged_rows"
#: a pressure that comes back from its running extreme by more than this share of the recording's span, and
#: by more than this many times its own noise (the scatter of its first differences), has turned: a new ramp
#: (assumed: the widest excursion of a Gaussian noise over a million rows is about +-5 standard deviations)
TURN_SHARE, TURN_NOISE = 0.02, 10.0
QUASI_STATIC_RULE = "block_mean"
STEP_RULE = "log_time"


@dataclass(frozen=True)
class Reduction:
    """How a recording was reduced: ``rows_recorded`` to ``rows``, by ``rule`` with its ``parameter``
    (``block_mean``: k, the most rows a block averages; ``log_time``: M, the rows kept as recorded after
    every valve switch), over ``stretches`` that no block crosses."""

    path: str
    kind: str
    rule: str
    rows_recorded: int
    rows: int
    parameter: int
    stretches: int
    limit: int  # the most rows read as recorded

    @property
    def words(self) -> str:
        head = (f"{self.path}: {self.rows_recorded} rows, more than the {self.limit} a diagnosis reads of a "
                f"{self.kind} recording as recorded: reduced to {self.rows} rows")
        noise = "its measurement noise is a recorded row's over sqrt(the rows it averages)"
        if self.rule == QUASI_STATIC_RULE:
            return (f"{head}, each the mean of a block of at most {self.parameter} consecutive rows (in recording "
                    f"order; no block crosses a change of cycle or phase or a turn of the pressure: "
                    f"{self.stretches} stretch{'es' if self.stretches != 1 else ''}); {noise}.")
        return (f"{head}: the first {self.parameter} rows after the start and after every valve switch kept as "
                f"recorded, later ones averaged in blocks spanning at most 1/{self.parameter} of the time since "
                f"the switch (no block crosses one: {self.stretches} stretch{'es' if self.stretches != 1 else ''}); "
                f"each kept row's {noise[4:]}.")

    def as_json(self) -> dict[str, Any]:
        key = "rows_per_block" if self.rule == QUASI_STATIC_RULE else "rows_after_switch"
        return {"rule": self.rule, "rows_recorded": self.rows_recorded, "rows": self.rows, key: self.parameter,
                "stretches": self.stretches, "limit": self.limit, "words": self.words}


def count_lines(path: str | Path) -> int:
    """Lines in ``path`` (an upper bound of its rows), counted in binary chunks without parsing."""
    n, last = 0, b"\n"
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            n += chunk.count(b"\n")
            last = chunk[-1:]
    return n + (last != b"\n")


def check_size(path: str | Path, limit: int | None = None) -> None:
    """Refuse (RecordingError, exit 2) a file of more than ``limit`` lines (default :data:`MAX_READ_ROWS`)
    before it is read."""
    limit = limit or MAX_READ_ROWS
    try:
        lines = count_lines(path)
    except OSError:
        return  # read_recording names what is wrong with it
    if lines > limit:
        raise RecordingError(str(path), None, (
            f"{lines} lines, more than the {limit} pnmold reads (reading takes about 1 kB of memory a row). "
            f"Average it before (e.g. consecutive blocks of {math.ceil(lines / MAX_ROWS['bending'])} rows, never "
            f"across a cycle, phase or valve switch) or split it by cycle; a diagnosis reads at most "
            f"{MAX_ROWS['bending']} rows of a quasi-static recording and {MAX_ROWS['step']} of a step recording as "
            f"recorded."))


def stretches(rec: Recording) -> list[tuple[int, int]]:
    """(first, end) row ranges that no block may cross: see the module docstring."""
    n = len(rec)
    cols = rec.columns
    if rec.kind == "step":
        supply = np.asarray(cols["supply_kpa"], float)
        state = supply >= 0.5 * float(np.max(supply))
        cuts = np.flatnonzero(state[1:] != state[:-1]) + 1
    else:
        change = np.zeros(n - 1, bool)
        for name in ("cycle", "phase"):
            if name in cols:
                v = np.asarray(cols[name])
                change |= v[1:] != v[:-1]
        cuts = np.flatnonzero(change) + 1
    edges = [0, *cuts.tolist(), n]
    runs = list(zip(edges[:-1], edges[1:], strict=True))
    if rec.kind == "step":
        return runs
    p = np.asarray(cols["pressure_kpa"], float)
    step = np.diff(p)
    noise = 1.4826 * float(np.median(np.abs(step - np.median(step)))) / math.sqrt(2.0)  # the transducer's
    tol = max(TURN_SHARE * float(np.ptp(p)), TURN_NOISE * noise)
    return [part for a, b in runs for part in _turned(p, a, b, tol)]


def _turned(p: np.ndarray, a: int, b: int, tol: float) -> list[tuple[int, int]]:
    """Rows a..b cut after every row where the pressure turns (comes back by more than ``tol``)."""
    q = p[a:b].tolist()
    out, start, direction = [], 0, 0
    hi = lo = 0
    i = 1
    while i < len(q):
        if q[i] > q[hi]:
            hi = i
        if q[i] < q[lo]:
            lo = i
        if direction >= 0 and q[hi] - q[i] > tol and (direction == 1 or q[hi] - q[start] > tol):
            turn, direction = hi, -1
        elif direction <= 0 and q[i] - q[lo] > tol and (direction == -1 or q[start] - q[lo] > tol):
            turn, direction = lo, 1
        else:
            if direction == 0 and q[hi] - q[lo] > tol:  # the first move sets the direction
                direction = 1 if hi > lo else -1
            i += 1
            continue
        out.append((a + start, a + turn + 1))
        start = hi = lo = turn + 1
        i = start + 1
    out.append((a + start, b))
    return [(s, e) for s, e in out if e > s]


def _even_blocks(length: int, k: int) -> list[int]:
    """Sizes of the fewest consecutive blocks of at most ``k`` rows, as equal as can be."""
    m = -(-length // k)
    base, extra = divmod(length, m)
    return [base + 1] * extra + [base] * (m - extra)


def _log_blocks(length: int, m: int) -> list[int]:
    """Sizes of the blocks of a stretch after a valve switch: the block starting j rows in spans max(1, j // m)."""
    out, j = [], 0
    while j < length:
        w = min(max(1, j // m), length - j)
        out.append(w)
        j += w
    return out


def _plan(rec: Recording, parts: list[tuple[int, int]], max_rows: int) -> tuple[list[int], int]:
    """Block sizes over the whole recording, in order, and the rule's parameter (k or M)."""
    lengths = [b - a for a, b in parts]
    if rec.kind == "step":
        lo, hi = 1, max_rows  # the largest M whose blocks number at most max_rows
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if sum(len(_log_blocks(n, mid)) for n in lengths) <= max_rows:
                lo = mid
            else:
                hi = mid - 1
        return [w for n in lengths for w in _log_blocks(n, lo)], lo
    lo, hi = max(1, -(-len(rec) // max_rows)), max(lengths)  # the smallest k leaving at most max_rows blocks
    while lo < hi:  # (past the longest stretch every stretch is one block: as few as the stretches allow)
        mid = (lo + hi) // 2
        if sum(-(-n // mid) for n in lengths) <= max_rows:
            hi = mid
        else:
            lo = mid + 1
    return [w for n in lengths for w in _even_blocks(n, lo)], lo


def reduce_recording(rec: Recording, max_rows: int | None = None) -> tuple[Recording, Reduction | None]:
    """``rec`` reduced by the module's rule when it holds more than ``max_rows`` rows (default :data:`MAX_ROWS`
    of its kind; else as it is, and None). The reduced recording has the same kind, metadata and columns,
    one row per block, and the column :data:`AVERAGED`."""
    n = len(rec)
    max_rows = max_rows or MAX_ROWS[rec.kind]
    if n <= max_rows:
        return rec, None
    parts = stretches(rec)
    sizes, parameter = _plan(rec, parts, max_rows)
    sizes_arr = np.asarray(sizes, np.int64)
    starts = np.concatenate([[0], np.cumsum(sizes_arr)[:-1]])
    columns: dict[str, np.ndarray] = {}
    for name, values in rec.columns.items():
        v = np.asarray(values)
        if name == "cycle" or not np.issubdtype(v.dtype, np.number):
            columns[name] = v[starts]  # constant within a block: no block crosses a change
        else:
            columns[name] = np.add.reduceat(v.astype(float), starts) / sizes_arr
    columns[AVERAGED] = sizes_arr
    rule = STEP_RULE if rec.kind == "step" else QUASI_STATIC_RULE
    return replace(rec, columns=columns), Reduction(rec.path, rec.kind, rule, n, len(sizes), parameter, len(parts),
                                                    max_rows)


def averaged_rows(rec: Recording) -> np.ndarray | None:
    """Per row, how many recorded rows it averages (None: a recording as recorded)."""
    k = rec.columns.get(AVERAGED)
    return None if k is None else np.asarray(k, float)
