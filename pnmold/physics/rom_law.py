"""The reduced model's free law: the FE's curves on its own pressure grid, read piecewise linearly.

A characterisation (:mod:`.characterisation`) gives, per FE step, each bottom-line edge's angle and
length, the hinges' compliance, the bend angle, the cavity volume and the largest stretch. The
:class:`Tables` hold them on the distinct pressure steps; :func:`interp` reads them at any pressure
(linear between steps, the last slope beyond them unless clamped) and :func:`slope` gives their
slope there. A characterisation from steps only has no rod: :func:`even_rod` spreads its bend evenly
over the free length. Pure functions on arrays, no FE (the model: docs/reduced-model.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pnmold.design import Design
from pnmold.physics.characterisation import Characterisation, distinct_steps
from pnmold.physics.section import slab_flexibility


@dataclass(frozen=True, eq=False)
class Tables:
    """The free law on the FE's pressure grid."""

    p: np.ndarray  # (S,)
    angle: np.ndarray  # (S, K)
    length: np.ndarray  # (S, K)
    compliance: np.ndarray  # (S, K)
    offset_deg: np.ndarray  # (S,) FE bend angle minus the last edge's angle
    volume_ml: np.ndarray  # (S,)
    stretch: np.ndarray  # (S,)
    compliance_down: np.ndarray | None = None  # (S, K) under a weight that opens the bend; None: as ``compliance``
    #: (S, K) each with the layer made compliant by ``layer_mm_per_n`` (the FE's probes); None: not probed
    compliance_layer: np.ndarray | None = None
    compliance_down_layer: np.ndarray | None = None
    layer_mm_per_n: float = 0.0
    #: (S, K) each with the FE's self-contact on (its probes); None: not probed
    compliance_contact: np.ndarray | None = None
    compliance_down_contact: np.ndarray | None = None


def interp(p: np.ndarray, table: np.ndarray, x: np.ndarray, extrapolate: bool = True) -> np.ndarray:
    """Piecewise linear in p (rows of ``table``), the end slopes beyond the ends unless clamped."""
    i = np.clip(np.searchsorted(p, x, side="right") - 1, 0, p.size - 2)
    t = (x - p[i]) / (p[i + 1] - p[i])
    if not extrapolate:
        t = np.clip(t, 0.0, 1.0)
    if table.ndim == 2:
        t = t[:, None]
    return table[i] + t * (table[i + 1] - table[i])


def slope(p: np.ndarray, table: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The slope in p of a 2-D ``table`` at ``x`` (the segment's of :func:`interp`)."""
    i = np.clip(np.searchsorted(p, x, side="right") - 1, 0, p.size - 2)
    return (table[i + 1] - table[i]) / (p[i + 1] - p[i])[:, None]


def rod_of(design: Design, c: Characterisation):
    """The rod of ``c`` (nodes' x, edges' angle, length and compliance per step): the FE's, or else
    :func:`even_rod`."""
    if c.has_rod:
        return c.rod_x_mm, c.rod_angle_rad, c.rod_length_mm, c.compliance_rad_per_n_mm
    return even_rod(design, c)


def free_law(design: Design, c: Characterisation) -> tuple[np.ndarray, Tables]:
    """The rod's nodes' x and the :class:`Tables` of ``c`` on its distinct pressure steps."""
    x, angle, length, comp = rod_of(design, c)
    offset = c.bend_angle_deg - np.degrees(angle[:, -1])
    k = distinct_steps(c.pressure_kpa)
    down = c.compliance_down_rad_per_n_mm if c.has_rod else None
    probed = c.has_rod and c.probe_layer_mm_per_n > 0
    up_layer = c.compliance_layer_rad_per_n_mm if probed else None
    down_layer = c.compliance_down_layer_rad_per_n_mm if probed and down is not None else None
    up_contact = c.compliance_contact_rad_per_n_mm if c.has_rod else None
    down_contact = c.compliance_down_contact_rad_per_n_mm if c.has_rod and down is not None else None
    return x, Tables(c.pressure_kpa[k], angle[k], length[k], comp[k], offset[k], c.cavity_volume_ml[k],
                     c.max_principal_stretch[k], None if down is None else down[k],
                     None if up_layer is None else up_layer[k], None if down_layer is None else down_layer[k],
                     c.probe_layer_mm_per_n, None if up_contact is None else up_contact[k],
                     None if down_contact is None else down_contact[k])


def even_rod(design: Design, c: Characterisation):
    """Rod for a characterisation from steps only: the bend spread evenly over the free length."""
    xc, L = design.clamp_end_mm, design.length_mm
    n = max(4 * (design.chambers.count - 1), 4)
    x = np.concatenate([[0.0], np.linspace(xc, L, n + 1)])
    mid = (x[:-1] + x[1:]) / 2
    frac = np.clip((mid - xc) / (L - xc), 0.0, None) * (mid > xc)
    angle = np.radians(c.bend_angle_deg)[:, None] * frac[None, :]
    length = np.tile(np.diff(x), (len(c.pressure_kpa), 1))
    comp = slab_flexibility(design, x) * (x[:-1] >= xc - 1e-9)
    return x, angle, length, np.tile(comp, (len(c.pressure_kpa), 1))
