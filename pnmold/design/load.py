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

_TYPES = {"int": int, "float": float, "str": str}


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


def _apply(design: Design, table: dict[str, Any], origin: str) -> Design:
    for section, values in table.items():
        if section not in SECTIONS:
            valid = ", ".join(SECTIONS)
            raise DesignError(section, f"unknown section in {origin}; valid sections: {valid}")
        if not isinstance(values, dict):
            raise DesignError(section, f"must be a table [{section}] in {origin}")
        changes = {k: coerce_value(f"{section}.{k}", field_type(f"{section}.{k}"), v) for k, v in values.items()}
        design = design.replace(section, **changes)
    return design


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
    design = _apply(Design(), table, str(path))
    for text in overrides:
        section, key, value = parse_override(text)
        design = _apply(design, {section: {key: value}}, "--set")
    validate(design)
    return design


def as_dict(design: Design) -> dict[str, dict[str, Any]]:
    return {name: dataclasses.asdict(getattr(design, name)) for name in SECTIONS}


def to_toml(design: Design) -> str:
    """Every field of the resolved design as TOML, with each field's source as a comment."""
    lines = [f"# pnmold resolved design {design.name!r}, digest {digest(design)}"]
    for name, cls in SECTIONS.items():
        lines.append(f"\n[{name}]")
        section = getattr(design, name)
        for f in dataclasses.fields(cls):
            value = getattr(section, f.name)
            text = json.dumps(value) if isinstance(value, str) else repr(value)
            source = f.metadata.get("source", "")
            lines.append(f"{f.name} = {text}" + (f"  # {source}" if source and source != "-" else ""))
    return "\n".join(lines) + "\n"


def digest(design: Design) -> str:
    """Short content hash of every field: keys outputs and caches."""
    blob = json.dumps(as_dict(design), sort_keys=True).encode()
    return hashlib.sha256(blob).hexdigest()[:16]
