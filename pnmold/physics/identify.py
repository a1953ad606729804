"""Pure identification from FE shapes: the bottom line's hinges and their bending compliance.

The characterisation's probe (the free run again with a little gravity, chambers up) bends
every hinge of the bottom line a little more than the free run; that extra rotation over
the moment of the weight about the hinge is the hinge's compliance (see
:mod:`pnmold.physics.characterise`). Arrays in, arrays out: no FE, no files.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pnmold.design import Design
from pnmold.physics.rod import moments, node_positions


def chamber_bounds_mm(design: Design) -> np.ndarray:
    """x of the chamber pitches' ends along the bottom face: 0, the proximal chamber's end, then one pitch
    each (the chambers' own bounds, wherever the clamp ends)."""
    xc = design.proximal_end_mm
    n = design.chambers.count
    return np.concatenate([[0.0], xc + design.pitch_mm * np.arange(n - 1), [design.length_mm]])


def bottom_line(nodes_mm: np.ndarray, shapes_mm: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference x of the nodes on y = 0, z = 0, and per step each edge's angle and length."""
    sel = np.flatnonzero((np.abs(nodes_mm[:, 1]) < 1e-6) & (np.abs(nodes_mm[:, 2]) < 1e-6))
    sel = sel[np.argsort(nodes_mm[sel, 0])]
    pos = nodes_mm[sel][None, :, [0, 2]] + np.asarray(shapes_mm)[:, sel][:, :, [0, 2]]
    d = np.diff(pos, axis=1)
    angle = np.unwrap(np.arctan2(-d[..., 1], d[..., 0]), axis=0)
    return nodes_mm[sel, 0].copy(), angle, np.hypot(d[..., 0], d[..., 1])


def identify_compliance(design: Design, x: np.ndarray, free_angle: np.ndarray, probe_angle: np.ndarray,
                        probe_length: np.ndarray, probe_g: float, bandwidth_steps: float = 1.5) -> np.ndarray:
    """(S, K) hinge compliance from the probe's extra hinge rotations over the free ones; ``probe_g``: the
    probe's gravity along -z in g (chambers up; negative: along +z, chambers down)."""
    from pnmold.physics.section import rod_loads

    loads = rod_loads(design, x)
    s_all, k = free_angle.shape
    s = probe_angle.shape[0]
    dh = np.diff(probe_angle, axis=1, prepend=0.0) - np.diff(free_angle[:s], axis=1, prepend=0.0)
    nodes = node_positions(probe_angle, probe_length)
    m, _ = moments(nodes, probe_angle, loads, (0.0, -probe_g), np.zeros(s))
    span = np.diff(x)
    trib = (np.concatenate([[0.0], span[:-1]]) + span) / 2
    a = m * trib
    j = np.arange(s)
    w = np.exp(-0.5 * ((j[:, None] - j[None, :]) / bandwidth_steps) ** 2)
    num, den = w @ (dh * a), w @ (a * a)
    bounds = chamber_bounds_mm(design)
    free_hinge = x[:-1] >= design.clamp_end_mm - 1e-6
    seg = np.clip(np.searchsorted(bounds, x[:-1], side="right") - 1, 0, len(bounds) - 2)
    onehot = (seg[:, None] == np.arange(len(bounds) - 1)[None, :]) & free_hinge[:, None]
    num_seg, den_seg = num @ onehot, den @ onehot
    ok = den_seg > 1e-3 * np.median(den_seg[:, den_seg.max(axis=0) > 0], axis=1, keepdims=True)
    c_seg = np.where(ok, num_seg / np.where(ok, den_seg, 1.0), np.nan)
    for i in range(1, c_seg.shape[1]):  # a segment without a moment borrows its proximal neighbour's value
        c_seg[:, i] = np.where(np.isnan(c_seg[:, i]), c_seg[:, i - 1], c_seg[:, i])
    c_seg = np.nan_to_num(c_seg, nan=0.0)
    lam = 0.1 * den[:, free_hinge].mean(axis=1, keepdims=True)
    per_length = np.clip((num + lam * c_seg[:, seg]) / (den + lam), 0.0, None)
    out = np.where(free_hinge[None, :], per_length * trib[None, :], 0.0)
    if s < s_all:  # the probe stopped early: keep its last compliance
        out = np.vstack([out, np.repeat(out[-1:], s_all - s, axis=0)])
    return out
