"""Design sweeps: a sweep file (TOML) -> points -> builds on local processes or a Dask
cluster -> one SQLite row per point, resumable after any interruption.

Modules: ``spec`` (the sweep file), ``points`` (grid or random points, stable keys),
``run`` (workers and the coordinator loop), ``store`` (SQLite), ``plot`` (the figure),
``progress`` (the terminal bar the CLI shows), ``files`` (a sweep file end to end).
"""

from pnmold.sweep.files import SweepRun, finish_sweep
from pnmold.sweep.points import Point, expand_points
from pnmold.sweep.run import THREAD_ENV, SweepResult, run_point, run_sweep
from pnmold.sweep.spec import SweepError, SweepSpec, load_sweep
from pnmold.sweep.store import SweepStore, default_db

__all__ = ["THREAD_ENV", "Point", "SweepError", "SweepResult", "SweepSpec", "SweepStore", "default_db",
           "SweepRun", "expand_points", "finish_sweep", "load_sweep", "run_point", "run_sweep"]
