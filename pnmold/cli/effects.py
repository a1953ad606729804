"""``pnmold effects``: the catalogue of physics effects (docs/effects.md)."""

from __future__ import annotations

from rich.markup import escape

from pnmold.cli._common import STDOUT, emit_json, json_file, out_console, say

HELP = "the catalogue of physics effects"
DESCRIPTION = ("The catalogue of physics effects: name, parameter, unit, default, plausible bounds, the "
               "recording kinds that show it, and its fingerprint.")


def add_args(parser) -> None:
    parser.add_argument("--json", nargs="?", const=STDOUT, metavar="FILE",
                        help="the catalogue as JSON: on standard output (--json or --json -) or into FILE")


def run(args) -> int:
    from pnmold.effects import EFFECTS, catalogue_json

    if args.json == STDOUT:
        emit_json(args, catalogue_json())
        return 0
    if args.json:
        from pnmold.fsutil import write_json

        say(f"wrote {write_json(json_file(args), catalogue_json())}", args)
        return 0
    for e in EFFECTS.values():
        lo, hi = e.bounds
        out_console.print(f"[bold]{e.name}[/bold] {e.parameter} [{lo:g}, {hi:g}] {e.unit}, default {e.default:g} "
                          f"({', '.join(e.kinds)}; {', '.join(e.models)}): {escape(e.description)}")
        for param, unit, default, (plo, phi) in e.extra:
            out_console.print(f"    {e.name}.{param} [{plo:g}, {phi:g}] {unit}, default {default:g}")
    return 0
