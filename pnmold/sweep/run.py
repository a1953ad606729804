"""Running a sweep: the worker function (one point -> one row) and the coordinator loop.

Local processes by default: a ``ProcessPoolExecutor`` with the spawn start method (each
worker a fresh interpreter: no forked gmsh/OCC state, and the single-thread environment
is in place before numpy, numba or PARDISO load). It needs no scheduler, no ports and
starts in about a second, which a local Dask cluster does not give for free. With a
scheduler address the same loop drives a Dask cluster through its
``concurrent.futures`` interface. Workers only compute and return rows; the coordinator
alone writes the database, one commit per arriving row.
"""

from __future__ import annotations

import logging
import os
import shutil
import socket
import sys
import tempfile
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pnmold.errors import DesignError, PnmoldError, UsageError
from pnmold.sweep.points import Point, expand_points
from pnmold.sweep.spec import RunOptions, SweepSpec
from pnmold.sweep.store import SweepStore

if TYPE_CHECKING:
    from pnmold.design import Design

log = logging.getLogger(__name__)

#: one thread per worker process for every numerics library (set before they load)
THREAD_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
              "NUMBA_NUM_THREADS": "1"}


def default_workers() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


# -- the worker side ----------------------------------------------------------------------
def one_thread() -> None:
    """One thread per numerics library in this process (pool workers, and workers pnmold did not start).
    The environment counts only for libraries not yet loaded; numba re-reads it at every
    compile and fails (RuntimeError) when NUMBA_NUM_THREADS changed after its threads
    started, so once numba is loaded its own run-time setting is used instead."""
    numba = sys.modules.get("numba")
    os.environ.update({k: v for k, v in THREAD_ENV.items() if numba is None or k != "NUMBA_NUM_THREADS"})
    if numba is not None:
        numba.set_num_threads(1)


def _init_local_worker(parent_pid: int) -> None:
    """Pool initializer: single-threaded numerics, and exit when the coordinator is gone
    (a SIGKILLed coordinator must not leave workers computing for nobody)."""
    one_thread()

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="pnmold-parent-watch", daemon=True).start()


def _threads() -> dict[str, Any]:
    found: dict[str, Any] = {k: os.environ.get(k) for k in THREAD_ENV}
    if "numba" in sys.modules:
        found["numba"] = sys.modules["numba"].get_num_threads()
    return found


def max_rss_mb() -> float:
    """Peak resident memory of this process, MB (MiB): ``getrusage`` where there is one (KiB on
    Linux, bytes on macOS), else psutil's peak working set (Windows)."""
    try:
        import resource
    except ImportError:  # Windows
        import psutil

        info = psutil.Process().memory_info()
        return round(getattr(info, "peak_wset", info.rss) / 2**20, 1)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return round(peak / (2**20 if sys.platform == "darwin" else 1024), 1)


def apply_values(base: Design, values: tuple[tuple[str, Any], ...]) -> Design:
    """``base`` with the point's fields set, checked by the design rules (DesignError)."""
    from pnmold.design import validate

    design = base
    for name, value in values:
        section, key = name.split(".", 1)
        design = design.replace(section, **{key: value})
    return validate(design)


def run_point(point: Point, base: Design, run: RunOptions, build_dir: str | None = None) -> dict[str, Any]:
    """Build one point; never raises for a bad design or a failed build: the returned
    ``{"row": ..., "report": ...}`` says what happened (status ok, refused, failed, check_failed)."""
    one_thread()
    started, cpu0 = time.time(), time.process_time()
    row: dict[str, Any] = {"key": point.key, "overrides": point.as_dict(), **point.as_dict(),
                           "fem": run.fem, "mesh_wall_mm": run.wall_mm, "mesh_max_mm": run.max_mm,
                           "pressure_limit_kpa": run.max_pressure_kpa, "started_at": started,
                           "worker": f"{socket.gethostname()}:{os.getpid()}"}
    report = None
    try:
        design = apply_values(base, point.values)
    except DesignError as err:
        row.update(status="refused", error_field=err.field, error_type=type(err).__name__, error=str(err))
    else:
        from pnmold.design import digest, to_toml

        row.update(design_name=design.name, design_digest=digest(design), design_toml=to_toml(design))
        try:
            report = _build(design, run, build_dir)
            row.update(summarize(report, design, run))
        except Exception as err:  # every failure is a result of the sweep, not its end
            log.warning("point %s failed: %s: %s", point.key, type(err).__name__, err)
            row.update(status="failed", error_type=type(err).__name__, error=str(err) or repr(err),
                       error_field=getattr(err, "field", None) or getattr(err, "feature", None))
    finished = time.time()
    row.update(finished_at=finished, time_s=round(finished - started, 3), cpu_s=round(time.process_time() - cpu0, 3),
               worker_threads=_threads(), worker_max_rss_mb=max_rss_mb())
    return {"row": row, "report": report}


