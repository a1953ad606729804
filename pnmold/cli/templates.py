"""``pnmold templates``: the design templates, one line each."""

from __future__ import annotations

from rich.markup import escape

from pnmold.cli._common import out_console

HELP = "list the design templates"
DESCRIPTION = "List the design templates with one line each."


def add_args(parser) -> None:
    pass


def run(args) -> int:
    from pnmold.design import list_templates

    for name, description in list_templates().items():
        out_console.print(f"{name:<14} {escape(description)}")
    return 0
