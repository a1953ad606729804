"""Write the generated parts of ``docs/``: ``docs/design-fields.md`` (every design field, from the
design dataclasses' metadata) and the marked tables of ``docs/recording-format.md`` (kinds,
columns, units and metadata keys, from :mod:`pnmold.recording.format`). The prose around the marked
tables is written by hand. ``tests/test_docs.py`` fails when a committed doc differs from what
this writes; run it after changing a design field or the recording format.

    .venv/bin/python scripts/write_docs.py [--check]
"""

from __future__ import annotations

import dataclasses
import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pnmold.design.model import SECTIONS  # noqa: E402
from pnmold.fsutil import write_text  # noqa: E402
from pnmold.recording import COLUMN_DOCS, COLUMNS, METADATA_KEYS  # noqa: E402
from pnmold.recording.units import ABSOLUTE_UNITS, PRESSURE_UNITS, VOLUME_UNITS  # noqa: E402

DOCS = ROOT / "docs"
#: a field name's ending -> its unit (units live in the names)
SUFFIX_UNITS = {"_mm": "mm", "_mpa": "MPa", "_kpa": "kPa", "_g_per_ml": "g/mL", "_ml": "mL", "_deg": "deg",
                "_s": "s"}
_BLOCK = re.compile(r"(<!-- generated: (?P<name>[a-z-]+) -->\n).*?(\n<!-- end generated -->)", re.S)


def _cell(text: str) -> str:
    """Text for a Markdown table cell: pipes escaped, angle brackets as entities, one line."""
    return text.replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;").replace("\n", " ")


def _table(head: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def unit_of(name: str) -> str:
    """The unit a field's name carries, or "-"."""
    return next((unit for suffix, unit in SUFFIX_UNITS.items() if name.endswith(suffix)), "-")


def design_fields() -> str:
    """``docs/design-fields.md``: a table per section of every field's type, default, unit, doc, source."""
    out = ["# Design fields", "",
           "<!-- Written by scripts/write_docs.py from pnmold/design/model.py; do not edit by hand. -->", "",
           "Every field of a design, by section. A template or your own TOML file sets any of them",
           "(`[chambers]` then `count = 12`), and so does `--set section.key=value` on every command",
           "(`--set chambers.count=12`); fields left out keep the defaults below, which describe the",
           "supplement's fast PneuNet (fPN). An unknown section or key is refused with the valid ones.",
           "Units are in the names (`_mm`, `_mpa`, ...); `pnmold build` writes the resolved design, every",
           "field with the source of its value, to `design.toml`. *source* says where a default comes",
           "from: a paper, a datasheet, or `assumed`.", ""]
    for section, cls in SECTIONS.items():
        rows = []
        for f in dataclasses.fields(cls):
            kind = f.type if isinstance(f.type, str) else f.type.__name__
            default = json.dumps(f.default) if isinstance(f.default, str) else repr(f.default)
            rows.append([f"`{section}.{f.name}`", kind, f"`{default}`", unit_of(f.name),
                         _cell(f.metadata.get("doc", "")), _cell(f.metadata.get("source", "")) or "-"])
        out += [f"## `[{section}]`", "", _table(["field", "type", "default", "unit", "what it is", "source"], rows), ""]
    return "\n".join(out)


def recording_blocks() -> dict[str, str]:
    """The marked tables of ``docs/recording-format.md``, by marker name."""
    kinds = _table(["kind", "required columns", "optional columns"],
                   [[f"`{k}`", ", ".join(f"`{c}`" for c in req), ", ".join(f"`{c}`" for c in opt)]
                    for k, (req, opt) in COLUMNS.items()])
    columns = _table(["column", "what it holds"], [[f"`{c}`", _cell(doc)] for c, doc in COLUMN_DOCS.items()])
    units = _table(["quantity", "column endings (unit)", "converted to"], [
        ["pressure (gauge)", ", ".join(f"`_{u}` (x {f:.7g})" for u, f in PRESSURE_UNITS.items()), "kPa"],
        ["volume", ", ".join(f"`_{u}` (x {f:.7g})" for u, f in VOLUME_UNITS.items()), "mL"],
        ["absolute pressure (refused)", ", ".join(f"`_{u}`" for u in ABSOLUTE_UNITS), "-"]])
    meta = _table(["key", "kinds", "what it says"],
                  [[f"`{k}`", ", ".join(kinds), _cell(what)] for k, (kinds, what) in METADATA_KEYS.items()])
    return {"kinds": kinds, "columns": columns, "units": units, "metadata": meta}


def fill(text: str, blocks: dict[str, str]) -> str:
    """``text`` with each ``<!-- generated: NAME -->`` ... ``<!-- end generated -->`` block replaced."""
    seen = set()

    def replace(m: re.Match) -> str:
        seen.add(m.group("name"))
        return m.group(1) + blocks[m.group("name")] + m.group(3)

    out = _BLOCK.sub(replace, text)
    missing = set(blocks) - seen
    if missing:
        raise SystemExit(f"docs/recording-format.md: no generated block(s) {', '.join(sorted(missing))}")
    return out


def documents() -> dict[Path, str]:
    """Path -> the text it must have."""
    recording = DOCS / "recording-format.md"
    return {DOCS / "design-fields.md": design_fields() + "\n",
            recording: fill(recording.read_text(encoding="utf-8"), recording_blocks())}


def main(argv: list[str]) -> int:
    stale = [p for p, text in documents().items() if not p.is_file() or p.read_text(encoding="utf-8") != text]
    if "--check" in argv:
        for p in stale:
            print(f"{p.relative_to(ROOT)} differs from what scripts/write_docs.py writes")
        return 1 if stale else 0
    for p, text in documents().items():
        if p in stale:
            write_text(p, text)
            print(f"wrote {p.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
