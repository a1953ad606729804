"""Cross-field design rules. Each violation raises :class:`DesignError` naming the field.

Rules are checked before any CAD, in order: names and kinds, positive sizes and integer
counts, the elastomer (castable) and ABS (printable) minimum walls, the channel and inlet
geometry, the paper seat, the material, and the printer's build volume.
"""

from __future__ import annotations

import dataclasses
import math
import re

from pnmold.design.model import KINDS, SECTIONS, Design
from pnmold.errors import DesignError

#: assumed: a tube up to 30 % wider than the bore still goes in (the supplement's 3/32" tube
#: in a 2 mm punched hole is 19 % wider)
TUBE_INTERFERENCE_MAX = 0.3

#: assumed: the Yeoh C10 of castable elastomers lies between these (MPa). The library's softest,
#: Ecoflex 00-30, has 0.0082 and Elastosil M4601 0.11 (pnmold/materials/library.py); the softest
#: castable silicones are about half as stiff as Ecoflex 00-30 and the stiffest castable polyurethane
#: rubbers (Shore 90A) about 20 times Elastosil, so the bounds leave a margin of 4 to 5 on each side.
#: A value outside is a typo or a unit slip (kPa for MPa, a Young's modulus of a plastic), not a rubber.
C10_CASTABLE_MPA = (0.001, 10.0)
#: assumed: a density outside this (g/mL) is not a castable elastomer (silicones 1.07-1.5, fillers to ~2)
DENSITY_CASTABLE_G_PER_ML = (0.5, 3.0)

# fields allowed to be zero or negative
_SIGNED = {"inlet.axis_offset_mm"}
_NON_NEGATIVE = {"chambers.tip_wall_mm", "clamp.length_mm", "paper.depth_mm",
                 "material.c20_mpa", "material.c30_mpa", "casting.waste_margin",
                 "chambers.gap_mm",
                 "layer_material.c10_mpa", "layer_material.c20_mpa", "layer_material.c30_mpa",
                 "layer_material.density_g_per_ml", "layer_material.mix_ratio_a_to_b"}


def _need(ok: bool, field: str, message: str) -> None:
    if not ok:
        raise DesignError(field, message)


def _check_numbers(design: Design) -> None:
    for name in SECTIONS:
        section = getattr(design, name)
        for f in dataclasses.fields(section):
            value, where = getattr(section, f.name), f"{name}.{f.name}"
            if isinstance(value, str | bool):
                continue
            _need(math.isfinite(value), where, f"must be a finite number, got {value}")
            if where in _SIGNED:
                continue
            if where in _NON_NEGATIVE:
                _need(value >= 0, where, f"must be zero or positive, got {value}")
            else:
                _need(value > 0, where, f"must be positive, got {value}")


