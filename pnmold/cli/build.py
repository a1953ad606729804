"""``pnmold build``: CAD, export, the design-rule gate, quick FE, checklist and report."""

from __future__ import annotations

from rich.markup import escape

from pnmold.cli._common import add_design, err_console, load, out_console, stages, verdict

HELP = "CAD, export, checks, quick FE into out/<design>/"
DESCRIPTION = "Build the actuator and its three molds as STEP and STL."


def add_args(parser) -> None:
    add_design(parser, default="fpn")
    parser.add_argument("--out", metavar="DIR", help="output folder (default out/<design-name>/)")
    parser.add_argument("--no-fem", action="store_true", help="skip the quick FE solve")
    parser.add_argument("--no-slicer", action="store_true", help="skip PrusaSlicer (reported as skipped)")
    parser.add_argument("--self-contact", action="store_true",
                        help="the quick FE keeps the chambers' walls from passing through each other "
                             "(frictionless penalty contact; about twice the FE's time); default: off")


def run(args) -> int:
    from pnmold.pipeline import build

    design = load(args)
    with stages(args, f"build {design.name}") as say:
        result = build(design, args.out, fem=not args.no_fem, use_slicer=not args.no_slicer, progress=say,
                       self_contact=args.self_contact)
    if not args.quiet:
        out_console.print(f"wrote {result.out_dir}/ ({len(result.report['parts'])} parts as "
                          f"STEP and STL, design.toml, report.json, report.html)")
    code = verdict(result.report["checks"], args.quiet)
    if result.fem_failed:
        err_console.print(f"[red]quick FE failed[/red]: {escape(result.report['fem']['reason'])} "
                          "(the parts, the checks and the report are written)")
    return code or result.exit_code
