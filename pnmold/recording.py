"""Lab recordings in the CSV format of CONTRACTS.md §4, version 1: read and write.

A recording is UTF-8 CSV: optional ``# key: value`` metadata lines, one header row of
column names that carry their units, then numbers (``phase`` is text). Unknown metadata
keys and extra columns are kept and ignored. A malformed file is refused with a
:class:`~pnmold.errors.RecordingError` naming the file, line and column.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pnmold.conventions import ORIENTATIONS, RECORDING_KINDS
from pnmold.errors import RecordingError
from pnmold.fsutil import write_text

VERSION = "1"
#: kind -> (required columns, optional columns) (CONTRACTS.md §4)
COLUMNS = {
    "bending": (("pressure_kpa", "tip_x_mm", "tip_z_mm"), ("bend_angle_deg", "cycle", "phase", "time_s")),
    "pv": (("volume_ml", "pressure_kpa"), ("cycle", "phase", "time_s")),
    "force": (("pressure_kpa", "force_n"), ("cycle", "phase")),
    "step": (("time_s", "supply_kpa", "pressure_kpa"),
             ("flow_slpm", "bend_angle_deg", "tip_x_mm", "tip_z_mm", "pressure_far_kpa", "volume_ml")),
}
PHASES = ("inflate", "deflate")
#: quantity -> the one unit pnmold reads it in (checked on column names)
UNITS = {"pressure": "kpa", "supply": "kpa", "tip_x": "mm", "tip_z": "mm", "volume": "ml", "force": "n",
         "time": "s", "bend_angle": "deg", "flow": "slpm"}
_TEXT_COLUMNS = ("phase",)


@dataclass(frozen=True, eq=False)
class Recording:
    """One recording: its kind, metadata and columns (numpy arrays; ``phase`` as text)."""

    path: str
    kind: str
    columns: dict[str, np.ndarray]
    metadata: dict[str, str] = field(default_factory=dict)

    @property
    def orientation(self) -> str:
        return self.metadata.get("orientation", "chambers_up")

    @property
    def design(self) -> str | None:
        return self.metadata.get("design")

    @property
    def rate_kpa_per_s(self) -> float | None:
        rate = self.metadata.get("rate_kpa_per_s")
        return float(rate) if rate is not None else None

    def __len__(self) -> int:
        return len(next(iter(self.columns.values())))

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]


def _unit_problem(name: str) -> str | None:
    """Why the column's unit is wrong for pnmold, or None."""
    for quantity, unit in UNITS.items():
        if name.startswith(quantity + "_") and name.count("_") == quantity.count("_") + 1:
            got = name[len(quantity) + 1:]
            if got != unit:
                return f"{quantity} must be in {unit} (column {quantity}_{unit}), not {got}"
    return None


def _metadata(lines: list[str], path: str) -> tuple[dict[str, str], int]:
    meta, n = {}, 0
    for n, line in enumerate(lines, 1):
        if not line.startswith("#"):
            return meta, n
        body = line[1:].strip()
        if not body:
            continue
        if ":" not in body:
            raise RecordingError(path, n, f"metadata must read '# key: value', got {line.strip()!r}")
        key, value = (s.strip() for s in body.split(":", 1))
        meta[key.lower()] = value.split()[0] if value else ""
    return meta, n + 1


def _check_metadata(meta: dict[str, str], path: str, columns: list[str]) -> str:
    version = meta.get("pnmold-recording", VERSION)
    if version != VERSION:
        raise RecordingError(path, 1, f"pnmold-recording version {version!r}; this pnmold reads version {VERSION}")
    kind = meta.get("kind")
    if kind is None:
        fits = [k for k, (req, _) in COLUMNS.items() if set(req) <= set(columns)]
        if len(fits) != 1:
            raise RecordingError(path, 1, "no '# kind: ...' line and the columns do not tell the kind "
                                 f"(kinds: {', '.join(RECORDING_KINDS)})")
        kind = fits[0]
    if kind not in RECORDING_KINDS:
        raise RecordingError(path, 1, f"unknown kind {kind!r}; kinds: {', '.join(RECORDING_KINDS)}")
    orientation = meta.get("orientation")
    if orientation is not None and orientation not in ORIENTATIONS:
        raise RecordingError(path, 1, f"unknown orientation {orientation!r}; one of {', '.join(ORIENTATIONS)}")
    rate = meta.get("rate_kpa_per_s")
    if rate is not None:
        try:
            ok = float(rate) > 0 and math.isfinite(float(rate))
        except ValueError:
            ok = False
        if not ok:
            raise RecordingError(path, 1, f"rate_kpa_per_s must be a positive number, got {rate!r}")
    return kind


def _column(header: list[str], name: str) -> str:
    """A column as an error names it: its position counted from 1 and its name."""
    return f"{header.index(name) + 1} ({name})"