def _check_identity(design: Design) -> None:
    _need(bool(re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", design.name)), "design.name",
          f"must be letters, digits, '-', '_' or '.', got {design.name!r}")
    _need(design.kind in KINDS, "design.kind", f"must be one of {', '.join(KINDS)}, got {design.kind!r}")
    _need(design.chambers.count >= 2, "chambers.count",
          f"needs at least 2 chambers joined by the channel, got {design.chambers.count}")
    _need(design.printer.min_wall_lines >= 1, "printer.min_wall_lines", "must be at least 1")


def _check_elastomer(design: Design) -> None:
    c, lim = design.chambers, design.casting.min_elastomer_wall_mm
    for field, value in (("chambers.inside_wall_mm", c.inside_wall_mm),
                         ("chambers.outer_wall_mm", c.outer_wall_mm),
                         ("chambers.tip_wall_mm", design.tip_wall_mm)):
        _need(value >= lim, field, f"{value} mm is below the castable minimum "
              f"casting.min_elastomer_wall_mm = {lim} mm")
    bottom = design.bottom_layer.thickness_mm - design.seat_top_mm
    _need(bottom >= lim, "bottom_layer.thickness_mm",
          f"leaves {bottom:.3g} mm of elastomer over the paper stops (paper.depth_mm + mold.seat_height_mm); "
          f"needs at least {lim} mm")
    remaining = c.end_wall_mm - design.channel_x_mm[0]
    _need(remaining >= lim, "chambers.end_wall_mm",
          f"leaves {remaining:.3g} mm of elastomer between the channel's end and the chamber; "
          f"needs at least {lim} mm")
    side = (design.width_mm - design.channel.width_mm) / 2
    _need(design.channel.width_mm <= c.width_mm, "channel.width_mm",
          f"{design.channel.width_mm} mm is wider than the chambers ({c.width_mm} mm)")
    _need(side >= lim, "channel.width_mm", f"leaves {side:.3g} mm side walls; needs {lim} mm")
    if design.kind == "fpn":
        roof = design.top_layer.floor_mm - design.channel.height_mm
        _need(roof >= lim, "top_layer.floor_mm",
              f"leaves {roof:.3g} mm of elastomer over the channel under the gaps; needs {lim} mm")
        _need(design.top_layer.floor_mm < c.height_mm, "top_layer.floor_mm",
              f"{design.top_layer.floor_mm} mm must be lower than the chambers ({c.height_mm} mm)")


def _check_printable(design: Design) -> None:
    lim = design.printable_wall_mm
    m = design.mold
    why = (f"the printable minimum (printer.nozzle_mm x printer.min_wall_lines = {lim:.3g} mm)")
    if design.kind == "fpn":
        _need(design.chambers.gap_mm >= lim, "chambers.gap_mm",
              f"{design.chambers.gap_mm} mm exterior-mold plates are thinner than {why}")
    for field, value in (("mold.wall_mm", m.wall_mm), ("mold.plate_mm", m.plate_mm),
                         ("mold.ledge_mm", m.ledge_mm), ("mold.seat_width_mm", m.seat_width_mm)):
        _need(value >= lim, field, f"{value} mm is thinner than {why}")
    _need(m.clearance_mm <= design.casting.min_elastomer_wall_mm, "mold.clearance_mm",
          f"{m.clearance_mm} mm is wider than the thinnest elastomer wall "
          f"(casting.min_elastomer_wall_mm = {design.casting.min_elastomer_wall_mm} mm), which is "
          "all that keeps the interior and exterior molds apart")
    _need(m.clearance_mm < m.ledge_mm, "mold.clearance_mm",
          f"{m.clearance_mm} mm must be smaller than the registration ledge ({m.ledge_mm} mm)")


def _check_proportions(design: Design) -> None:
    c, ch = design.chambers, design.channel
    _need(ch.height_mm < c.height_mm, "channel.height_mm",
          f"the channel ({ch.height_mm} mm) must be lower than the chambers ({c.height_mm} mm)")
    last = design.cavity_x_mm(c.count - 1)[0]
    _need(design.clamp_end_mm <= last, "clamp.length_mm",
          f"{design.clamp.length_mm} mm reaches past x = {last:.4g} mm, where the last chamber begins: "
          "at least one chamber must be free to bend")


def _check_channel_and_inlet(design: Design) -> None:
    c, ch, inlet = design.chambers, design.channel, design.inlet
    r = inlet.diameter_mm / 2
    _need(abs(inlet.axis_offset_mm) < ch.height_mm / 2 + r, "inlet.axis_offset_mm",
          f"{inlet.axis_offset_mm} mm puts the bore beside the channel: it must reach it")
    bottom = design.inlet_axis_z_mm - r
    paper = design.paper.depth_mm + design.paper.thickness_mm if design.paper.present else 0.0
    _need(bottom >= paper + design.casting.min_elastomer_wall_mm,
          "inlet.diameter_mm", f"the bore's bottom at z = {bottom:.3g} mm would cut into the paper "
          f"(needs {design.casting.min_elastomer_wall_mm} mm of elastomer above it)")
    top_limit = design.height_mm - c.outer_wall_mm
    _need(design.inlet_axis_z_mm + r <= top_limit, "inlet.diameter_mm",
          f"the bore's top at z = {design.inlet_axis_z_mm + r:.3g} mm breaks through the roof")
    _need(r + design.casting.min_elastomer_wall_mm <= design.width_mm / 2, "inlet.diameter_mm",
          "the bore is wider than the actuator")
    fit = (inlet.tubing_od_mm - inlet.diameter_mm) / inlet.diameter_mm
    _need(0 < fit <= TUBE_INTERFERENCE_MAX, "inlet.diameter_mm",
          f"the tubing (OD {inlet.tubing_od_mm:.3g} mm) must be slightly larger than the bore to seal "
          f"(0 to {100 * TUBE_INTERFERENCE_MAX:.0f}% larger), it is {100 * fit:.0f}% larger")
    _need(inlet.tubing_id_mm < inlet.tubing_od_mm, "inlet.tubing_id_mm",
          f"{inlet.tubing_id_mm} mm must be smaller than the outer diameter {inlet.tubing_od_mm} mm")


def _check_castable(prefix: str, name: str, c10_mpa: float, density_g_per_ml: float) -> None:
    lo, hi = C10_CASTABLE_MPA
    what = ("softer than any castable elastomer (a value in kPa, or a gel?)" if c10_mpa < lo
            else "stiffer than any castable elastomer (a value in kPa read as MPa, or a Young's modulus of a plastic?)")
    _need(lo <= c10_mpa <= hi, f"{prefix}.c10_mpa", f"{c10_mpa:g} MPa for {name!r} is {what}; castable rubbers "
          f"have a Yeoh C10 of {lo:g} to {hi:g} MPa (Ecoflex 00-30 0.0082, Elastosil M4601 0.11)")
    lo, hi = DENSITY_CASTABLE_G_PER_ML
    _need(lo <= density_g_per_ml <= hi, f"{prefix}.density_g_per_ml",
          f"{density_g_per_ml:g} g/mL for {name!r} is outside castable elastomers' {lo:g} to {hi:g} g/mL")


def _check_layer_material(design: Design) -> None:
    m = design.layer_material
    given = {k: getattr(m, k) for k in ("c10_mpa", "c20_mpa", "c30_mpa", "density_g_per_ml", "mix_ratio_a_to_b")}
    if not m.name:
        for key, value in given.items():
            _need(value == 0, f"layer_material.{key}", f"is {value:g} but layer_material.name is empty (the "
                  "bottom layer is [material]'s rubber); name the layer's rubber to give it constants")
        _need(design.paper.present, "paper.present", "without paper, the bottom layer must be a stiffer rubber "
              "to limit the strain: name it in layer_material.name (a library material or your own)")
        return
    for key in ("c10_mpa", "density_g_per_ml", "mix_ratio_a_to_b"):
        _need(given[key] > 0, f"layer_material.{key}", f"must be positive for {m.name!r}, got {given[key]:g}")
    _check_castable("layer_material", m.name, m.c10_mpa, m.density_g_per_ml)


def _check_paper(design: Design) -> None:
    if not design.paper.present:
        return
    p, m = design.paper, design.mold
    _need(p.thickness_mm <= m.seat_height_mm, "paper.thickness_mm",
          f"{p.thickness_mm} mm is thicker than the corner stops that hold it "
          f"(mold.seat_height_mm = {m.seat_height_mm} mm)")
    lim = design.casting.min_elastomer_wall_mm
    _need(p.inset_mm >= m.seat_width_mm + lim, "paper.inset_mm",
          f"{p.inset_mm} mm leaves no room for the corner stops (mold.seat_width_mm = {m.seat_width_mm} mm) "
          f"and {lim} mm of elastomer outside them")
    px, py = design.paper_size_mm
    room = 2 * m.seat_arm_mm + lim
    _need(px >= room and py >= room, "paper.inset_mm",
          f"leaves a {px:.3g} x {py:.3g} mm sheet, too small for the corner stops "
          f"(mold.seat_arm_mm = {m.seat_arm_mm} mm)")
    _need(p.poisson < 0.5, "paper.poisson", f"must be below 0.5, got {p.poisson}")
    _need(p.depth_mm == 0 or p.depth_mm >= lim, "paper.depth_mm",
          f"{p.depth_mm} mm of rubber below the sheet is thinner than casts reliably "
          f"(casting.min_elastomer_wall_mm = {lim} mm); 0 lays the sheet on the mold floor")


def _check_build_volume(design: Design) -> None:
    pr = design.printer
    bed = sorted((pr.build_x_mm, pr.build_y_mm))
    for part, size in (("exterior", design.exterior_mold_size_mm),
                       ("interior", design.interior_mold_size_mm),
                       ("bottom", design.bottom_mold_size_mm)):
        footprint = sorted(size[:2])
        fits = footprint[0] <= bed[0] and footprint[1] <= bed[1] and size[2] <= pr.build_z_mm
        _need(fits, "printer.build_x_mm",
              f"the {part} mold ({size[0]:.1f} x {size[1]:.1f} x {size[2]:.1f} mm) does not fit "
              f"the build volume {pr.build_x_mm} x {pr.build_y_mm} x {pr.build_z_mm} mm")


def validate(design: Design) -> Design:
    """Check every rule; return the design unchanged or raise :class:`DesignError`."""
    _check_identity(design)
    _check_numbers(design)
    _check_proportions(design)
    _check_elastomer(design)
    _check_printable(design)
    _check_channel_and_inlet(design)
    _check_paper(design)
    _check_castable("material", design.material.name, design.material.c10_mpa, design.material.density_g_per_ml)
    _check_layer_material(design)
    _check_build_volume(design)
    return design
