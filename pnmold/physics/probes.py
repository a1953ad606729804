"""The on-demand probes of a characterisation, and the characterisation a use of it needs.

A recording or simulation may need more of the FE than :func:`pnmold.physics.characterise.characterise`
holds (its items 4-6): the blocked tip (:func:`pnmold.physics.characterise.blocked_force_probe`), the
hinges' compliance under a weight that opens the bend (:func:`downward_probe`), and the compliance with
a compliant strain-limiting layer under each orientation's weight (:func:`layer_probe`).
:func:`characterised_for` runs the ones a use needs, each FE once, cached with the characterisation. A
probe that does not serve is noted with why (``probes_failed``) and not run again.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace

import numpy as np

from pnmold.conventions import NO_GRAVITY
from pnmold.design import Design
from pnmold.fsutil import write_json
from pnmold.physics.characterisation import CURVES, Characterisation
from pnmold.physics.characterise import (
    DEFAULT_MAX_PRESSURE_KPA,
    DEFAULT_SIZE,
    PROBE_G,
    blocked_force_probe,
    cache_path,
    characterise,
    self_contact_run,
)
from pnmold.physics.identify import bottom_line, identify_compliance
from pnmold.tetmesh import MeshSize

log = logging.getLogger(__name__)

#: the downward probe's gravity (g, along +z): a chambers-down test's own load
DOWN_PROBE_G = 1.0
#: the layer compliance (mm/N) of the layer's compliance probes (:func:`layer_probe`): the hinges' compliance
#: under a weight grows with the share of the bottom's stretching stiffness the layer loses, nearly in
#: proportion (the fPN's FE rest sag hanging chambers down at 1 g grew 4.0, 8.5 and 11.0 mm for 0.15, 0.5 and
#: 0.95 mm/N, shares 0.165, 0.40, 0.56); a value inside what the blind benchmark draws (as :data:`VARIANTS`'s)
LAYER_PROBE_MM_PER_N = 0.15


def characterised_for(design: Design, kinds: Sequence[str], orientations: Sequence[str], *, layer: bool = False,
                      contact: bool = False, size: MeshSize | None = None,
                      max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA,
                      progress: Callable[[str], None] | None = None) -> Characterisation:
    """The characterisation with the probes a use of it needs: the blocked tip for a blocked force
    (:func:`blocked_force_probe`), the opening compliance for a test hanging chambers down
    (:func:`downward_probe`), with ``layer`` (a compliant layer to be modelled) the compliance with it under
    the orientations' weights (:func:`layer_probe`), with ``contact`` (self-contact to be modelled) the free run
    with the FE's self-contact on (:func:`self_contact_run`); each FE once, cached."""
    kw = {"size": size, "max_pressure_kpa": max_pressure_kpa, "progress": progress}
    result = characterise(design, **kw)
    if "force" in kinds:
        result = blocked_force_probe(design, **kw)
    if "chambers_down" in orientations:
        result = downward_probe(design, **kw)
    if layer and {"chambers_up", "chambers_down"} & set(orientations):
        result = layer_probe(design, orientations, **kw)
    if "horizontal" in orientations:
        result = roll_probe(design, **kw)
    if contact:
        self_contact_run(design, **kw)
        result = contact_probe(design, [o for o in orientations if o in ("chambers_up", "chambers_down")], **kw)
    return result


