"""Cross-sections of the actuator along x, from the design's layout (no CAD, no mesh).

The body is boxes (``pnmold.cad.parts``): the bottom layer (z_b <= z <= z0) under the top
layer's envelope (z0 <= z <= z0 + top height), less the fPN gaps above the floor, the
chamber cavities and the channel; a passive side (0 <= z <= z_b, else z_b = 0) is the top layer
mirrored about the bottom layer's mid-plane, its cavities unpressurised. The paper and the
inlet bore are ignored (together
0.2 % of the volume of the templates: 16 817 mm^3 here against 16 789 mm^3 exported for
the fPN). Per unit length at x: area, first and second moments about the bottom face
(z = 0, the paper), and the same for the cavity and for the top layer's material.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pnmold.design import Design

#: sampling step of the piecewise-constant section functions, mm (the smallest feature is 1 mm)
_DX_MM = 0.02


@dataclass(frozen=True, eq=False)
class Sections:
    """Section properties sampled at ``x_mm`` (arrays of the same length)."""

    x_mm: np.ndarray
    area_mm2: np.ndarray  # elastomer
    first_moment_mm3: np.ndarray  # int z dA about z = 0
    second_moment_mm4: np.ndarray  # int z^2 dA about z = 0 (bending about the paper)
    cavity_area_mm2: np.ndarray  # air: chambers and channel
    cavity_moment_mm3: np.ndarray
    top_area_mm2: np.ndarray  # elastomer of the top layer's rubber: the top layer and a passive side
    top_moment_mm3: np.ndarray


def _band(z_a: float, z_b: float) -> tuple[float, float, float]:
    """Per unit width: area, first and second moments of the band z_a <= z <= z_b."""
    return z_b - z_a, (z_b ** 2 - z_a ** 2) / 2, (z_b ** 3 - z_a ** 3) / 3


def sections(design: Design, x_mm: np.ndarray | None = None) -> Sections:
    """Section properties of ``design`` at ``x_mm`` (default: every 0.02 mm over [0, L])."""
    L, W = design.length_mm, design.width_mm
    x = np.arange(_DX_MM / 2, L, _DX_MM) if x_mm is None else np.asarray(x_mm, float)
    z0, top = design.top_z0_mm, design.top_height_mm
    c = design.chambers
    inside = ((x >= 0) & (x <= L)).astype(float)
    bottom = np.array(_band(design.bottom_z0_mm, z0)) * W
    top_full = np.array(_band(z0, z0 + top)) * W
    removed = np.zeros((3, x.size))
    cavity = np.zeros((3, x.size))
    if design.kind == "fpn":
        for i in range(c.count - 1):
            a, b = design.gap_x_mm(i)
            m = (x > a) & (x < b)
            removed[:, m] += np.array(_band(z0 + design.top_layer.floor_mm, z0 + top))[:, None] * W
    in_cavity = np.zeros(x.size, bool)
    chamber = np.array(_band(z0, z0 + c.height_mm)) * c.width_mm
    for i in range(c.count):
        a, b = design.cavity_x_mm(i)
        m = (x > a) & (x < b)
        in_cavity |= m
        cavity[:, m] += chamber[:, None]
    a, b = design.channel_x_mm
    m = (x > a) & (x < b) & ~in_cavity
    cavity[:, m] += np.array(_band(z0, z0 + design.channel.height_mm))[:, None] * design.channel.width_mm
    top_part = (top_full[:, None] - removed - cavity) * inside
    if design.passive_side.present:  # z -> 2 zm - z: A, 2 zm A - Q, 4 zm^2 A - 4 zm Q + I
        zm = design.mid_plane_z_mm
        a, q, i2 = top_part
        top_part = top_part + np.array([a, 2 * zm * a - q, 4 * zm ** 2 * a - 4 * zm * q + i2])
    total = bottom[:, None] * inside + top_part
    return Sections(x, total[0], total[1], total[2], cavity[0] * inside, cavity[1] * inside,
                    top_part[0], top_part[1])


def interval_integrals(design: Design, edges_mm: np.ndarray) -> dict[str, np.ndarray]:
    """Integrals over the intervals [edges[k], edges[k+1]] of the section properties.

    Returns ``volume_mm3``, ``x_moment_mm4`` (int x dV), ``z_moment_mm4`` (int z dV),
    ``cavity_mm3``, ``cavity_z_mm4``, ``top_mm3``, ``top_z_mm4`` and ``flexibility``
    (int dx / I(x), 1/mm^3) per interval."""
    s = sections(design)
    edges = np.asarray(edges_mm, float)
    idx = np.clip(np.searchsorted(edges, s.x_mm, side="right") - 1, 0, len(edges) - 2)
    n = len(edges) - 1

    def total(values: np.ndarray) -> np.ndarray:
        return np.bincount(idx, weights=values * _DX_MM, minlength=n)

    with np.errstate(divide="ignore"):
        flex = np.where(s.second_moment_mm4 > 0, 1.0 / s.second_moment_mm4, 0.0)
    return {"volume_mm3": total(s.area_mm2), "x_moment_mm4": total(s.area_mm2 * s.x_mm),
            "z_moment_mm4": total(s.first_moment_mm3), "cavity_mm3": total(s.cavity_area_mm2),
            "cavity_z_mm4": total(s.cavity_moment_mm3), "top_mm3": total(s.top_area_mm2),
            "top_z_mm4": total(s.top_moment_mm3), "flexibility": total(flex)}


def rod_loads(design: Design, nodes_x_mm: np.ndarray):
    """Weight per g (N), load point (fraction along, height above) of each rod edge between nodes."""
    from pnmold.fem.material import G_STANDARD_N_PER_MM3_PER_G_PER_ML
    from pnmold.physics.rod import RodLoads

    x = np.asarray(nodes_x_mm, float)
    got = interval_integrals(design, x)
    vol = np.maximum(got["volume_mm3"], 1e-12)
    span = np.diff(x)
    frac = np.clip((got["x_moment_mm4"] / vol - x[:-1]) / span, 0.0, 1.0)
    top, bottom = design.material.density_g_per_ml, design.bottom_material.density_g_per_ml
    mass = top * got["top_mm3"] + bottom * (got["volume_mm3"] - got["top_mm3"])  # g/mL x mm^3
    z_mass = top * got["top_z_mm4"] + bottom * (got["z_moment_mm4"] - got["top_z_mm4"])
    return RodLoads(mass * G_STANDARD_N_PER_MM3_PER_G_PER_ML, frac, z_mass / np.maximum(mass, 1e-12))


def slab_flexibility(design: Design, nodes_x_mm: np.ndarray) -> np.ndarray:
    """Beam estimate of each edge's bending compliance (rad per N mm): the continuous slab under the
    chambers (bottom layer, and the fPN floor) bent about the paper, E = 6 C10; the chambers' thin
    walls are taken to add nothing (they shear)."""
    z = design.top_z0_mm + (design.top_layer.floor_mm if design.kind == "fpn" else 0.0)
    ei = 6.0 * design.material.c10_mpa * design.width_mm * z ** 3 / 3.0
    return np.diff(np.asarray(nodes_x_mm, float)) / ei
