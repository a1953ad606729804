"""The parser (one sub-parser per verb module) and :func:`main` (exit codes)."""

from __future__ import annotations

import argparse
import logging
import sys
import traceback
from collections.abc import Sequence

from rich.markup import escape

from pnmold.cli import (
    build,
    check,
    checklist,
    diagnose,
    docs,
    effects,
    export,
    material,
    recording,
    report,
    simulate,
    sweep,
    templates,
    track,
)
from pnmold.cli._common import err_console, output_flags, stdout_for_json
from pnmold.cli._interrupts import noting_interrupts
from pnmold.errors import EXIT_INTERRUPTED, EXIT_IO, EXIT_UNEXPECTED, PnmoldError
from pnmold.version import __version__

#: verb -> its module, in the order ``--help`` lists them
VERBS = {"build": build, "check": check, "report": report, "simulate": simulate, "checklist": checklist,
         "material": material, "sweep": sweep, "diagnose": diagnose, "effects": effects, "templates": templates,
         "recording": recording, "track": track, "export": export, "docs": docs}


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pnmold", parents=[output_flags(False)], description=(
        "PneuNet bending actuators: casting molds, design-rule checks, quick FE, diagnosis."))
    parser.add_argument("--version", action="version", version=f"pnmold {__version__}")
    flags = output_flags()  # after the verb too, without overriding the ones before it
    sub = parser.add_subparsers(dest="verb", required=True, metavar="VERB")
    for name, module in VERBS.items():
        p = sub.add_parser(name, parents=[flags], help=module.HELP, description=module.DESCRIPTION)
        module.add_args(p)
        if hasattr(module, "run"):
            p.set_defaults(handler=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = make_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help and --version -> 0, bad usage -> 2
        return int(exc.code or 0)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    with noting_interrupts() as interrupted:
        try:
            with stdout_for_json(args):  # --json -: standard output carries the JSON only
                code = args.handler(args)
            return _interrupted() if interrupted else code  # a Ctrl-C a library swallowed still ends the run so
        except PnmoldError as err:
            if interrupted:
                return _interrupted()
            err_console.print(f"[red]error[/red] ({type(err).__name__}): {escape(str(err))}")
            return err.exit_code
        except KeyboardInterrupt:
            return _interrupted()
        except OSError as err:  # a file or folder that cannot be read or written: the user's to fix, not a bug
            if interrupted:
                return _interrupted()
            where = f"{err.filename}: " if err.filename else ""
            err_console.print(f"[red]error[/red] (file access): {escape(where + (err.strerror or str(err)))}")
            return EXIT_IO
        except Exception as err:  # a bug, not the user's doing: one line, the traceback with -v
            if interrupted:
                return _interrupted()
            return _unexpected(err, args.verbose)


def _interrupted() -> int:
    err_console.print("interrupted")
    return EXIT_INTERRUPTED


def _unexpected(err: Exception, verbose: bool) -> int:
    if verbose:
        err_console.print(escape(traceback.format_exc()))
    err_console.print(f"[red]unexpected error[/red] ({type(err).__name__}): {escape(str(err))}"
                      + ("" if verbose else " (run with -v for the traceback)"))
    return EXIT_UNEXPECTED


if __name__ == "__main__":
    sys.exit(main())
