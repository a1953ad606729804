"""The fabrication and testing checklist of a design, with its quantities worked out.

Follows the supplement's procedure (Mosadegh et al. 2014, SI: Fabrication of fPN
Actuator; Characterization; Pressure-Volume curves): print the three ABS molds, cast the
top layer between the exterior and interior molds, cast the bottom layer over the paper,
set the top layer into it, punch the 2 mm inlet, plumb the 1/32" x 3/32" tubing, then test.
Every quantity comes from a build report (``report.json``): the cast volumes, the pours
(part A / part B by the material's mix ratio), the slicer's estimates and the FE's
full-bend pressure and largest stretch.
"""

from __future__ import annotations

import html
from dataclasses import dataclass
from typing import Any

from pnmold.checks.slicer import DEFAULT_PROFILE, read_profile
from pnmold.conventions import USES
from pnmold.design import Design

#: assumed: keep the test's largest stretch below half the stretch at break
STRETCH_SAFETY_FACTOR = 2.0
#: assumed: the leak test's pressure
LEAK_TEST_KPA = 10.0


@dataclass(frozen=True)
class Section:
    title: str
    steps: tuple[str, ...]


def _library_material(name: str):
    from pnmold.materials.library import find_material

    return find_material(name)


def _g(x: float) -> str:
    """Four significant figures: within 0.1 % of report.json."""
    return f"{x:.4g} g"


def _pour_steps(pour: dict[str, Any], m, material) -> list[str]:
    """Weigh, mix and degas one pour of the rubber ``m`` (a design's; ``material``: its library entry)."""
    pot = f"; pot life about {material.pot_life_min:.0f} min" if material else ""
    return [
        f"Weigh {_g(pour['part_a_g'])} of part A and {_g(pour['part_b_g'])} of part B "
        f"({m.name}, A:B = {m.mix_ratio_a_to_b:g}:1 by weight): {_g(pour['mix_g'])} in all, "
        f"{pour['volume_ml']:.4g} mL ({_g(pour['mass_g'])}) cast plus a "
        f"{100 * pour['waste_margin']:.0f}% waste margin{pot}.",
        "Mix thoroughly, scraping the cup's walls and floor.",
        "Degas in a vacuum chamber until the bubbles stop rising (a few minutes).",
    ]


def _sheet_steps(design: Design) -> tuple[str, ...]:
    """Where the paper goes: on the mold floor, or embedded on a first pour (``paper.depth_mm``)."""
    where = f"between the four corner stops ({design.paper.inset_mm:g} mm from every edge)"
    depth = design.paper.depth_mm
    if depth <= 0:
        return (f"Lay the paper flat on the bottom mold's floor {where}.",)
    share = depth / design.bottom_layer.thickness_mm
    return (f"The sheet lies {depth:g} mm above the bottom face: mix the quantities above in two batches, "
            f"{100 * share:.0f} % first for the rubber below the sheet and the rest after it has set.",
            f"Pour the first batch {depth:g} mm deep and level it; let it cure until tack-free.",
            f"Lay the paper flat on it {where}, pressing out any air under the sheet; mix the second batch.")


def _cure_step(material, what: str) -> str:
    if material is None or not material.cure:
        return f"Cure the {what} per the elastomer's datasheet (cure schedule unknown to pnmold)."
    options = " or ".join(f"{c.hours:g} h at {c.temperature_c:g} °C" for c in material.cure)
    return f"Cure the {what}: {options}."


