"""``pnmold check``: the design-rule gate again on a build folder's files."""

from __future__ import annotations

from pnmold.cli._common import verdict

HELP = "re-run every design-rule check on a build folder"
DESCRIPTION = ("Re-run the design-rule gate on the files of a build folder; updates its report.json; "
               "exit 1 when a check fails.")


def add_args(parser) -> None:
    parser.add_argument("dir", help="a build folder (out/<design-name>/)")
    parser.add_argument("--no-slicer", action="store_true", help="skip PrusaSlicer (reported as skipped)")


def run(args) -> int:
    from pnmold.pipeline import recheck

    return verdict(recheck(args.dir, use_slicer=not args.no_slicer)["checks"], args.quiet)
