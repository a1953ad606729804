"""``pnmold report``: (re)write a build folder's report.html."""

from __future__ import annotations

from pnmold.cli._common import say

HELP = "(re)write report.html of a build folder"
DESCRIPTION = ("Write DIR/report.html, the self-contained page of a build folder: part pictures, a 3D view, "
               "the checks, the FE curves and strain, the slicer's estimates and the checklist. Reads the "
               "folder's files; changes nothing else.")


def add_args(parser) -> None:
    parser.add_argument("dir", help="a build folder (out/<design-name>/)")


def run(args) -> int:
    from pnmold.report.html import write_report

    path = write_report(args.dir)
    say(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)", args)
    return 0
