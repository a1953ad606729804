"""Sweep files (TOML) -> a frozen :class:`SweepSpec`; every mistake is refused with a
:class:`SweepError` naming the file and the field.

A sweep file has three tables::

    [sweep]                         # name (default: the file's stem), base, sampling, n, seed
    base = "fig-s2a-h5"             # template name, or a design file relative to this file
    sampling = "grid"               # grid (cartesian product) | random (n points, seed)

    [axes]                          # any design field, section.key
    chambers.height_mm = [4.0, 6.0, 8.0]                 # a list
    chambers.count = { start = 5, stop = 13, step = 2 }  # a range, stop included
    chambers.inside_wall_mm = { start = 1, stop = 3, num = 5 }
    chambers.length_mm = { start = 5, stop = 8 }         # continuous: random sampling only

    [run]                           # fem, wall_mm, max_mm, max_pressure_kpa, keep_builds

Values are checked for the field's type here (a wrong type is a mistake in the file);
whether a point is a valid design is decided per point by the design rules.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pnmold.design import SECTIONS, coerce_value, digest, field_type, load_design, templates_dir
from pnmold.errors import DesignError, SweepError

SAMPLINGS = ("grid", "random")
RANGE_KEYS = ("start", "stop", "step", "num")
MAX_AXIS_VALUES = 10_000
MAX_POINTS = 100_000
_TABLES = {"sweep": ("name", "base", "description", "sampling", "n", "seed"),
           "axes": (),
           "run": ("fem", "wall_mm", "max_mm", "max_pressure_kpa", "keep_builds")}


@dataclass(frozen=True)
class Axis:
    """One varied design field: discrete ``values``, or a continuous range
    [``low``, ``high``] (uniform draws; random sampling only)."""

    field: str
    kind: str  # "int" | "float" | "str": the design field's type
    values: tuple[Any, ...] = ()
    low: float | None = None
    high: float | None = None

    @property
    def continuous(self) -> bool:
        return not self.values


@dataclass(frozen=True)
class RunOptions:
    """How each point is built: quick FE on/off, its mesh (mm; None = the build's default
    :class:`pnmold.mesh.MeshSize`), the pressure limit (kPa; None = the quick FE's own)."""

    fem: bool = True
    wall_mm: float | None = None
    max_mm: float | None = None
    max_pressure_kpa: float | None = None
    keep_builds: bool = False

    def key_part(self) -> dict[str, Any]:
        """The options that change a point's results (they key the point with its inputs)."""
        if not self.fem:
            return {"fem": False}
        return {"fem": True, "wall_mm": self.wall_mm, "max_mm": self.max_mm,
                "max_pressure_kpa": self.max_pressure_kpa}


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: the base design (file and digest), the axes, the sampling."""

    name: str
    path: Path
    base: Path
    base_digest: str
    axes: tuple[Axis, ...]
    sampling: str = "grid"
    n: int | None = None
    seed: int = 0
    description: str = ""
    run: RunOptions = RunOptions()

    @property
    def fields(self) -> tuple[str, ...]:
        return tuple(a.field for a in self.axes)


def load_sweep(path: str | os.PathLike) -> SweepSpec:
    """Read and validate a sweep file; raise :class:`SweepError` naming the field."""
    path = Path(path)
    if not path.is_file():
        raise SweepError(path, "sweep", "no such sweep file")
    try:
        table = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise SweepError(path, "sweep", f"not valid TOML: {err}") from err
    _known(path, "", table, tuple(_TABLES))
    for name, keys in _TABLES.items():
        if not isinstance(table.get(name, {}), dict):
            raise SweepError(path, name, f"must be a table [{name}]")
        if keys:
            _known(path, f"{name}.", table.get(name, {}), keys)
    head, run = table.get("sweep", {}), table.get("run", {})
    name = _get(path, head, "sweep.name", str, path.stem)
    if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", name):
        raise SweepError(path, "sweep.name", f"must be letters, digits, '-', '_' or '.', got {name!r}")
    base = _base(path, head)
    sampling = _get(path, head, "sweep.sampling", str, "grid")
    if sampling not in SAMPLINGS:
        raise SweepError(path, "sweep.sampling", f"must be one of {', '.join(SAMPLINGS)}, got {sampling!r}")
    n, seed = _sampling_size(path, head, sampling)
    axes = tuple(_axis(path, field, value, sampling) for field, value in _axis_entries(path, table.get("axes", {})))
    repeated = sorted({f for f in (a.field for a in axes) if [a.field for a in axes].count(f) > 1})
    if repeated:
        raise SweepError(path, f"axes.{repeated[0]}", "named twice")
    if not axes:
        raise SweepError(path, "axes", "no axis: name at least one design field, e.g. chambers.height_mm = [5, 7]")
    if sampling == "grid" and math.prod(len(a.values) for a in axes) > MAX_POINTS:
        raise SweepError(path, "axes", f"the grid has more than {MAX_POINTS} points")
    try:
        base_digest = digest(load_design(base))
    except DesignError as err:
        raise SweepError(path, "sweep.base", f"{base} is not a valid design: {err}") from err
    return SweepSpec(name, path, base, base_digest, axes, sampling, n, seed,
                     _get(path, head, "sweep.description", str, ""), _run_options(path, run))


def _known(path: Path, prefix: str, table: dict, valid: tuple[str, ...]) -> None:
    for key in table:
        if key not in valid:
            raise SweepError(path, f"{prefix}{key}", f"unknown key; valid: {', '.join(valid)}")


def _get(path: Path, table: dict, field: str, kind: type, default: Any) -> Any:
    value = table.get(field.split(".", 1)[1], default)
    return _value(path, field, kind.__name__, value)


def _base(path: Path, head: dict) -> Path:
    """The base design: relative to the sweep file, else a template name or path."""
    ref = _get(path, head, "sweep.base", str, "")
    if not ref:
        raise SweepError(path, "sweep.base", "missing: name a template (e.g. fpn) or a design file")
    for candidate in (path.parent / ref, templates_dir() / ref, templates_dir() / f"{ref}.toml"):
        if candidate.is_file():
            return candidate.resolve()
    names = ", ".join(p.stem for p in sorted(templates_dir().glob("*.toml")))
    raise SweepError(path, "sweep.base", f"no design file or template named {ref!r} (looked beside the "
                     f"sweep file and in {templates_dir()}); templates: {names}")


def _sampling_size(path: Path, head: dict, sampling: str) -> tuple[int | None, int]:
    if sampling == "grid":
        for key in ("n", "seed"):
            if key in head:
                raise SweepError(path, f"sweep.{key}", "only for sampling = \"random\"")
        return None, 0
    if "n" not in head:
        raise SweepError(path, "sweep.n", "random sampling needs the number of points n")
    n, seed = _get(path, head, "sweep.n", int, 0), _get(path, head, "sweep.seed", int, 0)
    if not 1 <= n <= MAX_POINTS:
        raise SweepError(path, "sweep.n", f"must be between 1 and {MAX_POINTS}, got {n}")
    return n, seed


def _axis_entries(path: Path, table: dict) -> list[tuple[str, Any]]:
    """``"section.key" = ...`` and ``section.key = ...`` (a nested TOML table) alike."""
    out = []
    for key, value in table.items():
        if "." in key:
            out.append((key, value))
        elif key in SECTIONS and isinstance(value, dict) and not set(value) & set(RANGE_KEYS):
            out.extend((f"{key}.{sub}", v) for sub, v in value.items())
        else:
            raise SweepError(path, f"axes.{key}", "an axis names a design field as section.key, "
                             f"e.g. chambers.height_mm; sections: {', '.join(SECTIONS)}")
    return out


def field_kind(path: Path, field: str) -> str:
    """The type name (int, float, str) of design field ``section.key``."""
    try:
        return field_type(field).__name__
    except DesignError as err:
        raise SweepError(path, f"axes.{field}", err.message) from None


def _value(path: Path, where: str, kind: str, value: Any) -> Any:
    """``value`` as the field's type (the designs' coercion, the error naming the sweep file)."""
    try:
        return coerce_value(where, {"int": int, "float": float, "str": str, "bool": bool}[kind], value)
    except DesignError as err:
        raise SweepError(path, where, err.message) from None


def _axis(path: Path, field: str, spec: Any, sampling: str) -> Axis:
    kind, where = field_kind(path, field), f"axes.{field}"
    if isinstance(spec, list):
        if not spec:
            raise SweepError(path, where, "empty axis: give at least one value")
        values = tuple(_value(path, where, kind, v) for v in spec)
        if len(set(values)) != len(values):
            raise SweepError(path, where, f"repeated values in {list(spec)}")
        return Axis(field, kind, values)
    if isinstance(spec, dict):
        return _range(path, field, kind, spec, sampling)
    raise SweepError(path, where, f"must be a list of values or a range {{start, stop, step | num}}, got {spec!r}")


def _range(path: Path, field: str, kind: str, spec: dict, sampling: str) -> Axis:
    where = f"axes.{field}"
    _known(path, f"{where}.", spec, RANGE_KEYS)
    if kind == "str":
        raise SweepError(path, where, "a range needs a numeric field; list the values instead")
    for key in ("start", "stop"):
        if key not in spec:
            raise SweepError(path, f"{where}.{key}", "a range needs start and stop")
    start, stop = (_value(path, f"{where}.{k}", kind, spec[k]) for k in ("start", "stop"))
    if stop < start:
        raise SweepError(path, where, f"bad range: stop ({stop}) is below start ({start})")
    if "step" in spec and "num" in spec:
        raise SweepError(path, where, "give step or num, not both")
    if "step" in spec:
        step = _value(path, f"{where}.step", kind, spec["step"])
        if step <= 0:
            raise SweepError(path, f"{where}.step", f"bad range: step must be positive, got {step}")
        count = math.floor((stop - start) / step + 1e-9) + 1
        values = [start + i * step for i in range(min(count, MAX_AXIS_VALUES + 1))]
    elif "num" in spec:
        num = _value(path, f"{where}.num", "int", spec["num"])
        if num < 1 or (num == 1 and stop != start):
            raise SweepError(path, f"{where}.num", f"bad range: num must be at least 2 (1 if start = stop), got {num}")
        values = [start + (stop - start) * i / max(num - 1, 1) for i in range(min(num, MAX_AXIS_VALUES + 1))]
        if kind == "int" and any(abs(v - round(v)) > 1e-9 for v in values):
            raise SweepError(path, f"{where}.num", f"{num} values from {start} to {stop} are not all integers")
    else:
        if sampling != "random":
            raise SweepError(path, where, "a grid needs step or num in a range (start and stop alone are "
                             "for random sampling)")
        return Axis(field, kind, (), start, stop)
    if len(values) > MAX_AXIS_VALUES:
        raise SweepError(path, where, f"bad range: more than {MAX_AXIS_VALUES} values")
    values = [int(round(v)) if kind == "int" else round(v, 10) for v in values]
    return Axis(field, kind, tuple(values))


def _run_options(path: Path, run: dict) -> RunOptions:
    fem = _get(path, run, "run.fem", bool, True)
    keep = _get(path, run, "run.keep_builds", bool, False)
    sizes = {}
    for key in ("wall_mm", "max_mm", "max_pressure_kpa"):
        if key in run:
            sizes[key] = _get(path, run, f"run.{key}", float, 0.0)
            if sizes[key] <= 0:
                raise SweepError(path, f"run.{key}", f"must be positive, got {sizes[key]}")
    if "wall_mm" in sizes and "max_mm" in sizes and sizes["max_mm"] < sizes["wall_mm"]:
        raise SweepError(path, "run.max_mm", f"{sizes['max_mm']} mm is finer than run.wall_mm = {sizes['wall_mm']} mm")
    if "max_pressure_kpa" in sizes:
        from pnmold.design_fe import QUICK_MAX_PRESSURE_KPA

        if sizes["max_pressure_kpa"] > QUICK_MAX_PRESSURE_KPA:
            raise SweepError(path, "run.max_pressure_kpa", f"{sizes['max_pressure_kpa']} kPa is above the build's "
                             f"quick FE limit ({QUICK_MAX_PRESSURE_KPA} kPa)")
    return RunOptions(fem, sizes.get("wall_mm"), sizes.get("max_mm"), sizes.get("max_pressure_kpa"), keep)