def _build(design: Design, run: RunOptions, build_dir: str | None) -> dict[str, Any]:
    from pnmold.pipeline import build

    size = None
    if run.fem and (run.wall_mm or run.max_mm):
        from pnmold.tetmesh import MeshSize

        default = MeshSize()
        size = MeshSize(run.wall_mm or default.wall_mm, run.max_mm or default.max_mm)
    tmp = None if build_dir else tempfile.mkdtemp(prefix="pnmold-sweep-")
    try:
        out = Path(build_dir) if build_dir else Path(tmp) / design.name
        return build(design, out, fem=run.fem, use_slicer=False, fem_size=size).report
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)


def summarize(report: dict[str, Any], design: Design, run: RunOptions) -> dict[str, Any]:
    """The row's result columns from a build report (schema pnmold.build/1).

    ``cavity_volume_ml`` is the air at rest: the interior mold's chambers and channel (its
    volume less its base plate; the gate proves the cavity is exactly these cores).
    With ``run.max_pressure_kpa`` the FE curve is cut there: a full bend above it counts
    as not reached."""
    failed = [c["id"] for c in report["checks"] if c["passed"] is False]
    fem = report["fem"]
    steps, bend, reason = fem.get("steps") or [], fem.get("full_bend_pressure_kpa"), fem.get("reason")
    limit = run.max_pressure_kpa
    if limit is not None:
        steps = [s for s in steps if s["pressure_kpa"] <= limit + 1e-9]
        if bend is not None and bend > limit:
            reason = f"not fully bent at run.max_pressure_kpa = {limit:g} kPa (full bend at {bend:.4g} kPa)"
            bend = None
    parts, pours, m = report["parts"], report["pours"], design.mold
    plate_mm3 = (design.length_mm + 2 * m.ledge_mm) * (design.width_mm + 2 * m.ledge_mm) * m.plate_mm
    by_part = {p["part"]: p for p in pours}
    fe_failed = not failed and fem.get("stop") == "failed"  # the parts stand, the FE curve is partial
    return {
        "status": "check_failed" if failed else "failed" if fe_failed else "ok",
        **({"error_type": "SolveError", "error": reason} if fe_failed else {}),
        "checks_failed": len(failed), "failed_checks": failed,
        "checks_skipped": sum(1 for c in report["checks"] if c["passed"] is None),
        "full_bend_pressure_kpa": bend, "reason": reason,
        "fem_max_pressure_kpa": max((s["pressure_kpa"] for s in steps), default=None),
        "max_principal_stretch": max((s["max_principal_stretch"] for s in steps), default=None),
        "cavity_volume_ml": round((parts["mold_interior"]["volume_mm3"] - plate_mm3) / 1000, 5),
        "actuator_volume_ml": round(parts["actuator"]["volume_mm3"] / 1000, 5),
        "pour_top_ml": by_part["top_layer"]["volume_ml"], "pour_bottom_ml": by_part["bottom_layer"]["volume_ml"],
        "elastomer_ml": round(sum(p["volume_ml"] for p in pours), 4),
        "elastomer_g": round(sum(p["mass_g"] for p in pours), 4),
        "part_a_g": round(sum(p["part_a_g"] for p in pours), 4),
        "part_b_g": round(sum(p["part_b_g"] for p in pours), 4),
        "pours": pours, "timings_s": {**report["timings_s"], **({"fem_" + k: v for k, v in
                                                                   fem.get("timings_s", {}).items()})},
    }


# -- the coordinator side -------------------------------------------------------------------
@dataclass
class Counts:
    """Progress of one invocation: ``total`` points to compute now, ``skipped`` found done."""

    total: int
    skipped: int = 0
    by_status: dict[str, int] = field(default_factory=lambda: dict.fromkeys(("ok", "refused", "failed",
                                                                              "check_failed"), 0))
    started: float = field(default_factory=time.monotonic)

    @property
    def done(self) -> int:
        return sum(self.by_status.values())

    @property
    def left(self) -> int:
        return self.total - self.done

    @property
    def eta_s(self) -> float | None:
        """Seconds left at the rate of this invocation so far (None before a point ends)."""
        if not self.done:
            return None
        return (time.monotonic() - self.started) / self.done * self.left


@dataclass(frozen=True)
class SweepResult:
    spec: SweepSpec
    db: Path
    points: list[Point]
    rows: list[dict[str, Any]]
    counts: Counts
    run_id: int


class _Pool:
    """Local process pool or Dask cluster, behind ``submit``; reopened if a local worker dies."""

    def __init__(self, workers: int, scheduler: str | None):
        self.workers, self.scheduler = workers, scheduler
        self.executor, self.client = None, None

    @property
    def label(self) -> str:
        return self.scheduler or "local"

    def open(self) -> None:
        if self.scheduler:
            self.client = _connect(self.scheduler)
            self.executor = self.client.get_executor(pure=False)
        else:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            self.executor = ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"),
                                                initializer=_init_local_worker, initargs=(os.getpid(),))

    def window(self) -> int:
        """Points in flight: one per local worker; twice the cluster's threads."""
        if self.client is None:
            return self.workers
        return max(2, 2 * sum(self.client.nthreads().values()))

    def close(self, cancel: bool = False) -> None:
        if self.client is not None:
            self.executor.shutdown(wait=not cancel)  # Dask: wait=False cancels
        elif self.executor is not None:
            self.executor.shutdown(wait=not cancel, cancel_futures=cancel)
        if self.client is not None:
            self.client.close()
        self.executor, self.client = None, None