def roll_probe(design: Design, *, size: MeshSize | None = None, max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA,
               progress: Callable[[str], None] | None = None) -> Characterisation:
    """The characterisation with the edges' torsional compliance held on its side
    (``roll_compliance_rad_per_n_mm``, :mod:`pnmold.physics.roll`) and its stiffening with pressure
    (``roll_stiffening``): the whole body (no half model: the weight leaves the plane of symmetry)
    under :data:`~pnmold.physics.roll.ROLL_PROBE_G` horizontal. At rest its sections' rolls read at the rod's
    nodes are identified with the rod under the rolled weight (the chambers-down compliance: the rolled weight
    opens the bend; :func:`downward_probe` first); carried on through
    :data:`~pnmold.physics.roll.ROLL_PROBE_SHARES` of the free run's last pressure (as far as the FE goes), its
    tips at the pressures asked for give the stiffening (:func:`roll_stiffening`; where the FE stopped short, a
    critical point, is kept aside as ``probe_roll["stopped"]``). FE, a few minutes; once, cached."""
    from pnmold.design_fe import run_fe
    from pnmold.physics.roll import NO_STIFFENING, ROLL_PROBE_G, ROLL_PROBE_SHARES, section_rolls

    size = replace(size or DEFAULT_SIZE, half=True)
    result = downward_probe(design, size=size, max_pressure_kpa=max_pressure_kpa, progress=progress)
    if (result.roll_stiffening is not None or "roll" in result.probes_failed or result.source != "fe"
            or not result.has_rod):
        return result
    pressures = [share * float(result.pressure_kpa[-1]) for share in ROLL_PROBE_SHARES]
    top = pressures[-1]
    (progress or (lambda stage: None))(f"{design.name}: roll probe (FE of the whole body, {ROLL_PROBE_G:g} g "
                                       f"horizontal, to {top:.3g} kPa)")
    t0 = time.perf_counter()
    run = run_fe(design, orientation="horizontal", effects={"gravity": ROLL_PROBE_G},
                 pressures_kpa=pressures, size=replace(size, half=False), keep_partial=True)
    steps, shapes = run.solution.steps, run.solution.shapes_mm
    if not steps or steps[0].pressure_kpa != 0.0 or not shapes or run.solution.rest_weight_g is not None:
        return _failed(design, result, "roll", run.solution.reason or "no state at rest", size, max_pressure_kpa)
    node_roll = section_rolls(run.mesh.nodes_mm, shapes[0], result.rod_x_mm)
    roll = roll_compliance(design, result, node_roll, ROLL_PROBE_G)
    rest = steps[0]
    doc = {"tip_x_mm": rest.tip_x_mm, "tip_z_mm": rest.tip_z_mm, "bend_angle_deg": rest.bend_angle_deg,
           "node_roll_deg": np.degrees(node_roll).tolist(), "pressed": []}
    result = replace(result, roll_compliance_rad_per_n_mm=roll, probe_roll_gravity_g=ROLL_PROBE_G, probe_roll=doc,
                     roll_stiffening=NO_STIFFENING)
    if len(steps) > 1 and len(shapes) == len(steps):
        # only the pressures asked for: a state where the FE stopped short (a critical point: its response
        # to the weight turns singular there, which no factor on a model without that point stands in for)
        # is kept aside, not read
        asked = np.array(pressures)
        doc["pressed"] = [{"pressure_kpa": s.pressure_kpa, "tip_x_mm": s.tip_x_mm, "tip_z_mm": s.tip_z_mm,
                           "node_roll_deg": np.degrees(section_rolls(run.mesh.nodes_mm, u, result.rod_x_mm)).tolist()}
                          for s, u in zip(steps[1:], shapes[1:], strict=True)
                          if np.isclose(s.pressure_kpa, asked, rtol=1e-9, atol=0.0).any()]
        if not np.isclose(steps[-1].pressure_kpa, top, rtol=1e-9, atol=0.0):
            doc["stopped"] = {"pressure_kpa": steps[-1].pressure_kpa, "reason": run.solution.reason}
        result = replace(result, roll_stiffening=roll_stiffening(design, result))
    result = replace(result, timings_s={**result.timings_s, "probe_roll": round(time.perf_counter() - t0, 2)})
    write_json(cache_path(design, size, max_pressure_kpa), result.to_json())
    return result


