"""Lab recordings in the CSV format of docs/recording-format.md, version 1: read and write.

A recording is UTF-8 CSV: optional ``# key: value`` metadata lines (``##`` lines are
comments), one header row of column names that carry their units, then numbers (``phase``
is text). Unknown metadata keys and extra columns are kept and ignored. Pressures and volumes
may come in any unit of :data:`PRESSURE_UNITS` and :data:`VOLUME_UNITS` (``pressure_psi``,
``supply_bar``, ``volume_ul``): they are converted once, here, to the canonical column
(``pressure_kpa``, ``volume_ml``) and :attr:`Recording.conversions` says so. A malformed file
is refused with a :class:`~pnmold.errors.RecordingError` naming the file, line and column.
The format for users: ``docs/recording-format.md``.
"""

from __future__ import annotations

import logging
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pnmold.conventions import ORIENTATIONS, QUASI_STATIC_KINDS, RECORDING_KINDS
from pnmold.errors import RecordingError
from pnmold.fsutil import write_text
from pnmold.recording.csvlayout import Layout, decode, find_layout
from pnmold.recording.measurement import KEYS as MEASUREMENT_KEYS
from pnmold.recording.measurement import Measurement, measurement_of
from pnmold.recording.metadata import conversion, metadata_number, rate_in_kpa, read_metadata
from pnmold.recording.units import ABSOLUTE_UNITS, PRESSURE_UNITS, VOLUME_UNITS

log = logging.getLogger(__name__)

VERSION = "1"
#: kind -> (required columns, optional columns) (docs/recording-format.md)
COLUMNS = {
    "bending": (("pressure_kpa", "tip_x_mm", "tip_z_mm"), ("bend_angle_deg", "cycle", "phase", "time_s")),
    "pv": (("volume_ml", "pressure_kpa"), ("cycle", "phase", "time_s")),
    "force": (("pressure_kpa", "force_n"), ("cycle", "phase")),
    "step": (("time_s", "supply_kpa", "pressure_kpa"),
             ("flow_slpm", "bend_angle_deg", "tip_x_mm", "tip_z_mm", "pressure_far_kpa", "volume_ml")),
}
#: kind -> another set of required columns that may stand for the first (a bending test that
#: measured only the bend angle, from a curvature, as many labs do)
ALTERNATIVE_COLUMNS = {"bending": ("pressure_kpa", "bend_angle_deg")}
PHASES = ("inflate", "deflate")
_TEXT_COLUMNS = ("phase",)

#: canonical unit -> the units a column may carry instead
_CONVERTIBLE = {"kpa": PRESSURE_UNITS, "ml": VOLUME_UNITS}
_CANONICAL = {c for req, opt in COLUMNS.values() for c in (*req, *opt)}
_MICRO = str.maketrans({"\u00b5": "u", "\u03bc": "u"})  # micro sign and Greek mu: uL

#: what each column holds (the actuator frame and units of docs/frame-and-units.md; pressures are gauge)
COLUMN_DOCS = {
    "pressure_kpa": "pressure at the actuator's inlet (step: the chamber at the inlet)",
    "tip_x_mm": "tip x: along the length from the clamped end (the tip: free end, bottom face, y = 0)",
    "tip_z_mm": "tip z: up from the bottom (strain-limiting) face; negative as the actuator curls",
    "bend_angle_deg": "rotation of the free end face about y, positive curling toward -z (360: fully bent)",
    "cycle": "inflation cycle, counting from 1",
    "phase": "inflate or deflate",
    "time_s": "time since the start of the test (never decreasing)",
    "volume_ml": "volume injected into the actuator since the first row (the cavity's volume change)",
    "force_n": "blocked tip force on a plane under the tip",
    "supply_kpa": "regulated supply pressure upstream of the valve (the valve opens when it rises)",
    "flow_slpm": "flow into the actuator, standard litres per minute (0 degC, 101.325 kPa)",
    "pressure_far_kpa": "pressure in the last (distal) chamber",
}

