"""The step response figure: pressures, flow and bend angle against time."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from pnmold.conventions import FULL_BEND_DEG
from pnmold.plots import figure_axes, save_figure
from pnmold.pneumatics.dynamics import StepResponse


def plot_step(response: StepResponse, title: str, path: str | Path | None = None, *,
              ax: Sequence[Any] | None = None) -> Figure:
    """Three panels sharing the time axis (ms): pressures, flow, bend angle.

    ``ax``: three axes to draw on (default a new figure); ``path``: also save the figure there
    (atomically). Returns the figure.
    """
    s = response.series
    t_ms = s["time_s"] * 1000
    fig, grid = figure_axes(ax, (3, 1), (8, 9), sharex=True)
    axes = grid[:, 0]
    top = axes[0]
    top.plot(t_ms, s["supply_kpa"], "k:", lw=1, label="supply")
    top.plot(t_ms, s["pressure_kpa"], lw=1.6, label="inlet")
    top.plot(t_ms, s["pressure_near_kpa"], lw=1.2, label="chamber 1 (near)")
    top.plot(t_ms, s["pressure_far_kpa"], lw=1.2, label=f"chamber {response.chamber_pressure_kpa.shape[1]} (far)")
    end = response.info.get("law_end")
    if end:  # the chamber law is known up to the FE's last solved step: no chamber passes it
        top.axhline(end["pressure_kpa"], color="grey", ls="--", lw=0.8,
                    label=f"FE's last step ({end['stop'].replace('_', ' ')})")
    top.set_ylabel("pressure (kPa, gauge)")
    top.legend(fontsize=8)
    axes[1].plot(t_ms, s["flow_slpm"], lw=1.4)
    axes[1].set_ylabel("flow (SLPM, at the valves)")
    axes[2].plot(t_ms, s["bend_angle_deg"], lw=1.6)
    axes[2].axhline(FULL_BEND_DEG, color="grey", ls=":", lw=1)
    tfb = response.time_to_full_bend_s
    if tfb is not None:
        for a in axes:
            a.axvline(tfb * 1000, color="red", ls="--", lw=1)
        axes[2].annotate(f"full bend {tfb * 1000:.1f} ms", (tfb * 1000, FULL_BEND_DEG), fontsize=8, color="red",
                         xytext=(5, -15), textcoords="offset points")
    axes[2].set_ylabel("bend angle (deg)")
    axes[2].set_xlabel("time (ms)")
    for a in axes:
        a.grid(alpha=0.3)
    axes[0].set_title(title, fontsize=10)
    if path is not None:
        save_figure(fig, path)
    return fig
