"""The ``pnmold`` command line: one module per verb (``add_args`` and ``run``), like meshio's.

Handlers only parse, call one library function and print; :func:`main` maps errors to exit
codes (docs/cli.md): 0 success, 1 a design-rule check failed, 2 bad usage or input, 3 a
geometry, meshing or solver failure; 130 after Ctrl-C; 70 for an unexpected error (a bug:
one line, the traceback with ``-v``).
"""

from pnmold.cli._interrupts import noting_interrupts


def main(argv=None) -> int:
    """Run the command line (``argv``: its words, default ``sys.argv[1:]``); return the exit code.
    The Ctrl-C handler goes in before the verbs are imported (:mod:`pnmold.cli._interrupts`)."""
    with noting_interrupts():
        from pnmold.cli._main import main as run

        return run(argv)


def make_parser():
    from pnmold.cli._main import make_parser as parser

    return parser()


__all__ = ["main", "make_parser"]