def roll_stiffening(design: Design, result: Characterisation) -> dict:
    """The torsional stiffening with pressure (:func:`pnmold.physics.roll.stiffened`'s table): at each of the
    roll probe's pressed states (``result``'s ``probe_roll["pressed"]``), the factor on the torsional stiffness
    within :data:`~pnmold.physics.roll.ROLL_STIFFENING_BOUNDS` that brings the reduced model's tip, held on its
    side at the probe's weight, nearest the FE's, a factor away from 1 costing as a tip miss of
    :data:`~pnmold.physics.roll.ROLL_STIFFENING_COST_SHARE` of the length per e-fold (where the tip hardly
    feels the roll, the model's other misfit reads no stiffening into it). A body that hardly rolls: an empty
    table (no stiffening)."""
    from pnmold.physics.protocol import Protocol
    from pnmold.physics.roll import NO_STIFFENING, ROLL_STIFFENING_BOUNDS, ROLL_STIFFENING_COST_SHARE
    from pnmold.physics.rom import MIN_ROLL_DEG, ReducedModel

    probe = result.probe_roll or {}
    pressed = probe.get("pressed") or []
    if not pressed or max(np.abs(probe["node_roll_deg"])) < MIN_ROLL_DEG:
        return NO_STIFFENING
    p = np.array([s["pressure_kpa"] for s in pressed])
    fe = np.array([[s["tip_x_mm"], s["tip_z_mm"]] for s in pressed])
    protocol = Protocol("bending", p, "horizontal")

    def tips(factor: np.ndarray) -> np.ndarray:
        """(S, 2) the model's tips at the states with ``factor`` (S,) at each state."""
        table = {"pressure_kpa": p.tolist(), "factor": factor.tolist()}
        out = ReducedModel(design, replace(result, roll_stiffening=table)).run(
            protocol, {"gravity": result.probe_roll_gravity_g}, partial=True)
        return np.stack([out["tip_x_mm"], out["tip_z_mm"]], axis=1)

    def miss(factor: np.ndarray) -> np.ndarray:
        d = np.sum((tips(factor) - fe) ** 2, axis=1) + (ROLL_STIFFENING_COST_SHARE * design.length_mm
                                                         * np.log(factor)) ** 2
        return np.where(np.isfinite(d), d, 1e18)

    lo, hi = (np.log(np.full(p.size, b, float)) for b in ROLL_STIFFENING_BOUNDS)
    return {"pressure_kpa": p.tolist(), "factor": np.exp(_golden(miss, lo, hi)).tolist()}


def _golden(miss: Callable[[np.ndarray], np.ndarray], lo: np.ndarray, hi: np.ndarray, tol: float = 1e-3
            ) -> np.ndarray:
    """Per state, the log factor in [``lo``, ``hi``] that minimises ``miss(exp(log factor))`` (a golden-section
    search, every state at once: each state's miss depends on its own factor alone)."""
    r = (np.sqrt(5.0) - 1.0) / 2.0
    a, b = lo.copy(), hi.copy()
    c, d = b - r * (b - a), a + r * (b - a)
    fc, fd = miss(np.exp(c)), miss(np.exp(d))
    while np.max(b - a) > tol:
        left = fc < fd
        b = np.where(left, d, b)
        a = np.where(left, a, c)
        c_new, d_new = b - r * (b - a), a + r * (b - a)
        c, d = np.where(left, c_new, d), np.where(left, c, d_new)
        f = miss(np.exp(np.where(left, c, d)))
        fc, fd = np.where(left, f, fd), np.where(left, fc, f)
    return (a + b) / 2.0


def downward_probe(design: Design, *, size: MeshSize | None = None,
                   max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA,
                   progress: Callable[[str], None] | None = None) -> Characterisation:
    """The characterisation with the hinges' compliance under a weight that opens the bend
    (``compliance_down_rad_per_n_mm``): the free run's pressures again hanging chambers down at
    :data:`DOWN_PROBE_G` (FE, a minute or two), identified as the chambers-up probe's is. Once, cached; a
    design the probe does not fit (its mesh's bottom line is not the free run's) keeps the chambers-up one."""
    from pnmold.design_fe import run_fe

    size = replace(size or DEFAULT_SIZE, half=True)
    result = characterise(design, size=size, max_pressure_kpa=max_pressure_kpa, progress=progress)
    if (result.compliance_down_rad_per_n_mm is not None or "down" in result.probes_failed or result.source != "fe"
            or not result.has_rod):
        return result
    (progress or (lambda stage: None))(f"{design.name}: compliance probe (FE, {DOWN_PROBE_G:g} g chambers down)")
    t0 = time.perf_counter()
    run = run_fe(design, orientation="chambers_down", effects={"gravity": DOWN_PROBE_G},
                 pressures_kpa=[float(p) for p in result.pressure_kpa[1:]], size=size, keep_partial=True)
    compliance = _probe_compliance(design, result, run, result.rod_angle_rad, -DOWN_PROBE_G)
    if isinstance(compliance, str):
        return _failed(design, result, "down", compliance, size, max_pressure_kpa)
    doc = {k: [float(s.as_dict()[k]) for s in run.solution.steps] for k in CURVES}
    result = replace(result, compliance_down_rad_per_n_mm=compliance, probe_down_gravity_g=DOWN_PROBE_G,
                     probe_down=doc, timings_s={**result.timings_s, "probe_down": round(time.perf_counter() - t0, 2)})
    write_json(cache_path(design, size, max_pressure_kpa), result.to_json())
    return result


