"""Results in a notebook: tables of rows as pandas DataFrames, and short summaries as HTML.

pnmold's results are plain values (dicts of JSON documents, dataclasses); these turn them
into tables for a notebook: :meth:`pnmold.fem.Solution.to_dataframe`,
:meth:`pnmold.pipeline.BuildResult.steps_frame`, :meth:`pnmold.simulate.Simulation.steps_frame`,
and :func:`dataframe` for anything else shaped as rows or columns, e.g. a recording's ``columns``
(where pandas is installed: ``pip install 'pnmold[pandas]'``; it is imported only when a frame is
asked for). :func:`summary_html` is the small table a result shows itself as in Jupyter
(``_repr_html_`` of a build result, a simulation and a diagnosis).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from html import escape
from typing import TYPE_CHECKING, Any

from pnmold.errors import UsageError

if TYPE_CHECKING:
    import pandas as pd


def require_pandas():
    """The pandas module, or :class:`~pnmold.errors.UsageError` saying how to install it."""
    try:
        import pandas
    except ImportError as err:
        raise UsageError("DataFrames need pandas, which is not installed: pip install 'pnmold[pandas]'") from err
    return pandas


def dataframe(data: Sequence[Mapping[str, Any]] | Mapping[str, Any]) -> pd.DataFrame:
    """A DataFrame of ``data``: rows (a list of dicts with the same keys, e.g. a simulation
    document's ``steps``) or columns (a dict of equal-length arrays, e.g. a recording's
    ``columns``). Column names keep their units (``pressure_kpa``, ``tip_x_mm``); a value that
    is a list (``clamp_reaction_n``) stays one cell."""
    pandas = require_pandas()
    if isinstance(data, Mapping):
        return pandas.DataFrame(dict(data))
    return pandas.DataFrame.from_records(list(data))


def summary_html(title: str, rows: Mapping[str, str], notes: Sequence[str] = (), notes_title: str = "") -> str:
    """A result's summary as a small HTML table (``title`` above it; ``rows``: label -> value), with
    an optional list of ``notes`` under ``notes_title``. Every string is escaped."""
    cells = "".join(f"<tr><th style='text-align:left'>{escape(k)}</th><td style='text-align:left'>{escape(v)}"
                    f"</td></tr>" for k, v in rows.items())
    items = "".join(f"<li>{escape(n)}</li>" for n in notes)
    return (f"<table><caption style='text-align:left'><b>{escape(title)}</b></caption>{cells}</table>"
            + (f"<p>{escape(notes_title)}</p><ul>{items}</ul>" if items else ""))
