"""``pnmold docs [PAGE]``: the manual, as installed: the list of its pages, or one page's text.

The pages are the Markdown files of ``docs/``: in a source checkout the top-level ``docs/``
(beside ``pyproject.toml``), in an installed wheel the copy ``setup.py`` puts into the package
(``pnmold/docs/``). Every ``--help`` that refers to a page names it as ``pnmold docs PAGE``.
"""

from __future__ import annotations

from pathlib import Path

from rich.markup import escape

from pnmold.cli._common import out_console
from pnmold.errors import UsageError

HELP = "the manual: list its pages or print one"
DESCRIPTION = ("The manual (docs/*.md) as installed with this pnmold: without PAGE, its pages with their titles "
               "and the folder they are in; with PAGE (e.g. recording-format), that page's text.")


def docs_dir() -> Path:
    """Folder of the manual's pages: the checkout's ``docs/`` when pnmold runs from one, else the
    package's ``pnmold/docs/`` (a wheel)."""
    package = Path(__file__).resolve().parents[1]
    checkout = package.parent
    if (checkout / "pyproject.toml").is_file() and (checkout / "docs").is_dir():
        return checkout / "docs"
    return package / "docs"


def doc_path(page: str) -> Path:
    """The file of manual page ``page`` (``recording-format`` or ``recording-format.md``); UsageError
    listing the pages when there is none of that name."""
    path = docs_dir() / f"{page.removesuffix('.md')}.md"
    if not path.is_file():
        raise UsageError(f"no manual page {page!r}; pages: {', '.join(pages())} (in {docs_dir()})")
    return path


def pages() -> dict[str, str]:
    """Page name -> its title (the first ``# `` heading)."""
    out = {}
    for path in sorted(docs_dir().glob("*.md")):
        title = next((line[2:].strip() for line in path.read_text(encoding="utf-8").splitlines()
                      if line.startswith("# ")), path.stem)
        out[path.stem] = title
    return out


def add_args(parser) -> None:
    parser.add_argument("page", nargs="?", metavar="PAGE", help="a page's name (see the list without PAGE)")
    parser.add_argument("--path", action="store_true", help="print the page's file (or the folder) instead")


def run(args) -> int:
    if args.page is None:
        if args.path:
            print(docs_dir())
            return 0
        for name, title in pages().items():
            out_console.print(f"{name:<20} {escape(title)}")
        out_console.print(f"({docs_dir()}; `pnmold docs PAGE` prints one)")
        return 0
    path = doc_path(args.page)
    print(path if args.path else path.read_text(encoding="utf-8"), end="\n" if args.path else "")
    return 0
