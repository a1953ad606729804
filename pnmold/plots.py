"""Figures a person looks at (matplotlib, Agg): the bending figure of a build."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pnmold.fsutil import atomic_path  # noqa: E402


def save_figure(fig, path: str | Path, dpi: int = 120) -> Path:
    """Save atomically (temporary name, then rename) and close the figure."""
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi, bbox_inches="tight")
    finally:
        plt.close(fig)
    return Path(path)


def plot_bending(title: str, steps: list[dict[str, Any]], shapes: list[tuple[float, np.ndarray, np.ndarray]],
                 path: str | Path, full_bend_kpa: float | None = None) -> Path:
    """Deformed shapes and the tip trajectory (like the supplement's Fig. S5 E-F), the
    bend angle against pressure and the pressure-volume curve.

    ``shapes``: (pressure_kpa, bottom_xz, top_xz) polylines in mm; ``steps``: the
    ``fem.steps`` dicts of report.json."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    ax = axes[0]
    cmap = plt.get_cmap("viridis")
    pmax = max((p for p, _, _ in shapes), default=1.0) or 1.0
    for p, bottom, top in shapes:
        colour = cmap(p / pmax)
        ax.plot(bottom[:, 0], bottom[:, 1], "-", color=colour, lw=1.6, label=f"{p:.0f} kPa")
        ax.plot(top[:, 0], top[:, 1], ".", color=colour, ms=1.5)
    tip_x = [s["tip_x_mm"] for s in steps]
    tip_z = [s["tip_z_mm"] for s in steps]
    ax.plot(tip_x, tip_z, "k--", lw=1, label="tip trajectory")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.set_title("deformed shape (y = 0) and tip")
    ax.legend(fontsize=7, loc="best")
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
    fig.suptitle(title)
    return save_figure(fig, path)
