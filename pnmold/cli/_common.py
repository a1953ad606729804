"""What the verbs share: the two consoles, the design arguments, progress and the gate's verdict."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rich.console import Console
from rich.markup import escape

err_console = Console(stderr=True, highlight=False, soft_wrap=True, emoji=False)  # a user's "A:B:C" stays text
out_console = Console(highlight=False, soft_wrap=True, emoji=False)


def output_flags(default=argparse.SUPPRESS) -> argparse.ArgumentParser:
    """``-v`` and ``-q`` as a parent parser: on ``pnmold`` itself (default False) and on every verb
    and sub-action (default: keep what was given before the verb)."""
    flags = argparse.ArgumentParser(add_help=False)
    flags.add_argument("-v", "--verbose", action="store_true", default=default,
                       help="log debug messages; print the traceback of an unexpected error")
    flags.add_argument("-q", "--quiet", action="store_true", default=default, help="print only errors and failures")
    return flags


#: ``--json -``: the JSON goes to standard output
STDOUT = "-"


def json_file(args) -> str | None:
    """The file ``--json`` names, for the library to write; None when there is none or it is
    standard output (``--json -``: the verb then calls :func:`emit_json`)."""
    path = getattr(args, "json", None)
    return None if path in (None, STDOUT) else path


def emit_json(args, doc: Any) -> None:
    """With ``--json -``, ``doc`` on standard output (as the library writes its JSON files)."""
    if getattr(args, "json", None) == STDOUT:
        sys.stdout.write(json.dumps(doc, indent=2, allow_nan=False) + "\n")
        sys.stdout.flush()


@contextmanager
def stdout_for_json(args) -> Iterator[None]:
    """With ``--json -`` standard output carries the JSON only: what the verb prints for a person
    goes to standard error meanwhile."""
    if getattr(args, "json", None) != STDOUT:
        yield
        return
    out_console.file = sys.stderr
    try:
        yield
    finally:
        out_console.file = None  # back to whatever sys.stdout is


def add_design(parser: argparse.ArgumentParser, default: str | None = None) -> None:
    """The DESIGN argument (a template or a TOML file) and ``--set`` (docs/cli.md)."""
    if default is None:
        parser.add_argument("design", help="template name (see `pnmold templates`) or TOML file")
    else:
        parser.add_argument("design", nargs="?", default=default,
                            help=f"template name or TOML file (default {default})")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a design field (repeatable)")


def load(args):
    """The design the command line names, with its overrides."""
    from pnmold.design import load_design

    return load_design(args.design, args.set)


@contextmanager
def stages(args, title: str) -> Iterator[Callable[[str], None]]:
    """A ``say(stage)`` callback that shows each stage with its time (nothing with ``--quiet``)."""
    from pnmold.cli._interrupts import INTERRUPTS
    from pnmold.cli.progress import stage_progress

    with stage_progress(err_console, args.quiet, title=title) as say:
        def checked(stage: str) -> None:
            if INTERRUPTS:  # a Ctrl-C noted during an import, or one a library swallowed (pnmold.cli._interrupts)
                raise KeyboardInterrupt
            say(stage)

        yield checked


def verdict(checks: list[dict], quiet: bool) -> int:
    """Print the failed checks in plain words (and the skipped ones); 1 when any failed."""
    failed = [c for c in checks if c["passed"] is False]
    skipped = [c for c in checks if c["passed"] is None]
    for check in failed:
        err_console.print(f"[red]FAILED[/red] {check['id']}: {escape(check['message'])}")
    if not quiet:
        for check in skipped:
            err_console.print(f"[yellow]skipped[/yellow] {check['id']}: {escape(check['message'])}")
        passed = len(checks) - len(failed) - len(skipped)
        out_console.print(f"checks: {passed} passed, {len(failed)} failed, {len(skipped)} skipped")
    return 1 if failed else 0


def say(text: str, args) -> None:
    """A line on standard output unless ``--quiet``."""
    if not args.quiet:
        out_console.print(escape(text))
