"""Write the templates' FE characterisations that ship with pnmold (``pnmold/data/characterisations/``).

Each template is characterised afresh on the default mesh and pressure limit (free run, gravity
probe, variant runs, the on-demand probes: the blocked tip, the chambers-down compliance, both
orientations' compliance with a compliant layer, the roll held on its side and the free run with
self-contact; one to a
few minutes of FE each on 2 cores) in a temporary cache; ``--probes-only`` adds the on-demand probes
to the bundled file as it is (a minute or two); its numbers are rounded to 6 significant digits and
the JSON written compact, under the cache's file name (design digest, mesh, pressure limit). Run it
after a change of a template or of the characterisation: ``tests/test_rom.py`` fails until the
bundled files are the templates' again.

    .venv/bin/python scripts/bundle_characterisations.py [--probes-only] [TEMPLATE ...]
"""

from __future__ import annotations

import importlib
import json
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pnmold.design import list_templates, load_design  # noqa: E402
from pnmold.fsutil import write_text  # noqa: E402

ch = importlib.import_module("pnmold.physics.characterise")  # the module (the package exports the function)
from pnmold.physics.probes import characterised_for  # noqa: E402


def rounded(value, digits: int = 6):
    """``value`` with every float rounded to ``digits`` significant digits (lists, dicts kept)."""
    if isinstance(value, float):
        return float(f"{value:.{digits}g}")
    if isinstance(value, list):
        return [rounded(v, digits) for v in value]
    if isinstance(value, dict):
        return {k: rounded(v, digits) for k, v in value.items()}
    return value


def main(names: list[str]) -> None:
    probes_only = "--probes-only" in names
    bundled = ch.BUNDLED_DIR
    for name in [n for n in names if n != "--probes-only"] or sorted(list_templates()):
        design = load_design(name)
        with tempfile.TemporaryDirectory() as tmp:
            os.environ["PNMOLD_CACHE"] = tmp
            ch.BUNDLED_DIR = bundled if probes_only else Path(tmp) / "none"  # afresh: not from the files written
            result = characterised_for(design, ["force"], ["chambers_up", "chambers_down", "horizontal"], layer=True,
                                       contact=True, progress=lambda stage: print(f"  {stage}", flush=True))
        doc = rounded(result.to_json())
        name_on_disk = ch.cache_path(design, ch.DEFAULT_SIZE, ch.DEFAULT_MAX_PRESSURE_KPA).name
        for old in (ROOT / "pnmold" / "data" / "characterisations").glob(f"{design.name}-*.json"):
            if old.name != name_on_disk:
                old.unlink()
        out = ROOT / "pnmold" / "data" / "characterisations" / name_on_disk
        write_text(out, json.dumps(doc, separators=(",", ":")) + "\n")
        print(f"{name}: {out.relative_to(ROOT)} ({out.stat().st_size / 1024:.0f} KiB, "
              f"full bend {result.full_bend_pressure_kpa} kPa)", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
