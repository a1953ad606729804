"""The layout of a lab's text table: its delimiter and decimal mark, found, not assumed.

The one reader of the layout of every table pnmold takes from a lab: recordings
(:mod:`.format`) and tensile tests (:mod:`pnmold.materials.tensile`). The rules
(docs/recording-format.md, docs/tensile-files.md):

- UTF-8 text, LF or CRLF line ends; a byte-order mark (as spreadsheets write one) is dropped.
- The delimiter is ``;`` or tab when every one of the table's last rows (up to
  :data:`TAIL_ROWS`, blank and ``#`` lines left out) has one, else ``,``.
- A decimal comma (``1,5``) is read with ``;`` or tab only (with ``,`` the comma separates
  cells): when a digit, a comma and a digit follow each other in those rows.

:class:`Layout` says what it found (``semicolon-separated, decimal comma``), splits the rows and
reads a cell as a number; a cell that is not one is refused with a
:class:`~pnmold.errors.RecordingError` naming the file, line and column, and the layout when
that explains it (``1,5`` in a comma-separated file).
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

from pnmold.errors import RecordingError

#: delimiter -> its name in messages
DELIMITERS = {",": "comma", ";": "semicolon", "\t": "tab"}
#: the rows at the end of a table that decide its layout (the data, past any metadata block)
TAIL_ROWS = 20
_DIGIT_COMMA_DIGIT = re.compile(r"\d,\d")
_COMMA_NUMBER = re.compile(r"[-+]?(\d+,\d*|,\d+)([eE][-+]?\d+)?")
_ADVICE = "save with ';' as the separator or a decimal point"


@dataclass(frozen=True)
class Layout:
    """A table's delimiter and whether its numbers have a decimal comma."""

    delimiter: str = ","
    decimal_comma: bool = False

    def __str__(self) -> str:
        return f"{DELIMITERS[self.delimiter]}-separated" + (", decimal comma" if self.decimal_comma else "")

    def split(self, lines: Iterable[str]) -> Iterator[list[str]]:
        """The cells of each line (quoted cells as CSV quotes them)."""
        return csv.reader(lines, delimiter=self.delimiter)

    def plain(self, text: str) -> str:
        """A number as Python reads it: with a decimal comma, ``1,5`` as ``1.5``."""
        return text.replace(",", ".") if self.decimal_comma else text

    def is_number(self, text: str) -> bool:
        try:
            float(self.plain(text))
        except ValueError:
            return False
        return True

    def number(self, text: str, path: str, line: int, column: str | int | None = None) -> float:
        """A cell as a finite number; RecordingError names the file, line and column (and the
        layout, when it explains why the cell is not a number)."""
        try:
            value = float(self.plain(text))
        except ValueError:
            raise RecordingError(path, line, f"not a number: {text!r}{self.cell_hint(text)}", column=column) from None
        if not math.isfinite(value):
            raise RecordingError(path, line, f"not a finite number: {text!r}", column=column)
        return value

    def cell_hint(self, text: str) -> str:
        """Why ``text`` may not read as a number in this layout ("" when the layout does not say)."""
        cell = text.strip()
        if _COMMA_NUMBER.fullmatch(cell) and not self.decimal_comma:
            if self.delimiter == ",":
                return f" (read as {self}: {cell} looks like a decimal comma; {_ADVICE})"
            return (f" (read as {self}: {cell} looks like a decimal comma, but the file's last rows have decimal "
                    "points; use one decimal mark)")
        others = [name for d, name in DELIMITERS.items() if d != self.delimiter and d in cell]
        return f" (read as {self}: the cell holds a {others[0]})" if others else ""

    def fields_hint(self, line: str, n: int, expected: int) -> str:
        """Why a row has ``n`` fields where the header has ``expected`` ("" when the layout does not say)."""
        if n > expected and self.delimiter == "," and _DIGIT_COMMA_DIGIT.search(line):
            return f" (read as {self}: if the numbers have decimal commas, as in 1,5, {_ADVICE})"
        others = [name for d, name in DELIMITERS.items() if d != self.delimiter and d in line]
        return f" (read as {self}: this row has {others[0]}s)" if n < expected and others else ""


def find_layout(lines: Sequence[str]) -> Layout:
    """The layout of a table's lines (module docstring): the delimiter and the decimal mark of its
    last :data:`TAIL_ROWS` rows that are neither blank nor ``#`` lines."""
    tail = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")][-TAIL_ROWS:]
    delimiter = next((d for d in (";", "\t") if tail and all(d in ln for ln in tail)), ",")
    return Layout(delimiter, delimiter != "," and any(_DIGIT_COMMA_DIGIT.search(ln) for ln in tail))


def decode(raw: bytes, path: str) -> str:
    """A file's bytes as text: UTF-8, a byte-order mark dropped; RecordingError names the line
    of the first byte that is not UTF-8."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        line = raw[:err.start].count(b"\n") + 1
        raise RecordingError(path, line, f"not UTF-8 text ({err.reason}); save it as UTF-8 (in a spreadsheet: "
                             "CSV UTF-8)") from None
