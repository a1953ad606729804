"""A stress-strain plot of a hyperelastic fit, like the supplement's Fig. S4 (PNG, atomic)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from pnmold.errors import ExportError

_UNITS = {"mpa": " MPa"}


def _label(result) -> str:
    parts = []
    for key, value in result.constants.items():
        name, _, unit = key.partition("_")
        parts.append(f"{name.upper() if name.startswith('c') else name} = {value:.4g}{_UNITS.get(unit, '')}")
    return f"{result.model} fit: " + ", ".join(parts) + f"\n$R^2$ = {result.r2:.5f}"


def plot_fit(data, result, path: str | Path | None = None, *, ax: Any = None) -> Figure:
    """Measured points, the fitted curve and the strain range where the fit holds.

    A :class:`~matplotlib.figure.Figure` (no pyplot state, no backend switch). ``ax``: the axes
    to draw on (default a new figure); ``path``: also save the figure there, as a PNG written
    to a temporary name beside it and renamed over it. Returns the figure.
    """
    from pnmold.plots import figure_axes, save_figure

    own = ax is None
    fig, grid = figure_axes(ax, (1, 1), (6.4, 4.8))
    ax = grid[0, 0]
    used = result.fitted(data)
    ax.plot(data.strain[used], data.stress_mpa[used], "o", ms=3.5, mfc="none", color="0.25", label="measured")
    if not used.all():
        ax.plot(data.strain[~used], data.stress_mpa[~used], "x", ms=4, color="0.6", label="not fitted")
    lo, hi = float(np.min(data.strain[used])), float(np.max(data.strain[used]))
    curve = np.linspace(lo, hi, 400)
    ax.plot(curve, result.stress(curve), "-", color="tab:red", lw=1.6, label=_label(result))
    if result.strain_range:
        a, b = result.strain_range
        ax.axvspan(a, b, color="tab:green", alpha=0.08, label=f"fit holds: strain {a:.3g} to {b:.3g}")
    ax.axhline(0, color="0.8", lw=0.6)
    ax.set_xlabel("engineering strain")
    ax.set_ylabel("engineering stress (MPa)")
    ax.set_title(Path(result.source).name, fontsize=9)
    ax.legend(fontsize=8, loc="upper left")
    if own:
        fig.tight_layout()
    if path is None:
        return fig
    try:
        save_figure(fig, path, dpi=120, tight=False)
    except OSError as err:
        raise ExportError(str(path), f"could not write the plot: {err}") from err
    return fig
