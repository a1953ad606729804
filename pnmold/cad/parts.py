"""The cast parts in the actuator frame: top layer, bottom layer, paper, bonded actuator.

Top layer: each chamber is a block with its own walls (fPN) or one block with shared
walls (sPN); the cavities open downward onto the bottom layer, and the 1 mm channel runs
along y = 0 at the bottom, from halfway into the proximal end wall to the last cavity.
Bottom layer: a slab whose underside carries the dimples of the mold's paper stops; the
paper lies flush on the mold floor (z = 0) inside it, or ``paper.depth_mm`` above it on a first
pour of rubber (the stops then rise that much higher to locate its corners there). Actuator: both layers bonded, with
the inlet punched along +x from the end face into the channel. Passive layer (a design with a passive
side, ``[passive_side]``): the top layer mirrored about the bottom layer's mid-plane, under it, with
its own inlet punched (vented); the bottom layer, the paper and their stops then sit that much higher.
"""

from __future__ import annotations

import cadquery as cq

from pnmold.cad.shapes import box, cut, cylinder_x, fuse
from pnmold.design import Design


def _y(design: Design, half: float | None = None) -> tuple[float, float]:
    w = design.width_mm / 2 if half is None else half
    return -w, w


def chamber_cores(design: Design) -> list[cq.Shape]:
    """The air cavities of the chambers (positive boxes), proximal first."""
    return [box(f"chamber {i + 1} cavity", *ranges) for i, ranges in enumerate(design.chamber_boxes_mm)]


def channel_core(design: Design) -> cq.Shape:
    return box("channel", *design.channel_box_mm)


def inlet_bore(design: Design) -> cq.Shape:
    """The 2 mm biopsy punch: from outside the end face along +x into the channel."""
    r = design.inlet.diameter_mm / 2
    return cylinder_x("inlet bore", r, (-1.0, design.inlet_depth_mm), 0.0, design.inlet_axis_z_mm)


def mirrored(design: Design, shape: cq.Shape) -> cq.Shape:
    """``shape`` mirrored about the bottom layer's mid-plane: the top layer's features on the passive side."""
    return shape.mirror("XY", (0.0, 0.0, design.mid_plane_z_mm))


def top_layer_envelope(design: Design) -> cq.Shape:
    """The box the top layer is cast in (the casting region of the top-layer molds)."""
    z0 = design.top_z0_mm
    return box("top layer envelope", (0.0, design.length_mm), _y(design),
               (z0, z0 + design.top_height_mm))


def gap_plates(design: Design) -> list[cq.Shape]:
    """fPN: the empty gaps between chambers above the floor (the exterior mold's plates)."""
    if design.kind != "fpn":
        return []
    z0 = design.top_z0_mm + design.top_layer.floor_mm
    z1 = design.top_z0_mm + design.top_height_mm
    return [box(f"plate {i + 1}", design.gap_x_mm(i), _y(design), (z0, z1))
            for i in range(design.chambers.count - 1)]


def top_layer(design: Design) -> cq.Shape:
    solid = cut("top layer", top_layer_envelope(design), gap_plates(design))
    return cut("top layer cavities", solid, [*chamber_cores(design), channel_core(design)])


def paper_seat_stops(design: Design) -> list[cq.Shape]:
    """L-shaped corner stops on the bottom mold's floor that locate the paper sheet (none without one)."""
    if not design.paper.present:
        return []
    m, p = design.mold, design.paper
    px, py = design.paper_size_mm
    x0, y0, h, w, a = p.inset_mm, -py / 2, design.seat_top_mm, m.seat_width_mm, m.seat_arm_mm
    stops = []
    z0 = design.bottom_z0_mm
    for sx in (0, 1):
        for sy in (0, 1):
            cx = x0 + sx * px  # paper corner
            cy = y0 + sy * py
            ox = (cx - w, cx) if sx == 0 else (cx, cx + w)  # outside the paper in x
            oy = (cy - w, cy) if sy == 0 else (cy, cy + w)
            ax = (cx - w, cx + a) if sx == 0 else (cx - a, cx + w)
            ay = (cy - w, cy + a) if sy == 0 else (cy - a, cy + w)
            stops.append(fuse(f"paper stop {2 * sx + sy + 1}", [
                box("paper stop arm x", ax, oy, (z0, z0 + h)),
                box("paper stop arm y", ox, ay, (z0, z0 + h))]))
    return stops


def bottom_layer(design: Design) -> cq.Shape:
    slab = box("bottom layer", (0.0, design.length_mm), _y(design), (design.bottom_z0_mm, design.top_z0_mm))
    stops = paper_seat_stops(design)
    return cut("bottom layer stops", slab, stops) if stops else slab


def paper(design: Design) -> cq.Shape:
    px, py = design.paper_size_mm
    z0 = design.sheet_z_mm
    return box("paper", (design.paper.inset_mm, design.paper.inset_mm + px), (-py / 2, py / 2),
               (z0, z0 + design.paper.thickness_mm))


def passive_layer(design: Design, top: cq.Shape) -> cq.Shape | None:
    """The passive side: the top layer as cast, turned over under the bottom layer (None without one)."""
    return mirrored(design, top) if design.passive_side.present else None


def actuator(design: Design, top: cq.Shape, bottom: cq.Shape, passive: cq.Shape | None = None) -> cq.Shape:
    """The bonded layers with the inlet punched (and the passive side's, which vents it). Under a passive
    side the paper stops' dimples in the bottom layer's face are filled by the coat that bonds it."""
    lower = [passive, *paper_seat_stops(design)] if passive is not None else []
    bonded = fuse("bonded actuator", [top, bottom, *lower])
    bores = [inlet_bore(design), *([mirrored(design, inlet_bore(design))] if passive is not None else [])]
    return cut("inlet punch", bonded, bores)
