"""Design sweeps: the sweep file, points and keys, local vs Dask, kill-and-resume, the FE row."""

from __future__ import annotations

import csv
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pnmold.cli import main
from pnmold.sweep import SweepError, expand_points, load_sweep, run_sweep
from pnmold.sweep.run import THREAD_ENV

ROOT = Path(__file__).resolve().parents[1]
SWEEPS = ROOT / "templates" / "sweeps"

#: 2 x 2 grid on the fPN without FE: height 1.0 mm is refused (the channel is 1 mm high)
SMALL = """
[sweep]
name = "small"
base = "fpn"
[axes]
chambers.count = [3, 4]
chambers.height_mm = [1.0, 6.0]
[run]
fem = false
"""
#: the columns that must not depend on where a point ran
SAME = ("key", "status", "overrides", "chambers.count", "chambers.height_mm", "design_digest", "checks_failed",
        "failed_checks", "error_field", "cavity_volume_ml", "actuator_volume_ml", "pour_top_ml", "pour_bottom_ml",
        "elastomer_ml", "elastomer_g", "reason")


def write(tmp_path: Path, text: str, name: str = "sweep.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def read_rows(db: Path) -> dict[str, dict]:
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    con.row_factory = sqlite3.Row
    try:
        return {r["key"]: dict(r) for r in con.execute("SELECT * FROM points")}
    finally:
        con.close()


# -- the sweep file -------------------------------------------------------------------------
BAD = [
    ("unknown-field", '[sweep]\nbase = "fpn"\n[axes]\nchambers.heigth_mm = [5.0]\n', "axes.chambers.heigth_mm"),
    ("unknown-section", '[sweep]\nbase = "fpn"\n[axes]\n"chamber.height_mm" = [5.0]\n', "axes.chamber.height_mm"),
    ("empty-axis", '[sweep]\nbase = "fpn"\n[axes]\nchambers.count = []\n', "axes.chambers.count"),
    ("no-axis", '[sweep]\nbase = "fpn"\n[axes]\n', "axes"),
    ("range-backwards", '[sweep]\nbase = "fpn"\n[axes]\nchambers.height_mm = {start = 9, stop = 5, step = 1}\n',
     "axes.chambers.height_mm"),
    ("range-zero-step", '[sweep]\nbase = "fpn"\n[axes]\nchambers.height_mm = {start = 5, stop = 9, step = 0}\n',
     "axes.chambers.height_mm.step"),
    ("range-unknown-key", '[sweep]\nbase = "fpn"\n[axes]\nchambers.height_mm = {start = 5, end = 9, num = 3}\n',
     "axes.chambers.height_mm.end"),
    ("grid-needs-step", '[sweep]\nbase = "fpn"\n[axes]\nchambers.height_mm = {start = 5, stop = 9}\n',
     "axes.chambers.height_mm"),
    ("int-range-fraction", '[sweep]\nbase = "fpn"\n[axes]\nchambers.count = {start = 3, stop = 6, num = 3}\n',
     "axes.chambers.count.num"),
    ("wrong-type", '[sweep]\nbase = "fpn"\n[axes]\nchambers.count = [3, 4.5]\n', "axes.chambers.count"),
    ("unknown-base", '[sweep]\nbase = "no-such-design"\n[axes]\nchambers.count = [3]\n', "sweep.base"),
    ("missing-base", '[axes]\nchambers.count = [3]\n', "sweep.base"),
    ("bad-sampling", '[sweep]\nbase = "fpn"\nsampling = "latin"\n[axes]\nchambers.count = [3]\n', "sweep.sampling"),
    ("random-without-n", '[sweep]\nbase = "fpn"\nsampling = "random"\n[axes]\nchambers.count = [3]\n', "sweep.n"),
    ("n-on-a-grid", '[sweep]\nbase = "fpn"\nn = 4\n[axes]\nchambers.count = [3]\n', "sweep.n"),
    ("unknown-table", '[sweep]\nbase = "fpn"\n[axes]\nchambers.count = [3]\n[runs]\nfem = true\n', "runs"),
    ("run-key", '[sweep]\nbase = "fpn"\n[axes]\nchambers.count = [3]\n[run]\nmesh_mm = 3\n', "run.mesh_mm"),
    ("run-pressure", '[sweep]\nbase = "fpn"\n[axes]\nchambers.count = [3]\n[run]\nmax_pressure_kpa = -5\n',
     "run.max_pressure_kpa"),
    ("not-toml", '[sweep\nbase = "fpn"\n', "sweep"),
]


@pytest.mark.parametrize(("text", "field"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_a_bad_sweep_file_is_refused_with_exit_2_naming_the_field(text, field, tmp_path, capsys):
    path = write(tmp_path, text)
    with pytest.raises(SweepError) as info:
        load_sweep(path)
    assert info.value.field == field and str(path) in str(info.value)
    assert main(["sweep", str(path), "--db", str(tmp_path / "x.sqlite"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert field in err and path.name in err
    assert not (tmp_path / "x.sqlite").exists()


def test_a_missing_sweep_file_exits_2(tmp_path):
    assert main(["sweep", str(tmp_path / "nope.toml"), "--quiet"]) == 2


@pytest.mark.parametrize("name", ["fig-s2a", "fig-s2b", "fig-s2c"])
def test_the_fig_s2_sweeps_load_with_fem_and_one_axis(name):
    spec = load_sweep(SWEEPS / f"{name}.toml")
    assert spec.name == name and spec.run.fem and len(spec.axes) == 1
    assert 3 <= len(expand_points(spec)) <= 4
    assert spec.run.wall_mm and spec.run.max_mm and spec.run.wall_mm <= spec.run.max_mm


# -- points and keys ------------------------------------------------------------------------
def test_grid_is_the_cartesian_product_and_ranges_include_stop(tmp_path):
    spec = load_sweep(write(tmp_path, '[sweep]\nbase = "fpn"\n[axes]\nchambers.count = {start = 3, stop = 7, '
                            'step = 2}\nchambers.height_mm = {start = 5, stop = 6, num = 3}\n'))
    points = expand_points(spec)
    assert [p.values for p in points[:3]] == [(("chambers.count", 3), ("chambers.height_mm", v))
                                              for v in (5.0, 5.5, 6.0)]
    assert len(points) == 9 and len({p.key for p in points}) == 9
    assert {p.as_dict()["chambers.count"] for p in points} == {3, 5, 7}


def test_keys_are_stable_across_spellings_and_change_with_base_and_run_options(tmp_path):
    dotted = load_sweep(write(tmp_path, '[sweep]\nbase = "fpn"\n[axes]\nchambers.height_mm = [5, 6]\n', "a.toml"))
    quoted = load_sweep(write(tmp_path, '[sweep]\nbase = "fpn"\n[axes]\n"chambers.height_mm" = [5.0, 6.0]\n',
                              "b.toml"))
    other_base = load_sweep(write(tmp_path, '[sweep]\nbase = "spn"\n[axes]\nchambers.height_mm = [5, 6]\n',
                                  "c.toml"))
    coarse = load_sweep(write(tmp_path, '[sweep]\nbase = "fpn"\n[axes]\nchambers.height_mm = [5, 6]\n'
                              '[run]\nwall_mm = 3.5\n', "d.toml"))
    keys = [[p.key for p in expand_points(s)] for s in (dotted, quoted, other_base, coarse)]
    assert keys[0] == keys[1]
    assert not set(keys[0]) & set(keys[2]) and not set(keys[0]) & set(keys[3])


def test_random_sampling_is_seeded_and_stays_in_range(tmp_path):
    text = ('[sweep]\nbase = "fpn"\nsampling = "random"\nn = 12\nseed = {seed}\n[axes]\n'
            'chambers.height_mm = {{start = 5, stop = 9}}\nchambers.count = [4, 6, 8]\n')
    a = expand_points(load_sweep(write(tmp_path, text.format(seed=1), "a.toml")))
    b = expand_points(load_sweep(write(tmp_path, text.format(seed=1), "b.toml")))
    c = expand_points(load_sweep(write(tmp_path, text.format(seed=2), "c.toml")))
    assert [p.key for p in a] == [p.key for p in b] != [p.key for p in c]
    assert len(a) == 12
    assert all(5 <= p.as_dict()["chambers.height_mm"] <= 9 and p.as_dict()["chambers.count"] in (4, 6, 8) for p in a)
    assert len({p.as_dict()["chambers.height_mm"] for p in a}) == 12  # continuous, not a grid


# -- running: local processes and a Dask cluster give the same rows ---------------------------
@pytest.fixture(scope="module")
def local_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("local")
    spec = load_sweep(write(tmp, SMALL))
    db = tmp / "small.sqlite"
    assert main(["sweep", str(spec.path), "--db", str(db), "--workers", "2", "--export", "csv", "--quiet"]) == 0
    return spec, db


def test_a_local_sweep_records_every_point_once_with_its_inputs_and_results(local_run):
    spec, db = local_run
    rows = read_rows(db)
    assert set(rows) == {p.key for p in expand_points(spec)}
    by_input = {(r["chambers.count"], r["chambers.height_mm"]): r for r in rows.values()}
    assert set(by_input) == {(3, 1.0), (3, 6.0), (4, 1.0), (4, 6.0)}
    for count in (3, 4):
        refused = by_input[count, 1.0]
        assert refused["status"] == "refused" and refused["error_field"] == "channel.height_mm"
        assert "lower than the chambers" in refused["error"] and refused["design_toml"] is None
        ok = by_input[count, 6.0]
        assert ok["status"] == "ok" and ok["checks_failed"] == 0 and json.loads(ok["failed_checks"]) == []
        assert f"count = {count}" in ok["design_toml"] and "height_mm = 6.0" in ok["design_toml"]
        # cavity: count chambers of 6 x 16 x 6 mm and the 2 x 1 mm channel outside them (2 + 4 mm per gap)
        assert ok["cavity_volume_ml"] == pytest.approx(count * 0.576 + 0.002 * (2 + 4 * (count - 1)), rel=1e-3)
        assert ok["elastomer_ml"] == pytest.approx(ok["pour_top_ml"] + ok["pour_bottom_ml"], rel=1e-6)
        assert ok["reason"] == "skipped (--no-fem)" and ok["full_bend_pressure_kpa"] is None
        assert json.loads(ok["worker_threads"]) == THREAD_ENV
        assert int(ok["worker"].rsplit(":", 1)[1]) != os.getpid()
    assert by_input[4, 6.0]["elastomer_ml"] > by_input[3, 6.0]["elastomer_ml"]
    with db.with_suffix(".csv").open(newline="") as fh:
        table = list(csv.DictReader(fh))
    assert {(r["key"], r["status"], r["chambers.height_mm"]) for r in table} == {
        (k, r["status"], str(r["chambers.height_mm"])) for k, r in rows.items()}


def test_a_dask_cluster_gives_the_same_rows_as_local_processes(local_run, tmp_path):
    distributed = pytest.importorskip("distributed")
    spec, local_db = local_run
    db = tmp_path / "dask.sqlite"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  env=dict(THREAD_ENV)) as cluster:
        assert main(["sweep", str(spec.path), "--db", str(db), "--scheduler", cluster.scheduler_address,
                     "--quiet"]) == 0
    local, remote = read_rows(local_db), read_rows(db)
    assert set(local) == set(remote) and len(remote) == 4
    for key in local:
        assert {c: remote[key][c] for c in SAME} == {c: local[key][c] for c in SAME}
    built = [r for r in remote.values() if r["status"] == "ok"]
    assert built and all(json.loads(r["worker_threads"])["OMP_NUM_THREADS"] == "1" for r in built)
    con = sqlite3.connect(db)
    assert con.execute("SELECT scheduler, points_run FROM runs").fetchall() == [(cluster.scheduler_address, 4)]
    con.close()


def test_workers_with_a_scheduler_is_bad_usage(local_run):
    spec, db = local_run
    assert main(["sweep", str(spec.path), "--db", str(db), "--scheduler", "tcp://127.0.0.1:1",
                 "--workers", "2", "--quiet"]) == 2


# -- kill the coordinator, resume -------------------------------------------------------------
def test_a_sweep_killed_midway_resumes_without_losing_or_repeating_points(tmp_path):
    spec_path = write(tmp_path, '[sweep]\nname = "kill"\nbase = "fpn"\n[axes]\nchambers.count = [3, 4, 5, 6, 7, 8]\n'
                      '[run]\nfem = false\n')
    keys = {p.key for p in expand_points(load_sweep(spec_path))}
    db = tmp_path / "kill.sqlite"
    cmd = [sys.executable, "-m", "pnmold.cli", "sweep", str(spec_path), "--db", str(db), "--workers", "1", "--quiet"]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    import psutil

    deadline, before = time.monotonic() + 240, {}
    while time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
        if db.exists() and (before := _rows_once_created(db)):
            break
    workers = psutil.Process(proc.pid).children(recursive=True) if proc.poll() is None else []
    assert proc.poll() is None, f"the sweep ended before it could be killed: {proc.stderr.read().decode()}"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    before = read_rows(db)  # the coordinator is gone: this is what survived
    assert 1 <= len(before) < len(keys)
    # its workers notice and exit instead of computing for nobody
    gone, alive = psutil.wait_procs(workers, timeout=60)
    assert not alive

    assert main(["sweep", str(spec_path), "--db", str(db), "--workers", "1", "--quiet"]) == 0
    after = read_rows(db)
    assert set(after) == keys  # every point exactly once (key is the primary key)
    for key, row in before.items():  # finished points were not computed again
        assert (after[key]["run_id"], after[key]["started_at"]) == (row["run_id"], row["started_at"])
    con = sqlite3.connect(db)
    runs = con.execute("SELECT run_id, points_skipped, points_run, interrupted FROM runs ORDER BY run_id").fetchall()
    con.close()
    assert runs[0][2] == len(before) and runs[0][3] == 1
    assert runs[1][1:] == (len(before), len(keys) - len(before), 0)
    assert {r["run_id"] for k, r in after.items() if k not in before} == {runs[1][0]}
    # a third run finds nothing to do
    assert main(["sweep", str(spec_path), "--db", str(db), "--quiet"]) == 0
    assert read_rows(db) == after


def _rows_once_created(db: Path) -> dict[str, dict]:
    """The rows, or none while the coordinator has created the file but not yet its tables."""
    try:
        return read_rows(db)
    except sqlite3.OperationalError as err:
        if "no such table" not in str(err):
            raise
        return {}


def crashing_worker(point, base, run, build_dir=None):
    """Kills its own process on the 4-chamber point; 'builds' the others instantly."""
    if point.as_dict()["chambers.count"] == 4:
        os._exit(3)
    return {"row": {"key": point.key, "overrides": point.as_dict(), **point.as_dict(), "status": "ok",
                    "started_at": time.time(), "finished_at": time.time()}, "report": None}


def test_a_point_that_kills_its_worker_is_recorded_as_failed_and_the_rest_complete(tmp_path):
    from pnmold.mesh import gmsh_session

    with gmsh_session():  # as after an in-process FE run: gmsh had left SIGPIPE fatal (exit 141 here)
        pass
    spec = load_sweep(write(tmp_path, '[sweep]\nbase = "fpn"\n[axes]\nchambers.count = [3, 4, 5, 6]\n'))
    result = run_sweep(spec, tmp_path / "crash.sqlite", workers=2, worker=crashing_worker)
    status = {r["chambers.count"]: r["status"] for r in result.rows}
    assert status == {3: "ok", 4: "failed", 5: "ok", 6: "ok"}
    failed = next(r for r in result.rows if r["status"] == "failed")
    assert failed["error_type"] == "BrokenProcessPool" and "worker process died" in failed["error"]


def test_a_build_that_raises_is_a_failed_row_with_its_message(monkeypatch):
    import pnmold.pipeline
    from pnmold.design import load_design
    from pnmold.errors import GeometryError
    from pnmold.sweep.run import run_point
    from pnmold.sweep.spec import RunOptions

    def broken(*args, **kwargs):
        raise GeometryError("chamber 3", "boolean cut failed at x = 40.0 mm")

    monkeypatch.setattr(pnmold.pipeline, "build", broken)
    (point,) = expand_points(load_sweep(SWEEPS / "fig-s2b.toml"))[:1]
    row = run_point(point, load_design("fig-s2b-n7"), RunOptions(fem=False))["row"]
    assert row["status"] == "failed" and row["error_type"] == "GeometryError"
    assert row["error"] == "chamber 3: boolean cut failed at x = 40.0 mm" and row["error_field"] == "chamber 3"
    assert row["design_digest"] and row["chambers.count"] == 7 and row["finished_at"] >= row["started_at"]



def test_a_point_run_where_numba_threads_already_run_leaves_numba_working(tmp_path, monkeypatch):
    """run_point in a process that has run parallel numba code (the FE's kernels), as a Dask
    worker or a test process does: the point runs on one numba thread, and numba still compiles
    (setting NUMBA_NUM_THREADS under running threads made its next compile raise)."""
    import numba
    import numpy as np

    from pnmold.design import load_design
    from pnmold.sweep.run import run_point

    for key in THREAD_ENV:  # run_point sets these for the process; put them back afterwards
        monkeypatch.setenv(key, os.environ[key]) if key in os.environ else monkeypatch.delenv(key, raising=False)

    @numba.njit(parallel=True)
    def total(values):
        acc = 0.0
        for i in numba.prange(values.size):
            acc += values[i]
        return acc

    threads = numba.get_num_threads()
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)  # every thread (the suite's workers run one)
    try:
        assert numba.get_num_threads() > 1
        assert total(np.ones(64)) == 64.0  # numba's threads are running now
        spec = load_sweep(write(tmp_path, SMALL))
        point = next(p for p in expand_points(spec) if p.as_dict()["chambers.height_mm"] == 1.0)
        row = run_point(point, load_design("fpn"), spec.run)["row"]
        assert row["status"] == "refused" and row["worker_threads"]["numba"] == 1
        assert numba.get_num_threads() == 1
        assert numba.njit(lambda x: x + 1)(1) == 2  # a fresh compile
    finally:
        numba.set_num_threads(threads)


def _report(full_bend_kpa, failed=()):
    steps = [{"pressure_kpa": p, "max_principal_stretch": 1.0 + p / 100} for p in (0.0, 40.0, 80.0, 95.0)]
    checks = [{"id": c, "passed": False} for c in failed] + [{"id": "mesh.watertight.actuator", "passed": True}]
    pours = [{"part": "top_layer", "volume_ml": 5.0, "mass_g": 5.65, "part_a_g": 5.85, "part_b_g": 0.65},
             {"part": "bottom_layer", "volume_ml": 2.0, "mass_g": 2.26, "part_a_g": 2.34, "part_b_g": 0.26}]
    return {"checks": checks, "pours": pours, "timings_s": {"cad": 1.0},
            "fem": {"full_bend_pressure_kpa": full_bend_kpa, "reason": None, "steps": steps},
            "parts": {"mold_interior": {"volume_mm3": 9000.0}, "actuator": {"volume_mm3": 8000.0}}}


@pytest.mark.parametrize(("limit", "bend", "stretch", "top"), [(None, 95.0, 1.95, 95.0), (90.0, None, 1.8, 80.0)],
                         ids=["no-limit", "limit-below-full-bend"])
def test_summarize_reads_the_report_and_cuts_the_curve_at_the_pressure_limit(limit, bend, stretch, top):
    from pnmold.design import load_design
    from pnmold.sweep.run import summarize
    from pnmold.sweep.spec import RunOptions

    design = load_design("fpn")
    row = summarize(_report(95.0), design, RunOptions(max_pressure_kpa=limit))
    assert row["status"] == "ok" and row["full_bend_pressure_kpa"] == bend
    assert row["max_principal_stretch"] == pytest.approx(stretch) and row["fem_max_pressure_kpa"] == top
    if limit is not None:
        assert "run.max_pressure_kpa = 90 kPa" in row["reason"] and "95" in row["reason"]
    plate = (design.length_mm + 6) * (design.width_mm + 6) * 3
    assert row["cavity_volume_ml"] == pytest.approx((9000.0 - plate) / 1000, abs=1e-5)
    assert (row["elastomer_ml"], row["part_a_g"]) == (7.0, 8.19)
    failed = summarize(_report(None, ["fit.void.top"]), design, RunOptions())
    assert failed["status"] == "check_failed" and failed["failed_checks"] == ["fit.void.top"]
    partial = _report(None)
    partial["fem"].update(stop="failed", reason="pressure stage failed at 95 kPa (last converged)")
    fe_failed = summarize(partial, design, RunOptions())  # the parts stand; the row says the FE failed
    assert fe_failed["status"] == "failed" and fe_failed["error_type"] == "SolveError"
    assert fe_failed["error"] == fe_failed["reason"] and fe_failed["fem_max_pressure_kpa"] == 95.0


# -- with the quick FE ------------------------------------------------------------------------
@pytest.mark.slow
def test_a_sweep_with_fem_stores_the_full_bend_pressure_or_why_not(tmp_path):
    path = write(tmp_path, '[sweep]\nname = "fe"\nbase = "fig-s2c-w2"\n[axes]\nchambers.inside_wall_mm = [0.8]\n'
                 '[run]\nfem = true\nwall_mm = 3.5\nmax_mm = 7.0\nmax_pressure_kpa = 100\n')
    db = tmp_path / "fe.sqlite"
    assert main(["sweep", str(path), "--db", str(db), "--workers", "1", "--quiet"]) == 0
    (row,) = read_rows(db).values()
    assert row["status"] == "ok" and row["fem"] == 1 and row["mesh_wall_mm"] == 3.5
    assert row["full_bend_pressure_kpa"] is not None or row["reason"]
    if row["full_bend_pressure_kpa"] is not None:
        assert 0 < row["full_bend_pressure_kpa"] <= 100
    assert 0 < row["fem_max_pressure_kpa"] <= 100 and row["max_principal_stretch"] > 1.0
    assert json.loads(row["worker_threads"]).get("numba") == 1  # numba loaded after the env was set
    assert "fem_solve" in json.loads(row["timings_s"])
    assert db.with_suffix(".png").stat().st_size > 1000  # one axis with FE: the figure


def test_one_coordinator_per_database_and_no_lock_file_left(tmp_path):
    from pnmold.errors import UsageError
    from pnmold.sweep.store import SweepStore

    db = tmp_path / "s.sqlite"
    with SweepStore(db):
        assert (tmp_path / "s.sqlite.lock").is_file()
        with pytest.raises(UsageError, match="s.sqlite: another pnmold sweep"):
            SweepStore(db)
    assert not (tmp_path / "s.sqlite.lock").exists()
    with SweepStore(db):  # free again
        pass
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.endswith(".lock")) == []


# -- optional parts: Dask only with --scheduler; portable lock and memory figures ---------------
def test_a_local_sweep_runs_where_dask_is_not_installed(tmp_path):
    """Without the ``cluster`` extra: dask and distributed cannot be imported, and a local sweep
    (the test's instant worker in a spawned process) still records its rows."""
    spec_path = write(tmp_path, '[sweep]\nname = "nodask"\nbase = "fpn"\n[axes]\nchambers.count = [3, 5]\n')
    code = f"""
import sys
sys.modules["dask"] = sys.modules["distributed"] = None  # import dask -> ImportError
from pnmold.sweep import load_sweep, run_sweep
from tests.test_sweep import crashing_worker
result = run_sweep(load_sweep({str(spec_path)!r}), {str(tmp_path / "n.sqlite")!r}, workers=1, worker=crashing_worker)
print(sorted(r["status"] for r in result.rows))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().splitlines()[-1] == "['ok', 'ok']"


def test_a_scheduler_without_dask_is_bad_usage_naming_the_extra(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)
    spec = write(tmp_path, SMALL)
    assert main(["sweep", str(spec), "--db", str(tmp_path / "s.sqlite"), "--scheduler", "tcp://127.0.0.1:1",
                 "--quiet"]) == 2
    assert "pip install 'pnmold[cluster]'" in capsys.readouterr().err


def test_the_workers_peak_memory_is_read_in_megabytes():
    import psutil

    from pnmold.sweep.run import max_rss_mb

    peak = max_rss_mb()
    assert psutil.Process().memory_info().rss / 2**20 * 0.9 <= peak < 100_000