#: the metadata keys pnmold reads: key -> (kinds that read it, what it says); others are kept and ignored
METADATA_KEYS = {
    "pnmold-recording": (RECORDING_KINDS, "format version; this pnmold reads 1 (the default)"),
    "kind": (RECORDING_KINDS, "bending | pv | force | step; without it the columns must tell the kind"),
    "design": (RECORDING_KINDS, "the design tested, a template name or TOML file (for people: the command "
               "line's DESIGN wins)"),
    "orientation": (RECORDING_KINDS, "where gravity points: chambers_up (along -z of the actuator, the default) "
                    "| chambers_down (+z) | horizontal (out of the bending plane) | submerged (in water)"),
    "rate_kpa_per_s": (QUASI_STATIC_KINDS, "pressure ramp rate (> 0; also rate_psi_per_s, rate_bar_per_s, ...): "
                       "each row's time when there is no time_s column (viscoelasticity needs time); "
                       "without either the test is quasi-static"),
    "tubing_length_mm": (("step",), "tubing from the valves to the actuator (default 300 mm, assumed)"),
    "tubing_id_mm": (("step",), "tubing bore (default the design's inlet.tubing_id_mm)"),
    "valve_orifice_mm": (("step",), "effective orifice of the supply and vent valves (default 1.0 mm, assumed)"),
    "valve_sonic_conductance": (("step",), "the valves' ISO 6358 sonic conductance C in dm3/(s bar), instead "
                                "of valve_orifice_mm"),
    "valve_critical_ratio": (("step",), "the valves' ISO 6358 critical pressure ratio b in [0, 0.999) "
                             "(default 0.5)"),
    "valve_volume_ml": (("step",), "volume between the valve seat and the tubing (default 0.05 mL)"),
    "atmosphere_kpa": (("step",), "absolute ambient pressure (default 101.325 kPa)"),
    "temperature_k": (("step",), "gas temperature (default 293.15 K)"),
    "gas_law": (("step",), "isothermal (the only one the step model has; adiabatic is refused)"),
    **MEASUREMENT_KEYS,
}


@dataclass(frozen=True, eq=False)
class Recording:
    """One recording: its kind, metadata and columns (numpy arrays; ``phase`` as text).

    ``conversions``: canonical column (or metadata key) -> how it was converted at reading,
    e.g. ``{"pressure_kpa": "from pressure_psi (x 6.894757)"}``; empty when none was."""

    path: str
    kind: str
    columns: dict[str, np.ndarray]
    metadata: dict[str, str] = field(default_factory=dict)
    conversions: dict[str, str] = field(default_factory=dict)
    measurement: Measurement = field(default_factory=Measurement)
    #: how the table was read (:class:`~pnmold.recording.csvlayout.Layout`), e.g. "semicolon-separated,
    #: decimal comma"
    layout: str = "comma-separated"

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


def _resolve_unit(name: str) -> tuple[str, float] | str | None:
    """A column name as pnmold reads it: (canonical name, factor to its unit), or why its unit
    is refused, or None for a column pnmold does not read (kept and ignored)."""
    name = name.translate(_MICRO)
    if name in _CANONICAL:
        return name, 1.0
    stem, _, unit = name.rpartition("_")
    wanted = [c for c in _CANONICAL if c.rpartition("_")[0] == stem]
    if not stem or not wanted:
        return None
    canonical = wanted[0]
    table = _CONVERTIBLE.get(canonical.rpartition("_")[2])
    if table is None:
        return f"{stem} must be in {canonical.rpartition('_')[2]} (column {canonical}), not {unit}"
    if unit in table:
        return canonical, table[unit]
    if unit in ABSOLUTE_UNITS:
        return f"{unit} is an absolute pressure; pnmold reads gauge pressure (above the atmosphere)"
    return f"{stem} must be in one of {', '.join(table)} (e.g. column {canonical}), not {unit}"


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
    metadata_number(meta, "rate_kpa_per_s", path)
    return kind


def _column(header: list[str], name: str) -> str:
    """A column as an error names it: its position counted from 1 and its name."""
    return f"{header.index(name) + 1} ({name})"


#: a cell of a comma-separated file with decimal points as a finite number (:meth:`Layout.number`)
finite_number = Layout().number


