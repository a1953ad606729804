"""The pressure at each frame: one per frame from the command line, or a logger's CSV matched to the
frames' times.

A pressure log is a CSV file (``#`` lines before the header skipped; ``,``, ``;`` or tab) with a time
column in seconds (``time_s``, or ``t_s``) and a pressure column whose name ends in a pressure unit
pnmold reads (``pressure_kpa``, ``p_psi``, ``pressure_bar``, ...; the first one that is not a supply);
a ``supply_<unit>`` column, when there is one, is the supply a step recording keeps. A frame's
pressure is the log's, linearly interpolated at the frame's time plus ``--offset-s``; a frame outside
the log's time span gets none (and is skipped, saying so).
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pnmold.errors import RecordingError, UsageError
from pnmold.recording.units import PRESSURE_UNITS


@dataclass(frozen=True, eq=False)
class PressureLog:
    """A logger's samples: time (s), pressure (kPa) and the supply (kPa, or None)."""

    path: str
    time_s: np.ndarray
    pressure_kpa: np.ndarray
    supply_kpa: np.ndarray | None

    def at(self, t: float) -> tuple[float | None, float | None]:
        """(pressure, supply) at time ``t``; (None, None) outside the log."""
        if not (self.time_s[0] <= t <= self.time_s[-1]):
            return None, None
        p = float(np.interp(t, self.time_s, self.pressure_kpa))
        s = float(np.interp(t, self.time_s, self.supply_kpa)) if self.supply_kpa is not None else None
        return p, s


def parse_pressures(text: str) -> list[float]:
    """``--pressures-kpa P1,P2,...`` as numbers; UsageError naming the option."""
    values = [_number(cell) for cell in text.split(",")]
    bad = [i for i, v in enumerate(values) if v is None]
    if bad:
        cell = text.split(",")[bad[0]].strip()
        raise UsageError(f"--pressures-kpa: value {bad[0] + 1}, {cell!r}, is not a finite number")
    return values


def _number(cell: str) -> float | None:
    try:
        value = float(cell)
    except ValueError:
        return None
    return value if np.isfinite(value) else None


def _unit_of(name: str, prefix: tuple[str, ...]) -> float | None:
    for p in prefix:
        if name.startswith(p + "_") and name[len(p) + 1:] in PRESSURE_UNITS:
            return PRESSURE_UNITS[name[len(p) + 1:]]
    return None


def read_pressure_log(path: str | Path) -> PressureLog:
    """A pressure log; RecordingError naming the file, line and column when it does not read."""
    path = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except OSError as err:
        raise UsageError(f"--pressure-log: {path}: {err.strerror or err}") from err
    except UnicodeDecodeError as err:
        raise RecordingError(path, None, "not UTF-8 text") from err
    lines = [(i, line) for i, line in enumerate(text.splitlines(), 1) if line.strip() and not line.startswith("#")]
    if len(lines) < 3:
        raise RecordingError(path, None, "a pressure log needs a header row and at least 2 rows")
    delim = ";" if all(";" in line for _, line in lines[-5:]) else "\t" if all("\t" in line for _, line in
                                                                              lines[-5:]) else ","
    rows = list(csv.reader(io.StringIO("\n".join(line for _, line in lines)), delimiter=delim))
    header = [c.strip().lower() for c in rows[0]]
    t_col = next((i for i, c in enumerate(header) if c in ("time_s", "t_s")), None)
    p_col = next((i for i, c in enumerate(header) if _unit_of(c, ("pressure", "p")) is not None), None)
    s_col = next((i for i, c in enumerate(header) if _unit_of(c, ("supply",)) is not None), None)
    if t_col is None or p_col is None:
        missing = "time_s" if t_col is None else "a pressure column (pressure_kpa, pressure_psi, ...)"
        raise RecordingError(path, lines[0][0], f"no {missing} in the header: {', '.join(header)}")
    data = np.full((len(rows) - 1, 3), np.nan)
    for r, row in enumerate(rows[1:]):
        line = lines[r + 1][0]
        for j, col in enumerate((t_col, p_col, s_col)):
            if col is None:
                continue
            try:
                data[r, j] = float(row[col].replace(",", ".") if delim != "," else row[col])
            except (ValueError, IndexError):
                cell = row[col] if col < len(row) else ""
                raise RecordingError(path, line, f"not a number: {cell!r}", f"{col + 1} ({header[col]})") from None
    t = data[:, 0]
    if np.any(np.diff(t) < 0):
        bad = int(np.argmax(np.diff(t) < 0)) + 2
        raise RecordingError(path, lines[bad][0], "time goes backwards", f"{t_col + 1} ({header[t_col]})")
    p = data[:, 1] * _unit_of(header[p_col], ("pressure", "p"))
    s = data[:, 2] * _unit_of(header[s_col], ("supply",)) if s_col is not None else None
    return PressureLog(path, t, p, s)
