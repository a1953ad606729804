"""The figure of a one-axis sweep: full-bend pressure against the varied field (like the
supplement's Fig. S2 A-C), points without a full bend marked as such."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from pnmold.errors import UsageError
from pnmold.sweep.spec import SweepSpec

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def plot_sweep(spec: SweepSpec, rows: list[dict[str, Any]], path: str | Path | None = None, *,
               ax: Any = None) -> Figure:
    """Full-bend pressure (kPa) against the sweep's one axis.

    Points that built but did not bend fully (pressure limit reached, or the solver stopped)
    are drawn at the top edge as open triangles labelled with the highest pressure solved;
    refused or failed points as crosses on the axis. ``ax``: the axes to draw on (default a
    new figure); ``path``: also save the figure there (atomically). Returns the figure."""
    from pnmold.plots import figure_axes, save_figure

    if len(spec.axes) != 1:
        raise UsageError(f"plot_sweep needs a one-axis sweep, {spec.name} has {len(spec.axes)}")
    field = spec.axes[0].field
    bent = sorted((r[field], r["full_bend_pressure_kpa"]) for r in rows if r["full_bend_pressure_kpa"] is not None)
    unbent = sorted((r[field], r["fem_max_pressure_kpa"]) for r in rows
                    if r["status"] == "ok" and r["full_bend_pressure_kpa"] is None)
    lost = sorted(r[field] for r in rows if r["status"] in ("refused", "failed", "check_failed"))
    fig, grid = figure_axes(ax, (1, 1), (6.0, 4.2))
    ax = grid[0, 0]
    if bent:
        ax.plot([x for x, _ in bent], [y for _, y in bent], "o-", color="C0", label="full bend (FE)")
    top = max([y for _, y in bent] + [y or 0.0 for _, y in unbent] + [spec.run.max_pressure_kpa or 0.0, 1.0])
    if unbent:
        ax.plot([x for x, _ in unbent], [top * 1.05] * len(unbent), "^", mfc="none", color="C3", ms=9,
                label="no full bend (FE stopped at the pressure shown)")
        for x, p in unbent:
            if p is not None:
                ax.annotate(f"{p:.0f} kPa", (x, top * 1.05), textcoords="offset points", xytext=(0, -14),
                            ha="center", fontsize=8, color="C3")
    if lost:
        ax.plot(lost, [0.0] * len(lost), "x", color="0.4", ms=9, label="refused or failed")
    ax.set_xlabel(field)
    ax.set_ylabel("full-bend pressure (kPa)")
    ax.set_ylim(0, top * 1.15)
    run = spec.run
    mesh = f", FE mesh {run.wall_mm or 'default'}/{run.max_mm or 'default'} mm" if run.fem else ""
    ax.set_title(f"{spec.name}: base {spec.base.stem}{mesh}", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    if path is not None:
        save_figure(fig, path)
    return fig
