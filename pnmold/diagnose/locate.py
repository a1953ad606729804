"""Where the calibrated baseline misses: observable, pressure (time, or the volume a rig set) window, cycle, phase.

The baseline's z-scores (residual / noise) of each series are scanned with windows of
contiguous pressure (or time) within each cycle and phase; a window's significance is its
excess chi-square in standard deviations, ``(sum z^2 - m) / sqrt(2 m)``. The strongest
windows that do not overlap are reported, strongest first.
"""

from __future__ import annotations

import numpy as np

from pnmold.physics.protocol import read_by_volume

from .data import DataSet

#: window widths tried, as a share of the series' pressure (or time) span
WIDTHS = (0.15, 0.3, 0.5, 1.0)
SIGNIFICANT = 4.0  # standard deviations


def _axis(data: DataSet, i: int) -> tuple[str, str, np.ndarray]:
    rec = data.recordings[i]
    if rec.kind == "step":
        return "time_s", "s", np.asarray(rec.columns["time_s"], float)
    if read_by_volume(rec):  # the rig set the volume: its rows are where they are by their volume
        return "volume_ml", "mL", np.asarray(rec.columns["volume_ml"], float)
    return "pressure_kpa", "kPa", np.asarray(rec.columns["pressure_kpa"], float)


def _groups(data: DataSet, i: int) -> list[tuple[dict, np.ndarray]]:
    """(labels, row mask) per cycle and phase of recording ``i`` (one group when absent)."""
    rec = data.recordings[i]
    n = len(rec)
    cycle = rec.columns.get("cycle")
    phase = rec.columns.get("phase")
    keys = sorted({(None if cycle is None else int(cycle[r]), None if phase is None else str(phase[r]))
                   for r in range(n)}, key=lambda k: (k[0] or 0, k[1] or ""))
    out = []
    for c, ph in keys:
        mask = np.ones(n, bool)
        labels = {}
        if c is not None:
            mask &= cycle == c
            labels["cycle"] = c
        if ph is not None:
            mask &= phase == ph
            labels["phase"] = ph
        out.append((labels, mask))
    return out


def locate(data: DataSet, z_by_series: list[np.ndarray], limit: int = 3,
           residuals: list[np.ndarray] | None = None) -> list[dict]:
    """The strongest non-overlapping windows of misfit, as ``mismatch`` entries (docs/json-schemas.md). ``residuals``:
    per series, measured minus predicted in the observable's units, said as the window's mean (default z x
    noise; a row out of the model's reach has a z-score beyond its residual, see :func:`.fitting.zscores`)."""
    found = []
    residuals = residuals or [z * s.sigma for s, z in zip(data.series, z_by_series, strict=True)]
    for s, z, res in zip(data.series, z_by_series, residuals, strict=True):
        axis, unit, x = _axis(data, s.recording)
        x = x[s.rows]  # the rows the series kept
        span = float(np.ptp(x)) or 1.0
        for labels, mask in _groups(data, s.recording):
            idx = np.where(mask[s.rows])[0]
            if idx.size == 0:
                continue
            for width in WIDTHS:
                for lo in np.arange(x[idx].min(), x[idx].max() + 1e-9, max(width * span / 3, 1e-9)):
                    sel = idx[(x[idx] >= lo) & (x[idx] <= lo + width * span)]
                    if sel.size < 3:
                        continue
                    chi2 = float(np.sum(z[sel] ** 2))
                    sig = (chi2 - sel.size) / np.sqrt(2.0 * sel.size)
                    mean = float(np.mean(res[sel]))
                    found.append((sig, s, axis, unit, float(x[sel].min()), float(x[sel].max()), labels, mean))
    found.sort(key=lambda f: -f[0])
    out: list[dict] = []
    for sig, s, axis, unit, a, b, labels, mean in found:
        if sig < SIGNIFICANT or len(out) >= limit:
            break
        if any(o["observable"] == s.observable and o["_rec"] == s.recording and o["_labels"] == labels
               and not (b < o["window"][axis][0] or a > o["window"][axis][1]) for o in out):
            continue
        where = ", ".join(f"{k} {v}" for k, v in labels.items())
        out.append({
            "observable": s.observable,
            "window": {axis: [round(a, 4), round(b, 4)], **labels},
            "significance": round(float(sig), 2),
            "description": (f"{s.observable} measured {'above' if mean > 0 else 'below'} the calibrated model by "
                            f"{abs(mean):.3g} on average for {axis.split('_')[0]} {a:.4g}-{b:.4g} {unit}"
                            f"{' (' + where + ')' if where else ''} in {data.recordings[s.recording].path}; "
                            f"{sig:.1f} standard deviations beyond the noise ({s.level:.2g})"),
            "_rec": s.recording, "_labels": labels,
        })
    for o in out:
        del o["_rec"], o["_labels"]
    return out
