"""``pnmold diagnose``: recordings against the model; the missing physics named, fitted, shown."""

from __future__ import annotations

from rich.markup import escape

from pnmold.cli._common import add_design, emit_json, json_file, load, out_console, stages

HELP = "compare recordings with the model and name the missing physics"
DESCRIPTION = ("Compare lab recordings (CSV: see docs/recording-format.md; pressures in kPa, psi, bar, ... and "
               "volumes in mL, uL, cc, ... by their column names, converted as read) with the reduced model (step "
               "recordings: with the pneumatic step model): recalibrate the modulus, locate the mismatch, name the "
               "missing physics from the catalogue of effects (pnmold effects), fit it and show the held-out "
               "improvement; or say nothing is missing. `pnmold recording template KIND` writes a file to fill in.")


def add_args(parser) -> None:
    add_design(parser)
    parser.add_argument("recordings", nargs="+", metavar="RECORDING.csv",
                        help="recordings (bending, pv, force, step; docs/recording-format.md)")
    parser.add_argument("--json", metavar="FILE",
                        help="write the diagnosis (schema pnmold.diagnosis/1: docs/json-schemas.md); - for "
                        "standard output")
    parser.add_argument("--report", metavar="DIR", help="write report.html with before/after plots into DIR")
    parser.add_argument("--seed", type=int, default=0, help="seed of the bootstrap resampling (default 0)")


def run(args) -> int:
    from pnmold.diagnose.run import diagnose_recordings

    design = load(args)
    with stages(args, f"characterise {design.name} (once)") as say:
        diag = diagnose_recordings(design, args.recordings, seed=args.seed, json_path=json_file(args),
                                   report_dir=args.report, progress=say)
    emit_json(args, diag.doc)
    if not args.quiet:
        for r in diag.doc["recordings"]:
            for column, how in r.get("conversions", {}).items():
                out_console.print(f"read {escape(r['path'])}: {escape(column)} {escape(how)}")
        out_console.print(escape(diag.doc["summary"]))
        for m in diag.doc["mismatch"]:
            out_console.print(f"  mismatch: {escape(m['description'])}")
    return 0