def _cell(text: str, layout: Layout, path: str, line: int, name: str, column: str) -> float | str:
    if name in _TEXT_COLUMNS:
        value = text.strip().lower()
        if value not in PHASES:
            raise RecordingError(path, line, f"phase must be inflate or deflate, got {text!r}", column=column)
        return value
    value = layout.number(text, path, line, column)
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
    lines = decode(raw, p).splitlines()
    meta, header_line = read_metadata(lines, p)
    if header_line > len(lines) or not lines[header_line - 1].strip():
        raise RecordingError(p, header_line, "no header row of column names")
    layout = find_layout(lines[header_line - 1:])
    rows = list(layout.split(lines[header_line - 1:]))
    meta = {k: layout.plain(v) if layout.is_number(v) else v for k, v in meta.items()}
    header, names, factors = _header(rows[0], p, header_line)
    conversions = rate_in_kpa(meta, p)
    kind = _check_metadata(meta, p, [n for n in names if n])
    required, optional = COLUMNS[kind]
    missing = [c for c in required if c not in names]
    alternative = ALTERNATIVE_COLUMNS.get(kind)
    if missing and alternative is not None and set(alternative) <= set(names):
        required, missing = alternative, []
    if missing:
        instead = f" (or {', '.join(alternative)})" if alternative else ""
        why = layout.fields_hint(lines[header_line - 1], len(header), len(required))
        raise RecordingError(p, header_line, f"a {kind} recording needs column(s) {', '.join(missing)}{instead}"
                             f"{why}", column=missing[0])
    used = {i: n for i, n in enumerate(names) if n in required + optional}
    data: dict[str, list] = {n: [] for n in used.values()}
    for offset, row in enumerate(rows[1:], 1):
        line = header_line + offset
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            where = f"{len(row) + 1} ({header[len(row)]})" if len(row) < len(header) else len(header) + 1
            why = layout.fields_hint(lines[line - 1] if line <= len(lines) else "", len(row), len(header))
            raise RecordingError(p, line, f"{len(row)} fields, the header has {len(header)}{why}", column=where)
        for i, name in used.items():
            data[name].append(_cell(row[i], layout, p, line, name, f"{i + 1} ({header[i]})"))
    n = len(data[required[0]])
    if n < 2:
        raise RecordingError(p, header_line + 1, f"needs at least 2 rows of data, found {n}")
    columns = {c: np.array(v, dtype=object if c in _TEXT_COLUMNS else float) for c, v in data.items()}
    for i, name in used.items():
        if factors[i] != 1.0 or header[i] != name:
            columns[name] = columns[name] * factors[i]
            conversions[name] = conversion(rows[0][i].strip(), factors[i])
    if "cycle" in columns:
        columns["cycle"] = columns["cycle"].astype(int)
    if "time_s" in columns:
        back = np.flatnonzero(np.diff(columns["time_s"]) < 0)
        if back.size:
            raise RecordingError(p, _data_line(rows, header_line, int(back[0]) + 1), "time goes backwards",
                                 column=_column(header, "time_s"))
    for name, how in conversions.items():
        log.info("%s: %s %s", p, name, how)
    if layout != Layout():
        log.info("%s: read as %s", p, layout)
    return Recording(p, kind, columns, meta, conversions, measurement_of(meta, p), str(layout))


def _header(cells: list[str], path: str, line: int) -> tuple[list[str], list[str | None], list[float]]:
    """The header's names (lower case), the canonical name each gives (None: not read) and the
    factor to its canonical unit; refuses an empty, repeated or unreadable name."""
    header = [h.strip().lower() for h in cells]
    names: list[str | None] = []
    factors: list[float] = []
    for i, name in enumerate(header, 1):
        if not name:
            raise RecordingError(path, line, "empty column name", column=i)
        if name in header[:i - 1]:
            raise RecordingError(path, line, f"column appears twice (first as column {header.index(name) + 1})",
                                 column=f"{i} ({name})")
        unit = _resolve_unit(name)
        if isinstance(unit, str):
            raise RecordingError(path, line, unit, column=f"{i} ({name})")
        canonical, factor = unit or (None, 1.0)
        if canonical is not None and canonical in names:
            first = names.index(canonical)
            raise RecordingError(path, line, f"gives {canonical} again (first as column {first + 1} "
                                 f"({header[first]})); keep one", column=f"{i} ({name})")
        names.append(canonical)
        factors.append(factor)
    return header, names, factors


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


def recording_template(kind: str) -> str:
    """An empty recording of ``kind``: ``##`` comments that explain every metadata key and
    column, the metadata lines, and the header row (required columns, then the optional
    ones). :func:`read_recording` accepts it once two or more rows are filled in."""
    if kind not in RECORDING_KINDS:
        raise RecordingError("<template>", None, f"unknown kind {kind!r}; kinds: {', '.join(RECORDING_KINDS)}")
    required, optional = COLUMNS[kind]

    def comment(text: str) -> list[str]:
        return textwrap.wrap(text, 96, initial_indent="## ", subsequent_indent="##     ")

    out = comment(f"pnmold recording, kind {kind}: the CSV format of `pnmold docs recording-format`. '##' lines are "
                  "comments, '# key: value' lines are metadata. After the header row: one row per sample, "
                  "comma-separated numbers, at least 2 rows.")
    for key, (kinds, what) in METADATA_KEYS.items():
        if kind in kinds:
            out += comment(f"{key}: {what}")
    out += [f"# pnmold-recording: {VERSION}", f"# kind: {kind}", "# orientation: chambers_up",
            "## Optional keys above go here as '# key: value' lines (e.g. '# design: fpn')."]
    out += comment(f"Required columns: {', '.join(required)}. Optional columns (delete those you did not "
                   f"record): {', '.join(optional)}.")
    out += [line for c in (*required, *optional) for line in comment(f"{c}: {COLUMN_DOCS[c]}")]
    out += comment("Units are in the names: pressures in " + ", ".join(PRESSURE_UNITS) + " (e.g. pressure_psi), "
                   "volumes in " + ", ".join(VOLUME_UNITS) + " (e.g. volume_ul); pnmold converts them to kPa and "
                   "mL as it reads them.")
    out.append(",".join((*required, *optional)))
    return "\n".join(out) + "\n"


def write_template(path: str | Path, kind: str) -> Path:
    """Write :func:`recording_template` atomically."""
    return write_text(path, recording_template(kind))