def finite_number(text: str, path: str, line: int, column: str | int | None = None) -> float:
    """A data file's cell as a finite number; RecordingError names the file, line and column."""
    try:
        value = float(text)
    except ValueError:
        raise RecordingError(path, line, f"not a number: {text!r}", column=column) from None
    if not math.isfinite(value):
        raise RecordingError(path, line, f"not a finite number: {text!r}", column=column)
    return value


def _cell(text: str, path: str, line: int, name: str, column: str) -> float | str:
    if name in _TEXT_COLUMNS:
        value = text.strip().lower()
        if value not in PHASES:
            raise RecordingError(path, line, f"phase must be inflate or deflate, got {text!r}", column=column)
        return value
    value = finite_number(text, path, line, column)
    if name == "cycle" and (value < 1 or not value.is_integer()):
        raise RecordingError(path, line, f"cycle counts 1, 2, 3...: got {text!r}", column=column)
    return value


def read_recording(path: str | Path) -> Recording:
    """Read and validate a recording file; refuse a malformed one with file, line, column."""
    p = str(path)
    try:
        raw = Path(path).read_bytes()
    except OSError as err:
        raise RecordingError(p, None, f"cannot read: {err.strerror or err}") from err
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        line = raw[:err.start].count(b"\n") + 1
        raise RecordingError(p, line, "not UTF-8 text") from err
    lines = text.splitlines()
    meta, header_line = _metadata(lines, p)
    if header_line > len(lines) or not lines[header_line - 1].strip():
        raise RecordingError(p, header_line, "no header row of column names")
    rows = list(csv.reader(io.StringIO("\n".join(lines[header_line - 1:]))))
    header = [h.strip().lower() for h in rows[0]]
    for i, name in enumerate(header, 1):
        if not name:
            raise RecordingError(p, header_line, "empty column name", column=i)
        if name in header[:i - 1]:
            raise RecordingError(p, header_line, f"column appears twice (first as column {header.index(name) + 1})",
                                 column=f"{i} ({name})")
        problem = _unit_problem(name)
        if problem:
            raise RecordingError(p, header_line, problem, column=f"{i} ({name})")
    kind = _check_metadata(meta, p, header)
    required, optional = COLUMNS[kind]
    missing = [c for c in required if c not in header]
    if missing:
        raise RecordingError(p, header_line, f"a {kind} recording needs column(s) {', '.join(missing)}",
                             column=missing[0])
    used = [c for c in header if c in required + optional]
    data: dict[str, list] = {c: [] for c in used}
    for offset, row in enumerate(rows[1:], 1):
        line = header_line + offset
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            where = _column(header, header[len(row)]) if len(row) < len(header) else len(header) + 1
            raise RecordingError(p, line, f"{len(row)} fields, the header has {len(header)}", column=where)
        for name, cell in zip(header, row, strict=True):
            if name in data:
                data[name].append(_cell(cell, p, line, name, _column(header, name)))
    n = len(data[required[0]])
    if n < 2:
        raise RecordingError(p, header_line + 1, f"needs at least 2 rows of data, found {n}")
    columns = {c: np.array(v, dtype=object if c in _TEXT_COLUMNS else float) for c, v in data.items()}
    if "cycle" in columns:
        columns["cycle"] = columns["cycle"].astype(int)
    if "time_s" in columns:
        back = np.flatnonzero(np.diff(columns["time_s"]) < 0)
        if back.size:
            raise RecordingError(p, _data_line(rows, header_line, int(back[0]) + 1), "time goes backwards",
                                 column=_column(header, "time_s"))
    return Recording(p, kind, columns, meta)


def _data_line(rows: list[list[str]], header_line: int, index: int) -> int:
    """File line of the ``index``-th (0-based) non-blank data row."""
    seen = -1
    for offset, row in enumerate(rows[1:], 1):
        if row and any(c.strip() for c in row):
            seen += 1
            if seen == index:
                return header_line + offset
    return header_line + len(rows) - 1


def format_recording(kind: str, columns: dict[str, np.ndarray], metadata: dict[str, str] | None = None) -> str:
    """The CSV text of a recording (metadata first, ``# pnmold-recording: 1``)."""
    if kind not in RECORDING_KINDS:
        raise RecordingError("<new recording>", None, f"unknown kind {kind!r}")
    meta = {"pnmold-recording": VERSION, "kind": kind, **(metadata or {})}
    out = [f"# {k}: {v}" for k, v in meta.items()]
    names = list(columns)
    out.append(",".join(names))
    for i in range(len(columns[names[0]])):
        cells = []
        for name in names:
            v = columns[name][i]
            cells.append(str(v) if isinstance(v, str) else (str(int(v)) if name == "cycle" else f"{float(v):.6g}"))
        out.append(",".join(cells))
    return "\n".join(out) + "\n"


def write_recording(path: str | Path, kind: str, columns: dict[str, np.ndarray],
                    metadata: dict[str, str] | None = None) -> Path:
    """Write a recording atomically."""
    return write_text(path, format_recording(kind, columns, metadata))
