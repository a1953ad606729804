"""Part volumes written out from the design's parameters alone (no CAD), for golden tests."""

from __future__ import annotations

import math

from pnmold.design import Design


def _strip_of_circle(r: float, lo: float, hi: float) -> float:
    """Area of a circle of radius r (centre 0) between heights lo and hi."""
    def f(t: float) -> float:
        t = max(-r, min(r, t))
        return t * math.sqrt(r * r - t * t) + r * r * math.asin(t / r)
    return f(hi) - f(lo)


def chambers_mm3(d: Design) -> float:
    c = d.chambers
    return c.count * c.length_mm * c.width_mm * c.height_mm


def channel_outside_chambers_mm3(d: Design) -> float:
    x0, x1 = d.channel_x_mm
    return d.channel.width_mm * d.channel.height_mm * (x1 - x0 - d.chambers.count * d.chambers.length_mm)


def gaps_mm3(d: Design) -> float:
    if d.kind != "fpn":
        return 0.0
    return (d.chambers.count - 1) * d.chambers.gap_mm * d.width_mm * (d.top_height_mm - d.top_layer.floor_mm)


def stops_mm3(d: Design) -> float:
    """The four L-shaped paper stops, rising a seat's height above the sheet's depth (none without paper)."""
    m = d.mold
    h = d.paper.depth_mm + m.seat_height_mm if d.paper.present else 0.0
    return 4 * h * (m.seat_width_mm ** 2 + 2 * m.seat_width_mm * m.seat_arm_mm)


def bore_parts_mm3(d: Design) -> tuple[float, float]:
    """(bore volume inside solid elastomer, bore volume beyond the channel's start).

    Assumes the channel is at least as wide as the bore (true for the templates)."""
    r = d.inlet.diameter_mm / 2
    area = math.pi * r * r
    zc = d.inlet_axis_z_mm
    lo, hi = d.top_z0_mm - zc, d.top_z0_mm + d.channel.height_mm - zc
    in_channel = _strip_of_circle(r, lo, hi)
    x_start = d.channel_x_mm[0]
    tail = d.inlet_depth_mm - x_start
    return area * x_start + (area - in_channel) * tail, (area - in_channel) * tail


def cavity_mm3(d: Design) -> float:
    """Chambers + channel + the bore's tail past the channel's start (inlet sealed)."""
    return chambers_mm3(d) + channel_outside_chambers_mm3(d) + bore_parts_mm3(d)[1]


def part_volumes_mm3(d: Design) -> dict[str, float]:
    L, W, Ht, z0 = d.length_mm, d.width_mm, d.top_height_mm, d.top_z0_mm
    m, tb = d.mold, d.bottom_layer.thickness_mm
    cores = chambers_mm3(d) + channel_outside_chambers_mm3(d)
    top = L * W * Ht - gaps_mm3(d) - cores
    bottom = L * W * tb - stops_mm3(d)
    px, py = d.paper_size_mm
    s, c = m.ledge_mm, m.clearance_mm
    R, r = s + c + m.wall_mm, s + c
    zb = z0 - m.plate_mm - m.pour_allowance_mm
    zt = z0 + Ht + m.wall_mm
    exterior = ((L + 2 * R) * (W + 2 * R) * (zt - zb) - L * W * Ht
                - (L + 2 * r) * (W + 2 * r) * (z0 - zb) + gaps_mm3(d))
    interior = (L + 2 * s) * (W + 2 * s) * m.plate_mm + cores
    h = tb + m.pour_allowance_mm
    bottom_mold = (L + 2 * m.wall_mm) * (W + 2 * m.wall_mm) * (m.wall_mm + h) - L * W * h + stops_mm3(d)
    volumes = {
        "actuator": top + bottom - bore_parts_mm3(d)[0],
        "top_layer": top, "bottom_layer": bottom, "paper": px * py * d.paper.thickness_mm,
        "mold_interior": interior, "mold_exterior": exterior, "mold_bottom": bottom_mold,
    }
    if d.passive_side.present:  # the top layer again, its own bore punched; the bond coat fills the stops
        volumes["passive_layer"] = top
        volumes["actuator"] += top + stops_mm3(d) - bore_parts_mm3(d)[0]
    return volumes