def _fem_numbers(report: dict[str, Any], material) -> tuple[str, str]:
    fem = report.get("fem") or {}
    steps = fem.get("steps") or []
    p_full = fem.get("full_bend_pressure_kpa")
    if p_full is None:
        bend = (f"The quick FE did not reach full bend ({fem.get('reason', 'not run')}); "
                "raise the pressure slowly and note where both ends touch.")
    else:
        bend = (f"The FE predicts full bend (both ends touching) at {p_full:.1f} kPa "
                f"({p_full * 0.145038:.2f} psi).")
    if not steps or material is None:
        return bend, ("Safety limit: no FE stretch available (run `pnmold build` with the FE); "
                      "go no higher than full bend.")
    limit_stretch = (1 + material.elongation_at_break) / STRETCH_SAFETY_FACTOR
    safe = [s["pressure_kpa"] for s in steps if s["max_principal_stretch"] <= limit_stretch]
    top = max(steps, key=lambda s: s["pressure_kpa"])
    safety = (f"Safety limit: the FE's largest principal stretch reaches {top['max_principal_stretch']:.2f} at "
              f"{top['pressure_kpa']:.1f} kPa; {material.name} breaks at a stretch of "
              f"{1 + material.elongation_at_break:.1f} (elongation {100 * material.elongation_at_break:.0f}%). "
              f"Stay below {max(safe):.1f} kPa, where the stretch is at most {limit_stretch:.2f} "
              f"(safety factor {STRETCH_SAFETY_FACTOR:g} on the stretch at break, assumed).")
    return bend, safety


def checklist_sections(design: Design, report: dict[str, Any]) -> list[Section]:
    """The ordered steps of fabrication and testing for ``design``, given its build report."""
    material = _library_material(design.material.name)
    layer = design.bottom_material
    layer_library = _library_material(layer.name)
    pours = {p["part"]: p for p in report["pours"]}
    slicer = report.get("slicer") or {}
    profile = read_profile(DEFAULT_PROFILE)
    px, py = design.paper_size_mm
    paper = design.paper.present
    embedded = paper and design.paper.depth_mm > 0
    sheet = _sheet_steps(design) if paper else ()
    prints = []
    for name, use in USES.items():
        est = slicer.get(name) or {}
        time_text = (f"PrusaSlicer estimate {est['print_time_s'] / 3600:.1f} h, {est['filament_g']:.1f} g of ABS"
                     if est.get("print_time_s") else "no slicer estimate (run `pnmold build` with PrusaSlicer)")
        face = "ceiling" if use.print_up[2] < 0 else "base"
        prints.append(f"Print `print/{name}.stl` in ABS on its {face}, no supports: layer "
                      f"{profile.get('layer_height')} mm, {profile.get('perimeters')} perimeters, "
                      f"{profile.get('fill_density')} infill, {profile.get('temperature')} °C nozzle, "
                      f"{profile.get('bed_temperature')} °C bed; {time_text}.")
    top, bottom = pours["top_layer"], pours["bottom_layer"]
    bend, safety = _fem_numbers(report, material)
    zc = design.inlet_axis_z_mm
    return [
        Section("Print the molds", (*prints, "Remove any stringing; check the interior mold's plate slides "
                                    f"into the exterior mold's recess ({design.mold.clearance_mm:g} mm clearance).")),
        Section("Cast the top layer (extensible, with the chambers)", (
            "Turn the exterior mold over (ceiling down) on a level surface.",
            *_pour_steps(top, design.material, material),
            "Pour into the exterior mold, filling the plates' gaps and the box.",
            "Press the interior mold in, chambers down, until its plate seats on the ledge; wipe the overflow.",
            _cure_step(material, "top layer"),
            "Demold: lift the interior mold out, then peel the top layer off the exterior mold's plates.")),
        Section(f"Cast the bottom layer (strain-limiting, {'with the paper' if paper else layer.name})", (
            *((f"Cut the paper to {px:.1f} x {py:.1f} mm ({design.paper.thickness_mm:g} mm sheet).",) if paper else ()),
            *(() if embedded else sheet),  # on the mold floor before the mix, embedded after it
            *_pour_steps(bottom, layer, layer_library),
            *(sheet if embedded else ()),
            f"Pour {'over the paper ' if paper else ''}to the top of the pocket "
            f"({design.bottom_layer.thickness_mm:g} mm deep).",
            "Before it cures, set the cured top layer into it, chambers down, pressing gently so no air stays "
            "under the walls.",
            _cure_step(layer_library, "bonded actuator"),
            "Alternative: cure the bottom layer alone, then bond the top layer to it with a silicone adhesive "
            "such as Elastosil E951.",
            "Demold the actuator and trim the flash.")),
        *((Section("Cast the passive side and bond it under the bottom layer", (
            "Cast a second top layer in the same two molds, exactly as above: it is the passive side.",
            *_pour_steps(pours["passive_layer"], design.material, material),
            _cure_step(material, "passive side"),
            "Turn it over, chambers up, and bond the actuator's bottom layer onto it with a thin coat of the "
            "same rubber, filling the paper stops' dimples in the bottom layer's face, its ends and edges "
            "flush with the top layer's.",
            f"Punch its inlet too ({design.top_z0_mm - design.inlet_axis_z_mm + design.bottom_z0_mm:.2f} mm "
            "above the bottom face): its chambers stay open to the room while the other side is driven.")),)
          if design.passive_side.present else ()),
        Section("Inlet and tubing", (
            "Punch the inlet with a 2 mm biopsy punch: at the end face x = 0, centred across the width, "
            f"{zc:.2f} mm above the bottom face, straight along the actuator for {design.inlet_depth_mm:.1f} mm "
            "into the channel.",
            f'Push in tubing of {design.inlet.tubing_id_mm:.2f} mm ID, {design.inlet.tubing_od_mm:.2f} mm OD '
            '(1/32" x 3/32"), slightly larger than the hole so it seals.')),
        Section("Test", (
            f"Leak test: hold the actuator under water at {LEAK_TEST_KPA:g} kPa (assumed) and look for bubbles.",
            (f"Clamp the top and bottom faces of the first {design.clamp_end_mm:.1f} mm "
             f"({'the proximal chamber' if not design.clamp.length_mm else 'clamp.length_mm'}: the fixed end, "
             "as the FE holds it)."),
            f"Bending test: raise the pressure with the regulator, photographing at each step. {bend}",
            safety,
            "Pressure-volume test: clamp the actuator vertically, fully submerged in a water tank; fill it with "
            "water (submerge, pull a vacuum several times until no bubbles emerge); infuse with a syringe pump "
            "slowly enough to be quasi-static, switch to withdrawal at full bend, and repeat for at least "
            "three cycles.",
            "Save the recordings in pnmold's recording format (kind bending, pv or force) for "
            "`pnmold diagnose`.")),
    ]


