"""Read a uniaxial tensile (or compression) test: pnmold's CSV or a lab's file as published.

The layout is found, not assumed: the delimiter and decimal mark by
:mod:`pnmold.recording.csvlayout`, the reader recordings use (``,``, ``;`` or tab; with ``;`` or
tab a decimal comma is read too), ``#`` comment lines or a block of ``key;value`` metadata rows
before the header, the header row (the row above the first row of numbers, or two rows above it
when that row holds only units, as some testing software writes them). Columns are
found by name (:mod:`pnmold.materials.columns`: ``eng_strain``, ``Engineering Strain``,
``Engineering Stress (MPa)``, ``True Stress (MPa)``, ``Load (N)``, ``Extension (mm)``, ...)
or named by :class:`TensileColumns`; units come from the header.

Stress is engineering (nominal) stress in MPa. A true stress column is converted with
``engineering = true / (1 + strain)`` and a true strain with ``strain = exp(true) - 1``
(incompressible, uniaxial). Without a stress column, force and extension give
``strain = extension / gauge length`` and ``stress = force / area`` with the specimen's size
from :class:`Specimen`, else from the file's metadata rows (``Specimen Length (mm)``,
``Specimen Width (mm)``, ``Specimen Thickness (mm)``, ``Specimen Cross-section (cm^2)``).
What was read, and how, is in :attr:`TensileData.read`. A strain column read as a ratio whose
values say percent (past :data:`MAX_RATIO_STRAIN`) is refused, naming ``--strain-unit %``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pnmold.errors import RecordingError, UsageError
from pnmold.materials.columns import DIMENSION, UNITS, factor, is_unit, normal_unit, role_of, split_name
from pnmold.recording.csvlayout import DELIMITERS, Layout, decode, find_layout

#: the fewest points a fit takes (and a tensile file must hold)
MIN_POINTS = 4
#: the largest engineering strain a strain column read as a ratio may reach: 20 (2000 %). Assumed, from
#: twice the elongation at break of the stretchiest rubber in pnmold's library (Ecoflex 00-30: 900 %,
#: Smooth-On's Ecoflex Series technical bulletin) and above the longest test pnmold ships (the Soft
#: Robotics Materials Database's Ecoflex 00-30, pulled to 1607 %). Past it the column is percent.
MAX_RATIO_STRAIN = 20.0
_LARGEST_TRUE = 700.0  # exp(700) is near the largest float: past it, a true strain stays finite (no overflow)
log = logging.getLogger(__name__)
_EXPECTED = "eng_strain and eng_stress_mpa (or e.g. 'Engineering Strain', 'Engineering Stress (MPa)')"


@dataclass(frozen=True)
class TensileData:
    """A uniaxial test in engineering strain and stress (MPa), in recorded order.

    ``mode`` is "tension" or "compression" per point; compression points (negative strain)
    are only read from files with a ``mode`` column. ``read``: quantity -> where it came from
    and how it was converted (for people and the fit's JSON).
    """

    strain: np.ndarray
    stress_mpa: np.ndarray
    mode: tuple[str, ...]
    path: str
    lines: tuple[int, ...]
    read: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class TensileColumns:
    """Columns named by the user (a header name, matched without case, spaces and units, or a
    1-based position) and units for columns whose header has none. ``stress_kind``:
    "engineering" or "true" (default: what the column's name says)."""

    strain: str | None = None
    stress: str | None = None
    stress_kind: str | None = None
    force: str | None = None
    extension: str | None = None
    strain_unit: str | None = None
    stress_unit: str | None = None
    force_unit: str | None = None
    extension_unit: str | None = None


@dataclass(frozen=True)
class Specimen:
    """The specimen's size for force + extension files: gauge length and the cross-section
    (``area_mm2``, or ``width_mm`` x ``thickness_mm``); None: from the file's metadata."""

    gauge_length_mm: float | None = None
    area_mm2: float | None = None
    width_mm: float | None = None
    thickness_mm: float | None = None


@dataclass(frozen=True)
class _Column:
    index: int
    label: str  # as the header spells it
    role: str
    factor: float
    unit: str


def _text(path: str) -> str:
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise UsageError(f"{path}: no such tensile test file") from None
    except IsADirectoryError:
        raise UsageError(f"{path}: is a folder, not a tensile test file") from None
    return decode(raw, path)


def _numeric(cells: list[str], layout: Layout) -> bool:
    """A row of data: at least two numbers, and numbers in at least half of its filled cells."""
    filled = [c.strip() for c in cells if c.strip()]
    numbers = sum(layout.is_number(c) for c in filled)
    return numbers >= 2 and 2 * numbers >= len(filled)


def _rows(text: str) -> tuple[list[tuple[int, list[str]]], Layout]:
    """The non-blank rows (line, cells) after any leading ``#`` comments, and the layout."""
    lines = text.splitlines()
    layout = find_layout(lines)
    rows, leading = [], True
    for n, cells in enumerate(layout.split(lines), start=1):
        if not cells or not "".join(cells).strip():
            continue
        if leading and cells[0].lstrip().startswith("#"):
            continue
        leading = False
        rows.append((n, cells))
    return rows, layout


def _header(rows: list[tuple[int, list[str]]], path: str, n_lines: int, layout: Layout) -> tuple[int, int | None]:
    """Index in ``rows`` of the header row and of a units row under it (or None): the header is
    the row above the first row of numbers that another row with numbers follows."""
    if not rows:
        if n_lines == 0:
            raise RecordingError(path, 1, f"empty file; expected a header row with {_EXPECTED}")
        raise RecordingError(path, n_lines, f"no header row after the comment lines; expected {_EXPECTED}")
    def starts_data(i: int) -> bool:  # a row of numbers with a number in the next row (not a metadata row)
        return _numeric(rows[i][1], layout) and (i + 1 == len(rows) or any(
            layout.is_number(c.strip()) for c in rows[i + 1][1] if c.strip()))

    first = next((i for i in range(len(rows)) if starts_data(i)), None)
    if first == 0:
        raise RecordingError(path, rows[0][0], f"no header row: expected column names {_EXPECTED}, got numbers")
    if first is None:
        raise RecordingError(path, rows[-1][0], f"no rows of numbers under a header of {_EXPECTED}")
    above = [c for c in rows[first - 1][1] if c.strip()]
    if first >= 2 and above and all(is_unit(c) for c in above):
        return first - 2, first - 1
    return first - 1, None


def _find(cells: list[str], wanted: str, path: str, line: int) -> int:
    """The position of the column the user named (a 1-based number, or a name)."""
    if wanted.strip().isdigit() and 1 <= int(wanted) <= len(cells):
        return int(wanted) - 1
    key = split_name(wanted)[0]
    hits = [i for i, c in enumerate(cells) if c.strip().lower() == wanted.strip().lower() or split_name(c)[0] == key]
    if len(hits) != 1:
        found = ", ".join(f"{i + 1} {c.strip()!r}" for i, c in enumerate(cells))
        raise RecordingError(path, line, f"{'no' if not hits else 'more than one'} column {wanted!r}; columns: {found}",
                             column=wanted)
    return hits[0]


def _columns(cells: list[str], units: list[str] | None, chosen: TensileColumns, path: str,
             line: int) -> dict[str, _Column]:
    """role -> the column that gives it (strain, stress, force, extension, mode): the user's
    choices, else the header's names; an engineering column before a true one."""
    picked = {role: _find(cells, getattr(chosen, role), path, line)
              for role in ("strain", "stress", "force", "extension") if getattr(chosen, role) is not None}
    by_role: dict[str, list[int]] = {}
    for i, cell in enumerate(cells):
        role = role_of(split_name(cell)[0])
        if role and i not in picked.values():
            by_role.setdefault(role, []).append(i)
    for role, hits in by_role.items():
        if len(hits) > 1 and _plain(role) not in picked:
            twice = ", ".join(f"{i + 1} ({cells[i].strip()})" for i in hits)
            raise RecordingError(path, line, f"{len(hits)} {role.replace('_', ' ')} columns ({twice}); choose one "
                                 f"with --{_plain(role)}-column", column=cells[hits[1]].strip())
    out = {}
    for role in ("strain", "stress", "force", "extension", "mode"):
        true = f"true_{role}"
        if role in picked:
            i = picked[role]
            named = role_of(split_name(cells[i])[0])
        elif role in by_role:
            i, named = by_role[role][0], role
        elif true in by_role:
            i, named = by_role[true][0], true
        else:
            continue
        kind = chosen.stress_kind if role == "stress" else None
        actual = {"true": true, "engineering": role}.get(kind, true if named == true else role)
        unit = getattr(chosen, f"{role}_unit", None)
        if unit is None and units is not None and units[i].strip():
            unit = units[i].strip().strip("()[]")
        out[role] = _column(i, cells[i].strip(), actual, unit, path, line)
    return out


def _plain(role: str) -> str:
    return role.removeprefix("true_")


def _column(i: int, label: str, role: str, unit: str | None, path: str, line: int) -> _Column:
    if role == "mode":
        return _Column(i, label, role, 1.0, "")
    shown = unit if unit is not None else split_name(label, as_written=True)[1]
    unit = normal_unit(shown) if shown is not None else None
    f = factor(role, unit)
    if f is None:
        name, accepted = _plain(role), ", ".join(u for u in UNITS[DIMENSION[role]] if u)
        why = (f"unit {unit!r} is not one of {accepted}" if unit else
               f"has no unit: name it like '{name.title()} (MPa)' or give --{name}-unit ({accepted})")
        raise RecordingError(path, line, f"{name} column {label!r}: {why}", column=label)
    return _Column(i, label, role, f, shown or "ratio")


#: metadata row name -> (specimen field, dimension of its unit)
_SIZES = {**dict.fromkeys(("specimenlength", "gaugelength", "length", "initiallength"), ("gauge_length_mm", "length")),
          **dict.fromkeys(("specimenwidth", "width"), ("width_mm", "length")),
          **dict.fromkeys(("specimenthickness", "thickness"), ("thickness_mm", "length")),
          **dict.fromkeys(("specimencrosssection", "crosssection", "crosssectionalarea", "area"), ("area_mm2", "area"))}


def _sizes(rows: list[tuple[int, list[str]]], layout: Layout) -> dict[str, tuple[float, str]]:
    """Specimen sizes in the metadata rows above the header: field -> (value, where it was)."""
    found = {}
    for line, cells in rows:
        name, unit = split_name(cells[0])
        target = _SIZES.get(name)
        values = [c.strip() for c in cells[1:] if c.strip()]
        if target and unit in UNITS[target[1]] and values and layout.is_number(values[0]):
            value = float(layout.plain(values[0])) * UNITS[target[1]][unit]
            if value > 0 and math.isfinite(value):
                found[target[0]] = (value, f"line {line} {cells[0].strip()!r}")
    return found


def _size(given: Specimen, meta: dict[str, tuple[float, str]], what: str) -> tuple[float, str] | None:
    """The gauge length or the cross-section: the command line's, else the file's metadata."""
    if what == "gauge_length_mm":
        if given.gauge_length_mm is not None:
            return given.gauge_length_mm, "--gauge-length-mm"
        return meta.get("gauge_length_mm")
    if given.area_mm2 is not None:
        return given.area_mm2, "--area-mm2"
    if given.width_mm is not None and given.thickness_mm is not None:
        return given.width_mm * given.thickness_mm, "--width-mm x --thickness-mm"
    if "area_mm2" in meta:
        return meta["area_mm2"]
    if "width_mm" in meta and "thickness_mm" in meta:
        (w, at_w), (t, at_t) = meta["width_mm"], meta["thickness_mm"]
        return w * t, f"{at_w} x {at_t}"
    return None


def read_tensile(path: str | Path, columns: TensileColumns | None = None,
                 specimen: Specimen | None = None) -> TensileData:
    """Read a tensile test (module docstring): pnmold's CSV (``eng_strain``, ``eng_stress_mpa``,
    ``#`` comments, an optional ``mode`` column of tension/compression) or a lab's file as
    published. Without a ``mode`` column the test is a tension test and a negative strain is
    refused. A damaged file is refused with a RecordingError naming the file, line and column.
    """
    path, chosen, given = str(path), columns or TensileColumns(), specimen or Specimen()
    if chosen.stress_kind not in (None, "engineering", "true"):
        raise UsageError(f"stress kind must be engineering or true, got {chosen.stress_kind!r}")
    for key in ("gauge_length_mm", "area_mm2", "width_mm", "thickness_mm"):
        value = getattr(given, key)
        if value is not None and not (value > 0 and math.isfinite(value)):
            raise UsageError(f"--{key.replace('_mm2', '-mm2').replace('_mm', '-mm').replace('_', '-')} must be a "
                             f"positive number, got {value}")
    text = _text(path)
    rows, layout = _rows(text)
    h, u = _header(rows, path, len(text.splitlines()) if text.strip() else 0, layout)
    header_line, cells = rows[h]
    cols = _columns(cells, rows[u][1] if u is not None else None, chosen, path, header_line)
    meta = _sizes(rows[:h], layout)
    strain_col, stress_col = cols.get("strain") or cols.get("extension"), cols.get("stress") or cols.get("force")
    gauge = _size(given, meta, "gauge_length_mm") if strain_col and strain_col.role == "extension" else None
    area = _size(given, meta, "area_mm2") if stress_col and stress_col.role == "force" else None
    _check_found(cells, strain_col, stress_col, gauge, area, path, header_line)
    mode = cols.get("mode")
    used = [c for c in (strain_col, stress_col, mode) if c is not None]
    need = max(c.index for c in used)
    strain, stress, modes, where = [], [], [], []
    for line, row in rows[(u if u is not None else h) + 1:]:
        if len(row) <= need or any(c.strip() for c in row[len(cells):]):
            why = layout.fields_hint(layout.delimiter.join(row), len(row), len(cells))
            raise RecordingError(path, line, f"{len(row)} values, the header has {len(cells)}{why}",
                                 column=cells[len(row)].strip() if len(row) < len(cells) else None)
        read = _number(row, strain_col, layout, path, line)
        e = (math.expm1(min(read, _LARGEST_TRUE)) if strain_col.role == "true_strain"
             else read / gauge[0] if gauge else read)
        _check_ratio(read, e, strain_col, chosen, path, line)
        s = _number(row, stress_col, layout, path, line) / (area[0] if area else 1.0)
        kind = row[mode.index].strip().lower() if mode else "tension"
        _check_point(e, kind, mode, strain_col, path, line)
        if stress_col.role == "true_stress":
            s /= 1.0 + e
        strain.append(e)
        stress.append(s)
        modes.append(kind)
        where.append(line)
    if len(strain) < MIN_POINTS:
        raise RecordingError(path, rows[-1][0] if len(rows) > h + 1 else header_line,
                             f"only {len(strain)} data rows; a fit needs at least {MIN_POINTS}")
    read = _provenance(strain_col, stress_col, gauge, area, header_line, layout, u is not None)
    log.info("%s: %s", path, "; ".join(f"{k} {v}" for k, v in read.items()))
    return TensileData(np.array(strain), np.array(stress), tuple(modes), path, tuple(where), read)


def _number(row: list[str], col: _Column, layout: Layout, path: str, line: int) -> float:
    """A cell in the column's pnmold unit; RecordingError names the file, line and column."""
    return layout.number(row[col.index], path, line, col.label) * col.factor


def _check_found(cells, strain_col, stress_col, gauge, area, path: str, line: int) -> None:
    found = ", ".join(c.strip() for c in cells) or "nothing"
    missing = [n for n, c in (("eng_strain", strain_col), ("eng_stress_mpa", stress_col)) if c is None]
    if missing:
        raise RecordingError(path, line, f"missing column(s) {', '.join(missing)} (case-insensitive; or e.g. "
                             "'Engineering Strain', 'Engineering Stress (MPa)', 'True Stress (MPa)', or force and "
                             f"extension columns with the specimen's size); found: {found}", column=missing[0])
    if stress_col.role == "force" and area is None:
        raise RecordingError(path, line, f"missing column eng_stress_mpa: the force column {stress_col.label!r} gives "
                             "the stress with the specimen's cross-section: --area-mm2, or --width-mm and "
                             "--thickness-mm", column="eng_stress_mpa")
    if strain_col.role == "extension" and gauge is None:
        raise RecordingError(path, line, f"missing column eng_strain: the extension column {strain_col.label!r} gives "
                             "the strain with the specimen's gauge length: --gauge-length-mm", column="eng_strain")


def _check_point(e: float, kind: str, mode: _Column | None, strain_col: _Column, path: str, line: int) -> None:
    col = strain_col.label
    if kind not in ("tension", "compression"):
        raise RecordingError(path, line, f"mode must be tension or compression, got {kind!r}", column=mode.label)
    if e <= -1.0:
        raise RecordingError(path, line, f"strain {e} would compress the specimen to nothing (needs > -1)",
                             column=col)
    if kind == "tension" and e < 0:
        why = "a tension row" if mode else "a tension test (no mode column)"
        raise RecordingError(path, line, f"negative strain {e} in {why}", column=col)
    if kind == "compression" and e > 0:
        raise RecordingError(path, line, f"positive strain {e} in a compression row", column=col)


def _check_ratio(read: float, e: float, strain_col: _Column, chosen: TensileColumns, path: str, line: int) -> None:
    """Refuse a strain a column read as a ratio gives past :data:`MAX_RATIO_STRAIN` (its values
    say percent), unless the command line gave the column's unit."""
    ratio = strain_col.role != "extension" and strain_col.factor == 1.0 and chosen.strain_unit is None
    if ratio and e > MAX_RATIO_STRAIN:
        col, unit = strain_col.label, "" if strain_col.unit == "ratio" else f" ({strain_col.unit})"
        raise RecordingError(path, line, f"strain column {col!r} read as a ratio{unit} reaches {read:g} here, "
                             f"{100 * e:.6g} % engineering strain, and castable elastomers break "
                             f"well below {100 * MAX_RATIO_STRAIN:g} %: the column looks like percent; give "
                             "--strain-unit % (or --strain-unit ratio if it is a ratio)", column=col)


def _provenance(strain_col: _Column, stress_col: _Column, gauge, area, header_line: int, layout: Layout,
                units_row: bool) -> dict[str, str]:
    """What was read and how: one line each for the strain, the stress and the layout."""
    def source(c: _Column) -> str:
        return f"column {c.index + 1} {c.label!r} ({c.unit}" + (f", x {c.factor:.7g})" if c.factor != 1 else ")")

    strain = source(strain_col) + {"true_strain": ": true strain, exp(x) - 1",
                                   "extension": f" / gauge length {gauge[0]:g} mm ({gauge[1]})" if gauge else ""
                                   }.get(strain_col.role, "")
    stress = source(stress_col) + {"true_stress": ": true stress / (1 + strain) (incompressible, uniaxial)",
                                   "force": f" / area {area[0]:g} mm2 ({area[1]})" if area else ""
                                   }.get(stress_col.role, "")
    where = (f"{DELIMITERS[layout.delimiter]}-separated, header on line {header_line}"
             + (", units on the next line" if units_row else "") + (", decimal comma" if layout.decimal_comma else ""))
    return {"strain": strain, "stress_mpa": stress, "layout": where}
