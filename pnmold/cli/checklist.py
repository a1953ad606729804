"""``pnmold checklist``: the fabrication and testing checklist of a design."""

from __future__ import annotations

from pnmold.cli._common import add_design, load, out_console

HELP = "fabrication checklist with quantities from the geometry"
DESCRIPTION = ("The fabrication and testing checklist of a design, with elastomer amounts, paper size, inlet "
               "position, print settings and test pressures worked out. Uses out/<design>/report.json when it "
               "was built from this design.")


def add_args(parser) -> None:
    add_design(parser)
    parser.add_argument("--format", choices=["md", "html"], default="md")
    parser.add_argument("--out", metavar="FILE", help="write to FILE (default: print)")


def run(args) -> int:
    from pnmold.fsutil import write_text
    from pnmold.pipeline import checklist_text

    text = checklist_text(load(args), args.format)
    if args.out:
        write_text(args.out, text)
        out_console.print(f"wrote {args.out}")
    else:
        out_console.print(text, markup=False)
    return 0
