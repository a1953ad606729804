"""Results as pandas DataFrames, where pandas is installed (``pip install 'pnmold[pandas]'``).

pnmold's results are plain values (dicts of JSON documents, dataclasses); these turn them
into tables for a notebook: :meth:`pnmold.fem.Solution.to_dataframe`,
:meth:`pnmold.pipeline.BuildResult.steps_frame`, and :func:`dataframe` for anything else
shaped as rows or columns, e.g. a simulation's ``doc["steps"]`` or a recording's ``columns``.
pandas is imported only when a frame is asked for.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
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