def layer_probe(design: Design, orientations: Sequence[str], *, size: MeshSize | None = None,
                max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA,
                progress: Callable[[str], None] | None = None) -> Characterisation:
    """The characterisation with the hinges' compliance when the strain-limiting layer is made compliant by
    :data:`LAYER_PROBE_MM_PER_N` (the ``layer_compliance`` effect), for the weights of ``orientations``:
    chambers up (``compliance_layer_rad_per_n_mm``, at :data:`PROBE_G` as the chambers-up probe) and chambers
    down (``compliance_down_layer_rad_per_n_mm``, at :data:`DOWN_PROBE_G`). A free run with the layer (its
    shape, which the probes' extra rotations are measured from) and a probe per orientation: FE, a minute
    or three, once, cached."""
    c = LAYER_PROBE_MM_PER_N
    return _probed(design, orientations, "layer", f"layer_compliance = {c:g} mm/N", size, max_pressure_kpa,
                   progress, effects={"layer_compliance": c}, extra={"probe_layer_mm_per_n": c})


def contact_probe(design: Design, orientations: Sequence[str], *, size: MeshSize | None = None,
                  max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA,
                  progress: Callable[[str], None] | None = None) -> Characterisation:
    """The characterisation with the hinges' compliance when the FE's self-contact is on (the ``self_contact``
    effect), for the weights of ``orientations``: chambers up (``compliance_contact_rad_per_n_mm``, at
    :data:`PROBE_G`) and chambers down (``compliance_down_contact_rad_per_n_mm``, at :data:`DOWN_PROBE_G`).
    Why: a weight that closes the gaps presses their walls together (hanging chambers down the fPN at rest
    bends 46 degrees with contact, 56 without, and goes on past the pressure where it snaps without), which
    the free run with contact cannot show. A free run with contact and a probe per orientation: FE, minutes,
    once, cached."""
    from pnmold.fem import SelfContact, SolveOptions

    return _probed(design, orientations, "contact", "self-contact", size, max_pressure_kpa, progress,
                   options=SolveOptions(self_contact=SelfContact()))


