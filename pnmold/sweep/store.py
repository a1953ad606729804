"""Sweep results in SQLite: one row per finished point, written by the coordinating process
only, each row committed as soon as it arrives (WAL), so killing the coordinator loses at
most the points in flight. A lock file keeps a second coordinator off the same database.

Tables: ``points`` (the results; each axis field is a column named ``section.key``),
``reports`` (each point's full ``report.json``), ``runs`` (one row per invocation: when,
where, how many points it computed).
"""

from __future__ import annotations

import csv
import io
import json
import os
import sqlite3
import time
from pathlib import Path
from typing import Any

from filelock import FileLock, Timeout

from pnmold.errors import UsageError
from pnmold.fsutil import write_text

STATUSES = ("ok", "refused", "failed", "check_failed")

#: the fixed columns of ``points``, in order (axis columns go after ``overrides``)
COLUMNS: tuple[tuple[str, str], ...] = (
    ("key", "TEXT PRIMARY KEY"), ("sweep", "TEXT"), ("run_id", "INTEGER"), ("status", "TEXT NOT NULL"),
    ("base", "TEXT"), ("base_digest", "TEXT"), ("overrides", "TEXT"),
    ("design_name", "TEXT"), ("design_digest", "TEXT"),
    ("checks_failed", "INTEGER"), ("failed_checks", "TEXT"), ("checks_skipped", "INTEGER"),
    ("full_bend_pressure_kpa", "REAL"), ("reason", "TEXT"), ("fem_max_pressure_kpa", "REAL"),
    ("max_principal_stretch", "REAL"), ("cavity_volume_ml", "REAL"), ("actuator_volume_ml", "REAL"),
    ("pour_top_ml", "REAL"), ("pour_bottom_ml", "REAL"), ("elastomer_ml", "REAL"), ("elastomer_g", "REAL"),
    ("part_a_g", "REAL"), ("part_b_g", "REAL"), ("pours", "TEXT"),
    ("fem", "INTEGER"), ("mesh_wall_mm", "REAL"), ("mesh_max_mm", "REAL"), ("pressure_limit_kpa", "REAL"),
    ("timings_s", "TEXT"), ("time_s", "REAL"), ("cpu_s", "REAL"),
    ("error_field", "TEXT"), ("error_type", "TEXT"), ("error", "TEXT"),
    ("started_at", "REAL"), ("finished_at", "REAL"), ("worker", "TEXT"), ("worker_max_rss_mb", "REAL"),
    ("worker_threads", "TEXT"), ("design_toml", "TEXT"),
)
_RUN_COLUMNS = ("run_id INTEGER PRIMARY KEY AUTOINCREMENT, sweep TEXT, started_at REAL, finished_at REAL, "
                "scheduler TEXT, workers INTEGER, points_total INTEGER, points_skipped INTEGER, "
                "points_run INTEGER DEFAULT 0, interrupted INTEGER DEFAULT 1, pnmold_version TEXT, host TEXT")


def default_db(sweep_name: str) -> Path:
    return Path("out") / "sweeps" / f"{sweep_name}.sqlite"


def _q(name: str) -> str:
    """A quoted SQL identifier (axis columns have dots in their names)."""
    return '"' + name.replace('"', '""') + '"'


