"""Designs from TOML: templates are partial overrides of the defaults.

Unknown sections and keys are refused with the list of valid ones; values are checked
for type; ``--set section.key=value`` overrides are applied last. The resolved design
(every field) can be written back as TOML and has a short digest that keys outputs.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import tomllib
from pathlib import Path
from typing import Any

from pnmold.design.model import SECTIONS, Design
from pnmold.design.rules import validate
from pnmold.errors import DesignError

_TYPES = {"int": int, "float": float, "str": str, "bool": bool}


def templates_dir() -> Path:
    """Folder of the design templates.

    ``PNMOLD_TEMPLATES`` when set; else the source checkout's top-level ``templates/`` when
    pnmold runs from one (beside ``pyproject.toml``); else the copy a wheel ships in the
    package, ``pnmold/templates/`` (``setup.py`` puts it there).
    """
    env = os.environ.get("PNMOLD_TEMPLATES")
    if env:
        return Path(env)
    package = Path(__file__).resolve().parents[1]
    checkout = package.parent
    if (checkout / "pyproject.toml").is_file() and (checkout / "templates").is_dir():
        return checkout / "templates"
    return package / "templates"


def list_templates() -> dict[str, str]:
    """Template name -> its one-line description."""
    out = {}
    for path in sorted(templates_dir().glob("*.toml")):
        out[path.stem] = load_design(path).design.description
    return out


def field_type(field: str) -> type:
    """The type (int, float, str) of design field ``section.key``; DesignError names an unknown one."""
    section, _, key = field.partition(".")
    if section not in SECTIONS:
        raise DesignError(field, f"unknown section; valid sections: {', '.join(SECTIONS)}")
    for f in dataclasses.fields(SECTIONS[section]):
        if f.name == key:
            return _TYPES[f.type] if isinstance(f.type, str) else f.type
    valid = ", ".join(f.name for f in dataclasses.fields(SECTIONS[section]))
    raise DesignError(field, f"unknown key; valid keys of [{section}]: {valid}")


def coerce_value(where: str, kind: type, value: Any) -> Any:
    """``value`` as ``kind`` (int, float, str or bool), the one coercion of every file pnmold reads
    (designs, overrides, sweep files): ints stay ints, numbers become finite floats, no bools."""
    if kind is str or kind is bool:
        if not isinstance(value, kind):
            raise DesignError(where, f"must be {'a string' if kind is str else 'true or false'}, got {value!r}")
        return value
    if isinstance(value, bool):
        raise DesignError(where, f"must be a number, got {value!r}")
    if kind is int:
        if isinstance(value, float) and value.is_integer():
            raise DesignError(where, f"must be an integer (write {int(value)}), got {value!r}")
        if not isinstance(value, int):
            raise DesignError(where, f"must be an integer, got {value!r}")
        return value
    if not isinstance(value, int | float):
        raise DesignError(where, f"must be a number, got {value!r}")
    if not math.isfinite(value):
        raise DesignError(where, f"must be finite, got {value!r}")
    return float(value)


#: the constants a library material fills in when a design names it
_RUBBER_KEYS = ("c10_mpa", "c20_mpa", "c30_mpa", "density_g_per_ml", "mix_ratio_a_to_b")


def _apply(design: Design, table: dict[str, Any], origin: str) -> Design:
    """``design`` with the values of a TOML ``table``, each recorded as set by ``origin``."""
    origins = dict(design.origins)
    for section, values in table.items():
        if section not in SECTIONS:
            valid = ", ".join(SECTIONS)
            raise DesignError(section, f"unknown section in {origin}; valid sections: {valid}")
        if not isinstance(values, dict):
            raise DesignError(section, f"must be a table [{section}] in {origin}")
        changes = {k: coerce_value(f"{section}.{k}", field_type(f"{section}.{k}"), v) for k, v in values.items()}
        design = design.replace(section, **changes)
        if "name" in changes and section in ("material", "layer_material"):  # another rubber: the constants
            for key in _RUBBER_KEYS:  # set before belonged to the one it replaces
                origins.pop(f"{section}.{key}", None)
        origins.update({f"{section}.{k}": origin for k in changes})
    return dataclasses.replace(design, origins=tuple(origins.items()))


def _with_library_rubber(design: Design, section: str) -> Design:
    """A named rubber's constants: a library material's fill in what the design did not set (a
    value set that differs is refused: it is another rubber, and deserves its own name); a rubber
    not in the library must have every constant set."""
    from pnmold.materials.library import find_material, list_materials

    m, origins = getattr(design, section), dict(design.origins)
    if not m.name:
        return design
    lib = find_material(m.name)
    if lib is None:
        missing = [k for k in _RUBBER_KEYS if f"{section}.{k}" not in origins]
        known = ", ".join(x.name for x in list_materials())
        if missing:
            raise DesignError(f"{section}.{missing[0]}", f"{m.name!r} is not in the material library ({known}): "
                              f"set its own {', '.join(f'{section}.{k}' for k in missing)}, or name a library rubber")
        return design
    changes = {"name": lib.name}
    for key in _RUBBER_KEYS:
        value, where = getattr(lib, key), f"{section}.{key}"
        if where not in origins:
            changes[key] = value
            origins[where] = f"{lib.name}, pnmold library: {lib.source(key)}"
        elif not math.isclose(getattr(m, key), value, rel_tol=1e-6, abs_tol=1e-12):
            raise DesignError(where, f"is {getattr(m, key):g}, but {lib.name}'s is {value:g} (pnmold's material "
                              f"library); to use other constants, give the rubber a name of its own (e.g. "
                              f"'{lib.name} (lab fit)')")
    return dataclasses.replace(design.replace(section, **changes), origins=tuple(origins.items()))


def parse_override(text: str) -> tuple[str, str, Any]:
    """Parse ``section.key=value``; the value is read as TOML, else as a bare string."""
    if "=" not in text or "." not in text.split("=", 1)[0]:
        raise DesignError(text, "an override must look like section.key=value")
    lhs, raw = text.split("=", 1)
    section, key = (s.strip() for s in lhs.split(".", 1))
    if section not in SECTIONS:
        raise DesignError(lhs, f"unknown section; valid sections: {', '.join(SECTIONS)}")
    kind = field_type(f"{section}.{key}")
    raw = raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    if kind is str and not isinstance(value, str):
        value = raw
    return section, key, value


def override_table(overrides: list[str] | tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """The ``--set`` overrides as one table, applied together so that their order does not matter (a rubber's
    constants set beside its name belong to it, before or after); a key set twice to different values is
    refused as ambiguous."""
    table: dict[str, dict[str, Any]] = {}
    for text in overrides:
        section, key, value = parse_override(text)
        given = table.setdefault(section, {})
        if key in given and given[key] != value:
            raise DesignError(f"{section}.{key}", f"set twice by --set ({given[key]!r} and {value!r}): give it once")
        given[key] = value
    return table


def resolve(ref: str | os.PathLike) -> Path:
    """A template name or a path to a TOML file -> the file."""
    path = Path(ref)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise DesignError("design", f"no design file {path}")
        return path
    candidate = templates_dir() / f"{ref}.toml"
    if not candidate.is_file():
        names = ", ".join(p.stem for p in sorted(templates_dir().glob("*.toml")))
        raise DesignError("design", f"no template named {ref!r}; templates: {names}")
    return candidate


def load_design(ref: str | os.PathLike = "fpn", overrides: list[str] | tuple[str, ...] = ()) -> Design:
    """Load a template or TOML file over the defaults, apply overrides, validate."""
    path = resolve(ref)
    try:
        table = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise DesignError("design", f"{path}: not valid TOML: {err}") from err
    except UnicodeDecodeError as err:
        raise DesignError("design", f"{path}: not UTF-8 text") from err
    table.setdefault("design", {}).setdefault("name", path.stem)
    origin = f"template {path.stem}" if path.parent == templates_dir() else f"set by the user in {path.name}"
    design = _apply(Design(), table, origin)
    if overrides:
        design = _apply(design, override_table(overrides), "set by the user (--set)")
    for section in ("material", "layer_material"):
        design = _with_library_rubber(design, section)
    validate(design)
    return design


def as_dict(design: Design) -> dict[str, dict[str, Any]]:
    return {name: dataclasses.asdict(getattr(design, name)) for name in SECTIONS}


def to_toml(design: Design) -> str:
    """Every field of the resolved design as TOML, with each field's source as a comment."""
    lines = [f"# pnmold resolved design {design.name!r}, digest {digest(design)}"]
    origins = dict(design.origins)
    for name, cls in SECTIONS.items():
        lines.append(f"\n[{name}]")
        section = getattr(design, name)
        for f in dataclasses.fields(cls):
            value = getattr(section, f.name)
            text = json.dumps(value) if isinstance(value, str | bool) else repr(value)
            source = origins.get(f"{name}.{f.name}") or f.metadata.get("source", "")
            lines.append(f"{f.name} = {text}" + (f"  # {source}" if source and source != "-" else ""))
    return "\n".join(lines) + "\n"


#: fields added after the first designs were keyed: they enter the digest only when a design sets them
#: off their default, so the designs that do not use them keep their digests (and their caches)
_OPTIONAL_SINCE_V1 = {"chambers.tip_wall_mm": 0.0, "clamp.length_mm": 0.0, "paper.present": True, "paper.depth_mm": 0.0,
                      "passive_side.present": False, "layer_material.name": "",
                      "layer_material.c10_mpa": 0.0, "layer_material.c20_mpa": 0.0, "layer_material.c30_mpa": 0.0,
                      "layer_material.density_g_per_ml": 0.0, "layer_material.mix_ratio_a_to_b": 0.0}


def digest(design: Design) -> str:
    """Short content hash of every field: keys outputs and caches."""
    fields = as_dict(design)
    for key, default in _OPTIONAL_SINCE_V1.items():
        section, _, name = key.partition(".")
        if fields[section].get(name) == default:
            del fields[section][name]
    blob = json.dumps({k: v for k, v in fields.items() if v}, sort_keys=True).encode()
    return hashlib.sha256(blob).hexdigest()[:16]