def render_markdown(design: Design, sections: list[Section]) -> str:
    lines = [f"# Fabrication checklist: {design.name}", "",
             f"{design.kind.upper()}, {design.chambers.count} chambers, {design.material.name}. "
             "Quantities come from this build's geometry (report.json).", ""]
    for n, section in enumerate(sections, 1):
        lines += [f"## {n}. {section.title}", ""]
        lines += [f"- [ ] {step}" for step in section.steps]
        lines.append("")
    return "\n".join(lines)


_CSS = """body{font-family:sans-serif;max-width:46em;margin:2em auto;line-height:1.4}
li{list-style:none;margin:.3em 0}li:before{content:"\\2610  ";font-size:1.2em}
h2{border-bottom:1px solid #999;page-break-after:avoid}section{page-break-inside:avoid}
@media print{body{margin:0;font-size:11pt}a{color:black}}"""


def render_html(design: Design, sections: list[Section]) -> str:
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>Checklist {html.escape(design.name)}"
             f"</title><style>{_CSS}</style></head><body>",
             f"<h1>Fabrication checklist: {html.escape(design.name)}</h1>"]
    for n, section in enumerate(sections, 1):
        items = "".join(f"<li>{html.escape(step)}</li>" for step in section.steps)
        parts.append(f"<section><h2>{n}. {html.escape(section.title)}</h2><ul>{items}</ul></section>")
    parts.append("</body></html>")
    return "\n".join(parts)