def _probed(design: Design, orientations: Sequence[str], label: str, what: str, size: MeshSize | None,
            max_pressure_kpa: float, progress: Callable[[str], None] | None, *,
            effects: Mapping[str, float] | None = None, options=None, extra: Mapping | None = None
            ) -> Characterisation:
    """The characterisation with the compliances ``compliance_<label>_rad_per_n_mm`` (chambers up) and
    ``compliance_down_<label>_rad_per_n_mm`` (chambers down) that ``orientations`` need and it lacks: a free
    run (no gravity) at the free run's pressures with ``effects`` and the solver's ``options``, and a gravity
    probe with them per orientation, each identified over the free run's shape (:func:`_probe_compliance`);
    ``extra`` fields kept with them; a probe that does not serve noted (``<label> <orientation>``)."""
    from pnmold.design_fe import run_fe

    size = replace(size or DEFAULT_SIZE, half=True)
    kw = {"size": size, "max_pressure_kpa": max_pressure_kpa, "progress": progress}
    result = downward_probe(design, **kw) if "chambers_down" in orientations else characterise(design, **kw)
    fields = {"chambers_up": (f"compliance_{label}_rad_per_n_mm", PROBE_G),
              "chambers_down": (f"compliance_down_{label}_rad_per_n_mm", -DOWN_PROBE_G)}
    wanted = {o: g for o, (name, g) in fields.items()
              if o in orientations and getattr(result, name) is None and f"{label} {o}" not in result.probes_failed}
    if not wanted or result.source != "fe" or not result.has_rod:
        return result
    (progress or (lambda stage: None))(f"{design.name}: compliance probes with {what} (FE: free, "
                                       f"{', '.join(wanted).replace('_', ' ')})")
    t0 = time.perf_counter()
    pressures = [float(p) for p in result.pressure_kpa[1:]]
    free = run_fe(design, orientation=NO_GRAVITY, effects=effects, pressures_kpa=pressures, size=size,
                  options=options, keep_partial=True)
    if len(free.solution.steps) < 2:
        return _failed(design, result, [f"{label} {o}" for o in wanted], free.solution.reason or "no step",
                       size, max_pressure_kpa)
    _, free_angle, _ = bottom_line(free.mesh.nodes_mm, free.solution.shapes_mm)
    rows = len(result.pressure_kpa)  # the free angles, the last repeated past the free run's end
    free_angle = np.vstack([free_angle, np.repeat(free_angle[-1:], max(rows - len(free_angle), 0), axis=0)])[:rows]
    found, failed = {}, {}
    for orientation, g in wanted.items():
        probe = run_fe(design, orientation=orientation, effects={"gravity": abs(g), **(effects or {})},
                       pressures_kpa=pressures, size=size, options=options, mesh_of=free, keep_partial=True)
        got = _probe_compliance(design, result, probe, free_angle, g, len(free.solution.steps))
        if isinstance(got, str):
            failed[f"{label} {orientation}"] = got
        else:
            found[fields[orientation][0]] = got
    result = replace(result, **found, **(extra or {}), probes_failed={**result.probes_failed, **failed},
                     timings_s={**result.timings_s, f"probe_{label}": round(time.perf_counter() - t0, 2)})
    write_json(cache_path(design, size, max_pressure_kpa), result.to_json())
    return result


def roll_compliance(design: Design, result: Characterisation, node_roll: np.ndarray, g: float) -> np.ndarray:
    """(K,) the edges' torsional compliance from a roll probe's section rolls ``node_roll`` (K+1, rad) at ``g``
    (:func:`pnmold.physics.roll.identify_roll`, with the rod at rest under the chambers-down compliance)."""
    from pnmold.physics.rod import solve_rod
    from pnmold.physics.roll import identify_roll
    from pnmold.physics.section import rod_loads

    compliance = result.compliance_down_rad_per_n_mm
    compliance = (result.compliance_rad_per_n_mm if compliance is None else compliance)[:1]
    loads = rod_loads(design, result.rod_x_mm)
    return identify_roll(design, loads, node_roll, lambda share: solve_rod(
        result.rod_angle_rad[:1], result.rod_length_mm[:1], compliance, loads, (0.0, g), share=share), g)


def _failed(design: Design, result: Characterisation, probes: str | list[str], why: str, size: MeshSize,
            max_pressure_kpa: float) -> Characterisation:
    """``result`` with ``probes`` noted as tried and why they did not serve (cached: not tried again)."""
    names = [probes] if isinstance(probes, str) else probes
    result = replace(result, probes_failed={**result.probes_failed, **dict.fromkeys(names, why)})
    write_json(cache_path(design, size, max_pressure_kpa), result.to_json())
    return result


def _probe_compliance(design: Design, result: Characterisation, run, free_angle: np.ndarray, probe_g: float,
                      rows: int | None = None) -> np.ndarray | str:
    """The hinge compliance (S, K) identified from a gravity probe ``run`` (``probe_g`` along -z) over the
    free rod's ``free_angle`` (the probe's first ``rows`` rows at most), or why the probe does not serve
    (said in the log)."""
    probe = run.solution
    why = None
    if len(probe.steps) < 2 or probe.rest_weight_g is not None:
        why = f"{probe.reason}"
    else:
        x, angle, length = bottom_line(run.mesh.nodes_mm, probe.shapes_mm)
        if x.shape != result.rod_x_mm.shape or not np.allclose(x, result.rod_x_mm):
            why = "its mesh's bottom line is not the free run's"
    if why is not None:
        log.warning("compliance probe of %s not used: %s", design.name, why)
        return why
    n = min(len(result.pressure_kpa), rows or len(angle))
    return identify_compliance(design, x, free_angle, angle[:n], length[:n], probe_g)