def _connect(address: str):
    try:
        from distributed import Client
    except ImportError as err:
        raise UsageError(f"--scheduler {address}: a Dask cluster needs dask.distributed, which is not installed: "
                         "pip install 'pnmold[cluster]' (local sweeps, without --scheduler, need no more)") from err
    try:
        return Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError) as err:
        raise UsageError(f"--scheduler {address}: cannot connect to the Dask scheduler ({err})") from err


Worker = Callable[..., dict[str, Any]]
OnUpdate = Callable[[Counts, dict[str, Any] | None], None]


def run_sweep(spec: SweepSpec, db: str | os.PathLike, *, scheduler: str | None = None, workers: int | None = None,
              on_update: OnUpdate | None = None, worker: Worker = run_point) -> SweepResult:
    """Compute every point of ``spec`` not yet finished in ``db``; return all its rows.

    ``worker(point, base_design, run, build_dir)`` must be importable by the workers."""
    from pnmold.design import load_design

    db, notify = Path(db), on_update or (lambda counts, row: None)
    workers = workers or default_workers()
    if workers < 1:
        raise UsageError(f"--workers must be at least 1, got {workers}")
    base = load_design(spec.base)
    points = expand_points(spec)
    with SweepStore(db, spec.fields) as store:
        finished = store.finished_keys()
        todo = deque(p for p in points if p.key not in finished)
        counts = Counts(total=len(todo), skipped=len(points) - len(todo))
        pool = _Pool(workers, scheduler)
        run_id = store.start_run(spec.name, pool.label, 0 if scheduler else workers, len(points), counts.skipped)
        notify(counts, None)
        interrupted = True
        try:
            if todo:
                pool.open()
                builds = db.parent / spec.name if spec.run.keep_builds else None
                _drive(pool, todo, lambda p: (worker, p, base, spec.run, str(builds / p.key) if builds else None),
                       lambda row, report: _record(store, run_id, spec, counts, row, report, notify))
            interrupted = False
        finally:
            pool.close(cancel=interrupted)
            store.finish_run(run_id, interrupted)
        rows = store.rows([p.key for p in points])
    return SweepResult(spec, db, points, rows, counts, run_id)


def _record(store: SweepStore, run_id: int, spec: SweepSpec, counts: Counts, row: dict[str, Any],
            report: dict[str, Any] | None, notify: OnUpdate) -> None:
    row = {**row, "sweep": spec.name, "base": str(spec.base), "base_digest": spec.base_digest}
    store.add(run_id, row, report)
    counts.by_status[row["status"]] += 1
    notify(counts, row)


def _drive(pool: _Pool, todo: deque[Point], call: Callable[[Point], tuple], record: Callable) -> None:
    """Keep the pool's window full and record each row as it arrives. When a local worker
    process dies, the points then in flight are rerun one at a time, so the one that kills
    its worker is found and recorded as failed while the others complete."""
    inflight: dict[Future, Point] = {}
    suspects: deque[Point] = deque()
    alone: set[str] = set()

    def submit(queue: deque[Point]) -> bool:
        point = queue.popleft()
        fn, *args = call(point)
        try:
            inflight[pool.executor.submit(fn, *args)] = point
        except BrokenProcessPool:  # a worker died since the last results came in
            queue.appendleft(point)
            return False
        return True

    while todo or suspects or inflight:
        broken = False
        if suspects and not inflight:
            alone.add(suspects[0].key)
            broken = not submit(suspects)
        while not broken and not suspects and todo and len(inflight) < pool.window():
            broken = not submit(todo)
        done = wait(inflight, return_when=FIRST_COMPLETED)[0] if inflight else set()
        for future in done:
            point = inflight.pop(future)
            try:
                out = future.result()
            except BrokenProcessPool:
                broken = True
                if point.key not in alone:
                    suspects.append(point)
                    continue
                out = _crashed(point, "the worker process died while building this point", "BrokenProcessPool")
            except Exception as err:
                if type(err).__name__ != "KilledWorker":  # Dask gave up on it after its own retries
                    raise PnmoldError(f"sweep stopped ({pool.label}): {type(err).__name__}: {err}; "
                                      "finished points are kept, re-run to resume") from err
                out = _crashed(point, str(err), type(err).__name__)
            record(out["row"], out["report"])
        if broken:
            suspects.extend(inflight.values())
            inflight.clear()
            pool.close(cancel=True)
            pool.open()


def _crashed(point: Point, message: str, kind: str) -> dict[str, Any]:
    now = time.time()
    return {"row": {"key": point.key, "overrides": point.as_dict(), **point.as_dict(), "status": "failed",
                    "error_type": kind, "error": message, "finished_at": now}, "report": None}
