"""``pnmold recording template|check``: an empty, commented recording to fill in; a check of lab files."""

from __future__ import annotations

import sys
from pathlib import Path

from rich.markup import escape

from pnmold.cli._common import err_console, output_flags, say
from pnmold.conventions import RECORDING_KINDS
from pnmold.errors import UsageError

HELP = "recording templates and checks (the lab CSV format, `pnmold docs recording-format`)"
DESCRIPTION = ("Lab recordings in pnmold's CSV format (see `pnmold docs recording-format`): write an empty, commented "
               "file of one kind to fill in, or check files as pnmold diagnose will read them, with the unit "
               "conversions it makes.")


def add_args(parser) -> None:
    actions = parser.add_subparsers(dest="recording_verb", required=True, metavar="ACTION")
    template = actions.add_parser(
        "template", parents=[output_flags()], help="write an empty, commented recording of one kind",
        description="Write an empty recording of KIND: '##' comments explaining every metadata key and column, "
        "the metadata lines and the header row (required columns, then optional ones to keep or delete). Fill "
        "in two or more rows and pnmold reads it. See `pnmold docs recording-format`.")
    template.add_argument("kind", choices=list(RECORDING_KINDS), metavar="KIND",
                          help=f"one of {', '.join(RECORDING_KINDS)}")
    template.add_argument("--out", metavar="FILE", help="write to FILE (default: standard output)")
    template.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    template.set_defaults(handler=run_template)
    check = actions.add_parser(
        "check", parents=[output_flags()], help="read recordings as pnmold diagnose does and say what was read",
        description="Read and validate recordings (a malformed one: exit 2 naming the file, line and column); "
        "print each one's kind, rows, orientation and the unit conversions made (pressure_psi -> pressure_kpa, "
        "...), and how pnmold diagnose reduces a recording too long to read row by row.")
    check.add_argument("recordings", nargs="+", metavar="RECORDING.csv")
    check.set_defaults(handler=run_check)


def run_template(args) -> int:
    from pnmold.recording import recording_template, write_template

    if args.out is None:
        sys.stdout.write(recording_template(args.kind))
        return 0
    if Path(args.out).exists() and not args.force:
        raise UsageError(f"{args.out} exists; pass --force to overwrite it")
    say(f"wrote {write_template(args.out, args.kind)}", args)
    return 0


def run_check(args) -> int:
    from pnmold.recording import read_recording
    from pnmold.recording.reduce import check_size, reduce_recording
    from pnmold.recording.sanity import check_usable

    for path in args.recordings:
        check_size(path)
    for path in args.recordings:
        rec = read_recording(path)
        say(f"{rec.path}: {rec.kind}, {len(rec)} rows, {rec.orientation}; columns {', '.join(rec.columns)}", args)
        if rec.layout != "comma-separated":
            say(f"  read as {rec.layout}", args)
        for name, how in rec.conversions.items():
            say(f"  {name} {how}", args)
        for doubt in check_usable(rec):  # a refusing doubt is raised: the diagnosis would refuse it too
            err_console.print(f"[yellow]warning[/yellow] {escape(rec.path)}, column {doubt.column}: "
                              f"{escape(doubt.message)}")
        _, reduced = reduce_recording(rec)
        if reduced is not None:  # what pnmold diagnose will read of it
            say(f"  pnmold diagnose reduces it as it reads it: {reduced.words}", args)
    return 0
