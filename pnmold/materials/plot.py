"""A stress-strain plot of a hyperelastic fit, like the supplement's Fig. S4 (PNG, atomic)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pnmold.errors import ExportError
from pnmold.fsutil import atomic_path

_UNITS = {"mpa": " MPa"}


def _label(result) -> str:
    parts = []
    for key, value in result.constants.items():
        name, _, unit = key.partition("_")
        parts.append(f"{name.upper() if name.startswith('c') else name} = {value:.4g}{_UNITS.get(unit, '')}")
    return f"{result.model} fit: " + ", ".join(parts) + f"\n$R^2$ = {result.r2:.5f}"


def plot_fit(data, result, path: str | Path) -> Path:
    """Measured points, the fitted curve and the strain range where the fit holds, as a PNG.

    Uses the Agg canvas directly (no pyplot state, no backend switch); the file is written
    to a temporary name beside ``path`` and renamed over it.
    """
    path = Path(path)
    fig = Figure(figsize=(6.4, 4.8), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
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
    fig.tight_layout()
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png")
    except OSError as err:
        raise ExportError(str(path), f"could not write the plot: {err}") from err
    return path
