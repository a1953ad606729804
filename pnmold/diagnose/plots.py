"""Before/after figures of a diagnosis: data, baseline, improved model, residuals, window."""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pnmold.physics.protocol import read_by_volume

from .fitting import REACH

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _x(rec) -> tuple[np.ndarray, str]:
    if rec.kind == "step":
        return np.asarray(rec.columns["time_s"], float), "time (s)"
    if read_by_volume(rec):
        return np.asarray(rec.columns["volume_ml"], float), "volume set by the rig (mL)"
    return np.asarray(rec.columns["pressure_kpa"], float), "pressure (kPa)"


def _residuals(panel, x: np.ndarray, s, pred: dict[str, np.ndarray], color: str, label: str) -> None:
    """Measured minus predicted, in the observable's units. A row past the model's pressure maximum
    (its prediction the state at the maximum; the fit also counts the pressure, or the volume, it cannot
    hold, which is not a residual of this observable) is drawn as a cross."""
    r = s.y - np.asarray(pred[s.observable], float)[s.rows]
    past = np.zeros(s.rows.size, bool)
    for key in REACH:
        past |= np.asarray(pred.get(key, np.zeros(len(pred[s.observable]))), float)[s.rows] > 0
    panel.plot(x[~past], r[~past], ".", ms=3, color=color, label=label)
    if past.any():
        panel.plot(x[past], r[past], "x", ms=4, color=color,
                   label=f"{label}, past the model's pressure maximum")


def fit_figure(diag: Any, path: str | Path | None = None, *, ax: Any = None) -> Figure:
    """One column per series of ``diag`` (a :class:`~pnmold.diagnose.core.Diagnosis`): data, baseline and
    final model on top, residuals below.

    ``ax``: a 2 x (number of series) grid of axes to draw on (default a new figure);
    ``path``: also save the figure there (atomically). Returns the figure.
    """
    from pnmold.plots import figure_axes, save_figure

    data, dec = diag.data, diag.decision
    base = dec.baseline.fit.predictions
    final = dec.final.fit.predictions
    n = len(data.series)
    fig, axes = figure_axes(ax, (2, n), (4.2 * n, 6.2), sharex="col", gridspec_kw={"height_ratios": [2, 1]})
    label = dec.final.label
    for j, s in enumerate(data.series):
        rec = data.recordings[s.recording]
        x, xlabel = _x(rec)
        top, bottom = axes[0, j], axes[1, j]
        top.plot(x[s.rows], s.y, ".", ms=3, color="0.3", label="recording")
        top.plot(x, base[s.recording][s.observable], "--", color="tab:red", lw=1.2, label="baseline (calibrated)")
        if dec.accepted:
            top.plot(x, final[s.recording][s.observable], "-", color="tab:blue", lw=1.2, label=f"with {label}")
        top.set_title(f"{Path(rec.path).name}: {s.observable}", fontsize=9)
        top.set_ylabel(s.observable)
        _residuals(bottom, x[s.rows], s, base[s.recording], "tab:red", "baseline")
        if dec.accepted:
            _residuals(bottom, x[s.rows], s, final[s.recording], "tab:blue", "improved")
        bottom.axhline(0, color="0.5", lw=0.8)
        bottom.fill_between([x.min(), x.max()], -2 * s.level, 2 * s.level, color="0.85", label="2 x noise")
        for m in diag.doc["mismatch"]:
            if m["observable"] == s.observable:
                a, b = next(iter(m["window"].values()))
                for panel in (top, bottom):
                    panel.axvspan(a, b, color="gold", alpha=0.25)
        bottom.set_xlabel(xlabel)
        bottom.set_ylabel("residual")
        if j == 0:
            top.legend(fontsize=7)
            bottom.legend(fontsize=7)
    if ax is None:
        # the summary's start, wrapped to the figure's width (one long line was cut off at both edges; at 8 pt
        # about 14 characters an inch)
        width = max(40, int(14 * fig.get_figwidth()))
        fig.suptitle(textwrap.fill(textwrap.shorten(diag.doc["summary"], 2 * width, placeholder=" ..."), width),
                     fontsize=8)
        fig.tight_layout(rect=(0.0, 0.0, 1.0, 0.95))
    if path is not None:
        save_figure(fig, path, dpi=110, tight=False)
    return fig
