"""A sweep from start to finish: what ``pnmold sweep`` does, as one library call."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from pnmold.errors import UsageError
from pnmold.sweep.plot import plot_sweep
from pnmold.sweep.run import OnUpdate, SweepResult, run_sweep
from pnmold.sweep.spec import SweepSpec
from pnmold.sweep.store import SweepStore, default_db

EXPORTS = ("csv",)


@dataclass(frozen=True)
class SweepRun:
    """A finished sweep and the files written (the database first)."""

    result: SweepResult
    written: tuple[Path, ...]


def finish_sweep(spec: SweepSpec, *, db: str | os.PathLike | None = None, scheduler: str | None = None,
                 workers: int | None = None, export: str | None = None, on_update: OnUpdate | None = None) -> SweepRun:
    """Compute the sweep's unfinished points (local processes, or the Dask cluster at ``scheduler``)
    into ``db`` (default :func:`default_db`), and write the table (``export='csv'``) and, for one
    axis with the FE, the figure beside the database."""
    if scheduler and workers is not None:
        raise UsageError("--workers sizes the local pool; with --scheduler the cluster's workers run the points")
    if export is not None and export not in EXPORTS:
        raise UsageError(f"--export: one of {', '.join(EXPORTS)}, got {export!r}")
    result = run_sweep(spec, db or default_db(spec.name), scheduler=scheduler, workers=workers, on_update=on_update)
    written = [result.db]
    if export == "csv":
        with SweepStore(result.db, spec.fields) as store:
            written.append(store.export_csv())
    if len(spec.axes) == 1 and spec.run.fem:
        figure = result.db.with_suffix(".png")
        plot_sweep(spec, result.rows, figure)
        written.append(figure)
    return SweepRun(result, tuple(Path(p) for p in written))
