"""Figures a person looks at, as matplotlib :class:`~matplotlib.figure.Figure` objects.

No pyplot and no backend switch: importing or calling pnmold leaves matplotlib's global state
(a notebook's backend, pyplot's figures) as it was. Every plotting function of pnmold draws
on the axes passed as ``ax=`` (then their figure is the one returned) or on a new figure,
returns the figure, and with a ``path`` also saves it atomically (:func:`save_figure`). In a
notebook a returned figure shows as the cell's value or with ``display(fig)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from pnmold.errors import UsageError
from pnmold.fsutil import atomic_path


def figure_axes(ax: Any, shape: tuple[int, int], figsize: tuple[float, float], **subplots: Any
                ) -> tuple[Figure, np.ndarray]:
    """The figure and the ``shape`` grid of axes to draw on: those given (``ax``: one Axes, or a
    sequence or array of ``rows x columns`` of them) or a new figure's (``subplots``: passed to
    :meth:`Figure.subplots`, e.g. ``sharex``)."""
    if ax is None:
        fig = Figure(figsize=figsize)
        return fig, fig.subplots(*shape, squeeze=False, **subplots)
    given = np.asarray(ax, dtype=object)
    if given.size != shape[0] * shape[1]:
        raise UsageError(f"ax: this figure draws on {shape[0]} x {shape[1]} axes, got {given.size}")
    axes = given.reshape(shape)
    return axes.flat[0].figure, axes


def save_figure(fig: Figure, path: str | Path, dpi: int = 120, tight: bool = True) -> Path:
    """Save ``fig`` as the file ``path`` says (PNG, SVG, PDF, ...), atomically: to a temporary
    name beside it, then renamed over it."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, bbox_inches="tight" if tight else None)
    return Path(path)


def plot_bending(title: str, steps: list[dict[str, Any]], shapes: list[tuple[float, np.ndarray, np.ndarray]],
                 path: str | Path | None = None, full_bend_kpa: float | None = None, *,
                 ax: Sequence[Any] | None = None) -> Figure:
    """Deformed shapes and the tip trajectory (like the supplement's Fig. S5 E-F), the
    bend angle against pressure and the pressure-volume curve.

    Parameters
    ----------
    title : the figure's title (on a new figure only).
    steps : the ``fem.steps`` dicts of report.json.
    shapes : (pressure_kpa, bottom_xz, top_xz) polylines in mm.
    path : also save the figure there (atomically).
    full_bend_kpa : marked on the bend-angle panel.
    ax : three axes to draw on (shapes, bend angle, pressure-volume); default a new figure.

    Returns
    -------
    The figure drawn on.
    """
    from matplotlib import colormaps

    fig, grid = figure_axes(ax, (1, 3), (15, 4.6))
    axes = grid[0]
    shape_ax = axes[0]
    cmap = colormaps["viridis"]
    pmax = max((p for p, _, _ in shapes), default=1.0) or 1.0
    for p, bottom, top in shapes:
        colour = cmap(p / pmax)
        shape_ax.plot(bottom[:, 0], bottom[:, 1], "-", color=colour, lw=1.6, label=f"{p:.0f} kPa")
        shape_ax.plot(top[:, 0], top[:, 1], ".", color=colour, ms=1.5)
    shape_ax.plot([s["tip_x_mm"] for s in steps], [s["tip_z_mm"] for s in steps], "k--", lw=1, label="tip trajectory")
    shape_ax.set_aspect("equal")
    shape_ax.set_xlabel("x (mm)")
    shape_ax.set_ylabel("z (mm)")
    shape_ax.set_title("deformed shape (y = 0) and tip")
    shape_ax.legend(fontsize=7, loc="best")
    p = [s["pressure_kpa"] for s in steps]
    axes[1].plot(p, [s["bend_angle_deg"] for s in steps], "o-", ms=3)
    axes[1].axhline(360, color="grey", ls=":", lw=1)
    if full_bend_kpa is not None:
        axes[1].axvline(full_bend_kpa, color="red", ls="--", lw=1, label=f"full bend {full_bend_kpa:.1f} kPa")
        axes[1].legend(fontsize=8)
    axes[1].set_xlabel("pressure (kPa)")
    axes[1].set_ylabel("bend angle (deg)")
    axes[1].set_title("bend angle")
    v0 = steps[0]["cavity_volume_ml"] if steps else 0.0
    axes[2].plot([s["cavity_volume_ml"] - v0 for s in steps], p, "o-", ms=3)
    axes[2].set_xlabel("volume change (mL)")
    axes[2].set_ylabel("pressure (kPa)")
    axes[2].set_title("pressure-volume")
    for a in axes:
        a.grid(alpha=0.3)
    if ax is None:
        fig.suptitle(title)
    if path is not None:
        save_figure(fig, path)
    return fig


def plot_simulation(doc: dict[str, Any], path: str | Path | None = None, *, ax: Any = None) -> Figure:
    """A ``pnmold.simulation/1`` document's curve: the tip's path and the bend angle against pressure
    (bending), pressure against the volume (pv) or the force against pressure (force).

    Parameters
    ----------
    doc : the document (:attr:`pnmold.simulate.Simulation.doc`).
    path : also save the figure there (atomically).
    ax : the axes to draw on (two for bending, one otherwise); default a new figure.
    """
    steps, kind = doc["steps"], doc["kind"]
    fig, grid = figure_axes(ax, (1, 2 if kind == "bending" else 1), (10 if kind == "bending" else 5, 4))
    axes = grid[0]
    p = [s["pressure_kpa"] for s in steps]
    if kind == "bending":
        axes[0].plot([s["tip_x_mm"] for s in steps], [s["tip_z_mm"] for s in steps], "o-", ms=3)
        axes[0].set_aspect("equal")
        axes[0].set(xlabel="tip x (mm)", ylabel="tip z (mm)", title="tip path")
        axes[1].plot(p, [s["bend_angle_deg"] for s in steps], "o-", ms=3)
        axes[1].set(xlabel="pressure (kPa)", ylabel="bend angle (deg)", title="bend angle")
    elif kind == "pv":
        v = [s.get("volume_ml", s["cavity_volume_ml"] - steps[0]["cavity_volume_ml"]) for s in steps]
        axes[0].plot(v, p, "o-", ms=3)
        axes[0].set(xlabel="volume (mL)", ylabel="pressure (kPa)", title="pressure-volume")
    else:
        axes[0].plot(p, [s["force_n"] for s in steps], "o-", ms=3)
        axes[0].set(xlabel="pressure (kPa)", ylabel="blocked force (N)", title="blocked force")
    for a in axes:
        a.grid(alpha=0.3)
    if ax is None:
        fig.suptitle(f"{doc['design']['name']}: {doc['model']} {kind}, {doc['orientation']}")
    if path is not None:
        save_figure(fig, path)
    return fig
