"""``pnmold diagnose``: recordings against the model; the missing physics named, fitted, shown."""

from __future__ import annotations

from rich.markup import escape

from pnmold.cli._common import add_design, emit_json, json_file, load, out_console, stages
from pnmold.errors import UsageError

HELP = "compare recordings with the model and name the missing physics"
DESCRIPTION = ("Compare lab recordings (CSV: see `pnmold docs recording-format`; pressures in kPa, psi, bar, ... and "
               "volumes in mL, uL, cc, ... by their column names, converted as read) with the reduced model (step "
               "recordings: with the pneumatic step model): recalibrate the modulus, locate the mismatch, name the "
               "missing physics from the catalogue of effects (pnmold effects), fit it and show the held-out "
               "improvement; or say nothing is missing. `pnmold recording template KIND` writes a file to fill in.")


def add_args(parser) -> None:
    add_design(parser)
    parser.add_argument("recordings", nargs="+", metavar="RECORDING.csv",
                        help="recordings (bending, pv, force, step; `pnmold docs recording-format`)")
    parser.add_argument("--json", metavar="FILE",
                        help="write the diagnosis (schema pnmold.diagnosis/1: `pnmold docs json-schemas`); - for "
                        "standard output")
    parser.add_argument("--report", metavar="DIR", help="write report.html with before/after plots into DIR")
    parser.add_argument("--seed", type=int, default=0, help="seed of the bootstrap resampling (default 0)")
    parser.add_argument("--model-error", type=float, default=None, metavar="SHARE",
                        help="the model's own form error as a share of each observable's range: the noise floor "
                        "of a recording without repeated cycles (default 0.01; raise it for a design known only "
                        "roughly, e.g. from another paper's drawings); on bending, P-V and force recordings the "
                        "model's 2%% error in pressure, through its slope, is added row by row")
    parser.add_argument("--uncertain", action="append", default=[], metavar="FIELD=MM",
                        help="a design dimension known only to a standard uncertainty, e.g. "
                        "chambers.outer_wall_mm=1 for a wall read off another paper's drawing (repeatable): the FE "
                        "solves the design with it moved up by that much (a free run each, once, cached) and what "
                        "that changes in the recordings, beyond what the modulus absorbs, is a floor under the noise")


def run(args) -> int:
    from pnmold.diagnose.data import MODEL_FORM_SHARE
    from pnmold.diagnose.run import diagnose_recordings

    share = MODEL_FORM_SHARE if args.model_error is None else args.model_error
    if not 0.0 <= share < 1.0:
        raise UsageError(f"--model-error must be in [0, 1), got {share:g}")
    uncertain = {}
    for item in args.uncertain:
        field, sep, value = item.partition("=")
        try:
            uncertain[field.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep:
            raise UsageError(f"--uncertain takes FIELD=MM (e.g. chambers.outer_wall_mm=1), got {item!r}")
    if args.report:  # refused before the work, not after it
        from pnmold.fsutil import check_replaceable

        check_replaceable(args.report)
    design = load(args)
    with stages(args, f"characterise {design.name} (once)") as say:
        diag = diagnose_recordings(design, args.recordings, seed=args.seed, json_path=json_file(args),
                                   report_dir=args.report, progress=say, model_form_share=share,
                                   uncertain=uncertain)
    emit_json(args, diag.doc)
    if not args.quiet:
        for r in diag.doc["recordings"]:
            for column, how in r.get("conversions", {}).items():
                out_console.print(f"read {escape(r['path'])}: {escape(column)} {escape(how)}")
        reduced = [r["reduction"]["words"] for r in diag.doc["recordings"] if "reduction" in r]
        summary = diag.doc["summary"]
        for words in reduced:  # said first, on a line of its own
            out_console.print(f"read {escape(words)}")
            summary = summary.replace(words, "", 1).lstrip()
        out_console.print(escape(summary))
        for m in diag.doc["mismatch"]:
            out_console.print(f"  mismatch: {escape(m['description'])}")
    return 0
