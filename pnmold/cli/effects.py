"""``pnmold effects``: the catalogue of physics effects (CONTRACTS.md §5)."""

from __future__ import annotations

import json
import sys

from rich.markup import escape

from pnmold.cli._common import out_console

HELP = "the catalogue of physics effects"
DESCRIPTION = ("The catalogue of physics effects: name, parameter, unit, default, plausible bounds, the "
               "recording kinds that show it, and its fingerprint.")


def add_args(parser) -> None:
    parser.add_argument("--json", action="store_true", help="print the catalogue as JSON")


def run(args) -> int:
    from pnmold.effects import EFFECTS, catalogue_json

    if args.json:
        sys.stdout.write(json.dumps(catalogue_json(), indent=2) + "\n")
        return 0
    for e in EFFECTS.values():
        lo, hi = e.bounds
        out_console.print(f"[bold]{e.name}[/bold] {e.parameter} [{lo:g}, {hi:g}] {e.unit}, default {e.default:g} "
                          f"({', '.join(e.kinds)}; {', '.join(e.models)}): {escape(e.description)}")
        for param, unit, default, (plo, phi) in e.extra:
            out_console.print(f"    {e.name}.{param} [{plo:g}, {phi:g}] {unit}, default {default:g}")
    return 0