class SweepStore:
    """The results database of a sweep; use as a context manager (holds the lock)."""

    def __init__(self, path: str | os.PathLike, fields: tuple[str, ...] = ()):
        self.path = Path(path)
        self.fields = tuple(fields)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock_path = self.path.with_name(self.path.name + ".lock")
        self._lock = self._take_lock()
        existed = self.path.is_file() and self.path.stat().st_size > 0
        try:
            self.con = sqlite3.connect(self.path, timeout=30)
            if existed:
                self._check_ours()
            self.con.execute("PRAGMA journal_mode=WAL")
            self.con.execute("PRAGMA synchronous=FULL")
            self._create()
        except sqlite3.DatabaseError as err:
            self.close()
            raise UsageError(f"{self.path}: not a sweep database ({err})") from err

    def _check_ours(self) -> None:
        """Refuse a database pnmold did not write (before anything is written to it)."""
        tables = {row[0] for row in self.con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        if not {"points", "runs", "reports"} <= tables:
            self.close()
            raise UsageError(f"{self.path}: an SQLite database pnmold did not write (tables: "
                             f"{', '.join(sorted(tables)) or 'none'}); give --db a new file's name")

    def __enter__(self) -> SweepStore:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _take_lock(self) -> FileLock:
        """The lock file, held (``filelock``: ``flock`` on Unix, ``LockFileEx`` on Windows), or
        UsageError when another coordinator holds it. A finished sweep removes the file while it
        holds it; a lock taken meanwhile on the removed file is dropped by filelock (link count
        0) and taken again on the new file within the half second allowed."""
        lock = FileLock(self._lock_path, timeout=0.5)
        try:
            lock.acquire()
        except Timeout as err:
            raise UsageError(f"{self.path}: another pnmold sweep is writing to this database") from err
        return lock

    def close(self) -> None:
        if getattr(self, "con", None) is not None:
            self.con.close()
            self.con = None
        if self._lock.is_locked:
            if os.name == "posix":  # still held: no one else owns this file (Windows removes it on release)
                self._lock_path.unlink(missing_ok=True)
            self._lock.release()

    def _create(self) -> None:
        with self.con:
            head = [f"{_q(n)} {t}" for n, t in COLUMNS]
            at = [n for n, _ in COLUMNS].index("overrides") + 1
            cols = ", ".join(head[:at] + [_q(f) for f in self.fields] + head[at:])
            self.con.execute(f"CREATE TABLE IF NOT EXISTS points ({cols})")
            self.con.execute("CREATE TABLE IF NOT EXISTS reports (key TEXT PRIMARY KEY, report_json TEXT)")
            self.con.execute(f"CREATE TABLE IF NOT EXISTS runs ({_RUN_COLUMNS})")
            have = self.columns()
            for name, kind in (*COLUMNS, *((f, "") for f in self.fields)):  # columns added since: new
                if name not in have:  # axes of an edited sweep file, or of a newer pnmold
                    self.con.execute(f"ALTER TABLE points ADD COLUMN {_q(name)} {kind}")

    def columns(self) -> list[str]:
        return [row[1] for row in self.con.execute("PRAGMA table_info(points)")]

    def finished_keys(self) -> set[str]:
        """Keys of every point with a final status (ok, refused, failed, check_failed)."""
        marks = ",".join("?" * len(STATUSES))
        return {k for (k,) in self.con.execute(f"SELECT key FROM points WHERE status IN ({marks})", STATUSES)}

    def start_run(self, sweep: str, scheduler: str, workers: int, total: int, skipped: int) -> int:
        import socket

        from pnmold.version import __version__

        with self.con:
            cur = self.con.execute(
                "INSERT INTO runs (sweep, started_at, scheduler, workers, points_total, points_skipped, "
                "pnmold_version, host) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (sweep, time.time(), scheduler, workers, total, skipped, __version__, socket.gethostname()))
        return int(cur.lastrowid)

    def add(self, run_id: int, row: dict[str, Any], report: dict[str, Any] | None = None) -> None:
        """Insert one finished point and commit. A point already there is an error: it
        would mean a finished point was computed twice."""
        if row.get("status") not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}, got {row.get('status')!r}")
        known = set(self.columns())
        data = {k: _cell(v) for k, v in {**row, "run_id": run_id}.items() if k in known}
        names = ", ".join(_q(k) for k in data)
        with self.con:
            self.con.execute(f"INSERT INTO points ({names}) VALUES ({', '.join('?' * len(data))})",
                             tuple(data.values()))
            if report is not None:
                self.con.execute("INSERT OR REPLACE INTO reports VALUES (?, ?)", (row["key"], json.dumps(report)))
            self.con.execute("UPDATE runs SET points_run = points_run + 1 WHERE run_id = ?", (run_id,))

    def finish_run(self, run_id: int, interrupted: bool = False) -> None:
        with self.con:
            self.con.execute("UPDATE runs SET finished_at = ?, interrupted = ? WHERE run_id = ?",
                             (time.time(), int(interrupted), run_id))

    def rows(self, keys: list[str] | None = None) -> list[dict[str, Any]]:
        """Rows as dicts (all, or those of ``keys`` in that order)."""
        self.con.row_factory = sqlite3.Row
        try:
            found = {r["key"]: dict(r) for r in self.con.execute("SELECT * FROM points ORDER BY finished_at")}
        finally:
            self.con.row_factory = None
        return list(found.values()) if keys is None else [found[k] for k in keys if k in found]

    def runs(self) -> list[dict[str, Any]]:
        self.con.row_factory = sqlite3.Row
        try:
            return [dict(r) for r in self.con.execute("SELECT * FROM runs ORDER BY run_id")]
        finally:
            self.con.row_factory = None

    def export_csv(self, path: str | os.PathLike | None = None) -> Path:
        """The ``points`` table as CSV beside the database (temporary name, then rename)."""
        path = Path(path) if path is not None else self.path.with_suffix(".csv")
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        cur = self.con.execute("SELECT * FROM points ORDER BY finished_at")
        writer.writerow([d[0] for d in cur.description])
        writer.writerows(cur)
        return write_text(path, buf.getvalue())


def _cell(value: Any) -> Any:
    """SQLite holds numbers and text: lists and dicts go in as JSON, booleans as 0/1."""
    if isinstance(value, dict | list | tuple):
        return json.dumps(value)
    if isinstance(value, bool):
        return int(value)
    return value
