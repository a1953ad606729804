"""The three ABS molds, in casting position in the actuator frame.

Interior mold: a plate under the top layer carrying the chamber cavities and the channel
as positive features. Exterior mold: a box over the top layer whose plates fill the fPN
gaps (no two chambers share a wall); below the top layer it opens into a recess, wider by
the registration ledge plus the clearance, that the interior plate slides into until it
seats against the ledge at the top layer's base: that fixes the chambers' depth. The rim
reaches past the plate by the pour allowance. Bottom mold: a tray whose pocket is the
bottom layer, with L-shaped stops on its floor that locate the paper, and a rim rising by
the pour allowance where the top layer is set into the uncured bottom layer. A passive side
(``[passive_side]``) is a second top layer from the same two molds, bonded under the bottom layer.
For pouring, the exterior mold is turned over (ceiling down) and the interior mold is
pressed in from above; every mold prints flat on its largest face without supports.
"""

from __future__ import annotations

import cadquery as cq

from pnmold.cad.parts import (
    chamber_cores,
    channel_core,
    gap_plates,
    paper_seat_stops,
    top_layer_envelope,
)
from pnmold.cad.shapes import box, cut, fuse
from pnmold.design import Design


def _sym(half: float) -> tuple[float, float]:
    return -half, half


def interior_mold(design: Design) -> cq.Shape:
    m, z0 = design.mold, design.top_z0_mm
    plate = box("interior mold plate", (-m.ledge_mm, design.length_mm + m.ledge_mm),
                _sym(design.width_mm / 2 + m.ledge_mm), (z0 - m.plate_mm, z0))
    return fuse("interior mold", [plate, *chamber_cores(design), channel_core(design)])


def exterior_mold(design: Design) -> cq.Shape:
    m, z0 = design.mold, design.top_z0_mm
    recess = m.ledge_mm + m.clearance_mm
    rim = recess + m.wall_mm
    z_bottom = z0 - m.plate_mm - m.pour_allowance_mm
    z_top = z0 + design.top_height_mm + m.wall_mm
    outer = box("exterior mold", (-rim, design.length_mm + rim), _sym(design.width_mm / 2 + rim),
                (z_bottom, z_top))
    pocket = box("exterior mold recess", (-recess, design.length_mm + recess),
                 _sym(design.width_mm / 2 + recess), (z_bottom - 1.0, z0))
    shell = cut("exterior mold cavity", outer, [top_layer_envelope(design), pocket])
    plates = gap_plates(design)
    return fuse("exterior mold plates", [shell, *plates]) if plates else shell


def bottom_mold(design: Design) -> cq.Shape:
    """The tray, its floor under the bottom layer (above the passive side, in a design with one)."""
    m = design.mold
    z0, z1 = design.bottom_z0_mm, design.top_z0_mm
    outer = box("bottom mold", (-m.wall_mm, design.length_mm + m.wall_mm),
                _sym(design.width_mm / 2 + m.wall_mm), (z0 - m.wall_mm, z1 + m.pour_allowance_mm))
    pocket = box("bottom mold pocket", (0.0, design.length_mm), _sym(design.width_mm / 2),
                 (z0, z1 + m.pour_allowance_mm + 1.0))
    tray = cut("bottom mold pocket", outer, [pocket])
    stops = paper_seat_stops(design)
    return fuse("bottom mold paper seat", [tray, *stops]) if stops else tray
