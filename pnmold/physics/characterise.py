"""What the FE says about a design, once: the free-bending law and the bending compliance.

FE solves through the one door (:func:`pnmold.design_fe.run_fe`: the actuator alone, no molds,
gate or pictures), on one half-model mesh:

1. **free** -- no gravity, 0 kPa up to full bend (360 degrees) or ``max_pressure_kpa``: the
   curves of docs/json-schemas.md (pressure, tip, bend angle, cavity volume, largest stretch) and
   the shape of the bottom face's line (y = 0, z = 0) at every step: the rod's free law,
   edge by edge (per chamber: :attr:`Characterisation.chamber_rotation_deg`).
2. **probe** -- the same pressures with gravity scaled to ``PROBE_G`` along -z (chambers
   up). The extra rotation of every hinge of the bottom line over the free state, divided by
   the moment of the weight about that hinge (computed on the probe's deformed line with the
   design's cross-sections), is the hinge's bending compliance. It is fitted per hinge by
   least squares over neighbouring pressure steps (Gaussian weights, 1.5 steps), shrunk
   toward its chamber's value where the moment is small, and kept >= 0.

Why a probe: the fPN's weight moment is carried by its thin inside walls and the slab
under the gaps, which shear and bend far more than beam theory of the cross-section says
(about 8x more compliant than the section's EI, 1.7x more than the slab alone), and the
compliance grows about 1.5x toward full bend. Why 0.35 g: the identified compliance then
predicts 1 g (the hinge compliances at 0 kPa agree within 3 % between 0.35 g and 1 g on
the fPN), while the test against 1 g stays a prediction, not a fit.

3. **variants** -- the free run again with one catalogued effect switched on in the FE at a
   few values (:data:`VARIANTS`): the FE's own response to a compliant strain-limiting layer
   and to Yeoh strain stiffening, curve by curve. The reduced model reads its
   ``layer_compliance`` and ``strain_stiffening`` terms from them (bend, cavity volume and
   the tip's distance from the clamp; interpolated in the effect's intensity), so
   concealed FE data and the model that diagnoses them leave the same fingerprint; the
   analytic forms stand in only for a characterisation without variants.

Items 4 and 6 are run by :mod:`pnmold.physics.probes` (:func:`~pnmold.physics.probes.characterised_for`:
the probes a use needs).

4. **down** (on demand, for a recording or simulation hanging chambers down) -- the free run's
   pressures again with Earth's gravity along +z (:data:`pnmold.physics.probes.DOWN_PROBE_G`): the
   hinges' compliance under a weight that opens the bend, identified as the probe's is. The two differ
   hinge by hinge (the fPN's thin inside walls and the slab under its gaps carry an opening moment
   otherwise than a closing one): with the chambers-up compliance the reduced model missed the fPN's
   FE hanging chambers down by up to 24 % of its length near its pressure maximum, with this one by
   under 1 %. At 1 g, the test's own load: an opening compliance from a light probe did not carry to
   1 g (it stiffens as the hinges open).
5. **blocked** (on demand, for a blocked-force recording or simulation) -- the tip against a rigid
   plane at its rest height, no gravity, at one small pressure (:data:`BLOCKED_PROBE_SHARE` of the
   free run's last): the FE's blocked force to first order, which the reduced model's tip compliance
   is scaled to match (the gravity probe's compliance, identified under a distributed load, gave a
   blocked tip force 1.2x the FE's on the ribbed segment of the README's worked example).
6. **layer** (on demand, for a diagnosis or a simulation with a compliant layer, chambers up or down)
   -- a free run with the layer made compliant by :data:`pnmold.physics.probes.LAYER_PROBE_MM_PER_N`
   and each orientation's gravity probe on top of it: the hinges' compliance when the layer carries
   the weight's moment (:func:`pnmold.physics.probes.layer_probe`). A probe that does not serve (e.g.
   a floppy design that loses stability under its weight before any pressure) is noted with why
   (``probes_failed``) and not tried again.

Results are cached as JSON in the user's cache directory (:func:`cache_dir`; ``PNMOLD_CACHE``
overrides the folder), keyed by the design digest, the mesh size and the pressure limit. A
cached file without the variants gains them on first use (the two solves above are not
repeated). The templates' characterisations on the default mesh ship with pnmold
(:data:`BUNDLED_DIR`, written by ``scripts/bundle_characterisations.py``), so a template needs
no FE here; a design that differs from a template in anything (another digest) is
characterised once.
"""

from __future__ import annotations

import functools
import json
import logging
import math
import os
import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from pnmold.conventions import NO_GRAVITY
from pnmold.design import Design, digest
from pnmold.errors import SolveError
from pnmold.fsutil import write_json
from pnmold.physics.characterisation import CURVES, Characterisation, characterisation_from_steps, distinct_steps
from pnmold.physics.identify import bottom_line, identify_compliance
from pnmold.physics.uncertainty import UNCERTAIN_PREFIX, moved_design, uncertainty_keys
from pnmold.tetmesh import MeshSize

log = logging.getLogger(__name__)

PROBE_G = 0.35
#: the characterisation's mesh: the full-bend pressure within 2 % of the build's 2.5/5 mm mesh
DEFAULT_SIZE = MeshSize(3.5, 7.0)
DEFAULT_MAX_PRESSURE_KPA = 150.0
#: effect -> values of its FE variant runs (assumed: inside what the blind benchmark draws,
#: 0.02-0.3 mm/N and 0.01-0.06 MPa). Two for the layer: the sPN's response to it is not
#: proportional to the lost stiffness share (its bend change at 0.05 mm/N is half what 0.15
#: mm/N scaled down predicts), the fPN's and the stiffening's are (within 5-15 %)
VARIANTS = {"layer_compliance": (0.05, 0.15), "strain_stiffening": (0.04,)}
VARIANT_FORMAT = 2  # at the free run's pressures; older runs are re-done
#: the stiffening ladder (:func:`stiffening_ladder`): free runs with the rubber's large-strain Yeoh term C30
#: added, as shares of the design's C10 (assumed: they bracket 2e-5 MPa on Ecoflex 00-30's 0.0082 MPa C10,
#: the C30 that carries the ribbed segment of the worked example to its 72 degrees)
LADDER_C30_PER_C10 = (0.001, 0.0025, 0.006)
LADDER_EFFECT = "strain_stiffening.c30_mpa"
#: the variant run with the FE's frictionless self-contact (:class:`pnmold.fem.SelfContact`, its defaults) on
#: (:func:`self_contact_run`): what the reduced model's ``self_contact`` reads
CONTACT_KEY = "self_contact=1"
#: the blocked-tip probe's pressure, a share of the free run's last (assumed: the FE's blocked force of the
#: ribbed segment per kPa was 0.0069 N at 2 kPa and 0.0076 N at 5 kPa of its 17.5, so a twentieth is linear)
BLOCKED_PROBE_SHARE = 0.05
#: a characterisation solved on past its pressure cap goes up to the pressure asked for rounded up to a multiple
#: of this (assumed: nearby supplies share one FE run; :func:`characterise_up_to`)
EXTEND_STEP_KPA = 50.0
#: the templates' characterisations (default mesh and pressure limit), read when the cache has none
BUNDLED_DIR = Path(__file__).resolve().parents[1] / "data" / "characterisations"


def cache_dir() -> Path:
    """Folder of the cached characterisations: ``PNMOLD_CACHE`` when set, else ``fe/`` in the
    user's cache directory (platformdirs: ``~/.cache/pnmold/fe`` on Linux,
    ``~/Library/Caches/pnmold/fe`` on macOS, ``%LOCALAPPDATA%\\pnmold\\Cache\\fe`` on Windows), so
    every working folder shares it."""
    env = os.environ.get("PNMOLD_CACHE")
    if env:
        return _claimed(Path(env))
    from platformdirs import user_cache_dir

    return _claimed(Path(user_cache_dir("pnmold", appauthor=False)) / "fe")


#: the names pnmold writes in its FE cache (:func:`cache_path`)
CACHE_NAME = re.compile(r"[\w.+-]+-v\d+\.json")


@functools.cache
def _claimed(folder: Path) -> Path:
    """The cache folder, made or adopted once per process (:func:`pnmold.fsutil.claim_store`)."""
    from pnmold.fsutil import claim_store

    return claim_store(folder, "FE cache", CACHE_NAME)


def cache_path(design: Design, size: MeshSize, max_pressure_kpa: float) -> Path:
    # the last part is the FE's version: v2 since the volume-controlled FE with the series
    # paper sheet; a change of the FE's answers bumps it so no older curve is read
    key = (f"{design.name}-{digest(design)}-m{size.wall_mm:g}x{size.max_mm:g}x{size.band_mm:g}"
           f"{'h' if size.half else 'f'}-p{max_pressure_kpa:g}-g{PROBE_G:g}-v2")
    return cache_dir() / f"{key}.json"


def stored_path(design: Design, size: MeshSize, max_pressure_kpa: float) -> Path | None:
    """The cached characterisation's file, else the bundled one's, else None (the FE must run)."""
    path = cache_path(design, size, max_pressure_kpa)
    return next((p for p in (path, BUNDLED_DIR / path.name) if p.is_file()), None)


def characterise(design: Design, *, size: MeshSize | None = None,
                 max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA,
                 progress: Callable[[str], None] | None = None, variants: bool = True) -> Characterisation:
    """The design's characterisation: from the cache or the bundled templates', else quick-FE
    solves (minutes), written to the cache.

    ``size`` defaults to :data:`DEFAULT_SIZE` (3.5/7 mm: the full-bend pressure within 2 %
    of the build's 2.5/5 mm mesh); the free run stops at full bend or ``max_pressure_kpa``.
    ``variants=False``: without the variant runs (what the rod needs without the layer and
    stiffening terms, which then take their analytic forms); a later call adds them."""
    size = replace(size or DEFAULT_SIZE, half=True)
    path = cache_path(design, size, max_pressure_kpa)
    say = progress or (lambda stage: None)
    result = None
    stored = stored_path(design, size, max_pressure_kpa)
    if stored is not None:
        try:
            result = Characterisation.from_json(json.loads(stored.read_text()))
        except (ValueError, KeyError, TypeError) as err:
            log.warning("ignoring the unreadable characterisation %s: %s", stored, err)
    if result is None:
        result = _run_fe(design, size, max_pressure_kpa, say)
        write_json(path, result.to_json())
    missing = [key for key in variant_keys() if result.variants.get(key, {}).get("format") != VARIANT_FORMAT]
    if variants and missing and result.source == "fe":
        extra = result.pressure_kpa[-1] * (1.0 + 0.05 * np.arange(1, 6))  # a stiffer variant gets further
        pressures = [float(p) for p in (*result.pressure_kpa[1:], *extra[extra <= max_pressure_kpa])]
        result = _with_variants(result, _run_variants(design, size, missing, say, pressures_kpa=pressures))
        write_json(path, result.to_json())
    return result


def characterise_up_to(design: Design, pressure_kpa: float, *, size: MeshSize | None = None,
                       progress: Callable[[str], None] | None = None) -> Characterisation:
    """The design's characterisation reaching ``pressure_kpa`` where the FE can: :func:`characterise`'s, and
    when that ended merely at its pressure cap (below full bend) below ``pressure_kpa``, the FE solved on up
    to ``pressure_kpa`` rounded up to :data:`EXTEND_STEP_KPA` (a characterisation of its own, cached under
    that pressure limit, without the variant runs), which ends at full bend, a named physical stop or that
    cap. A characterisation that ended at full bend or at a physical stop is returned as it is: the laws
    answer with that end (:class:`pnmold.pneumatics.law.LawEnd`)."""
    c = characterise(design, size=size, progress=progress)
    if not c.ends_at_cap or c.source != "fe" or pressure_kpa <= c.max_pressure_kpa * (1 + 1e-9):
        return c
    cap = math.ceil(pressure_kpa / EXTEND_STEP_KPA) * EXTEND_STEP_KPA
    (progress or log.info)(f"{design.name}: its characterisation ends at the pressure cap "
                           f"{c.max_pressure_kpa:.4g} kPa below full bend; solving on to {cap:g} kPa")
    return characterise(design, size=size, max_pressure_kpa=cap, progress=progress, variants=False)


def ladder_keys(design: Design) -> list[str]:
    """``strain_stiffening.c30_mpa=value`` of every run of the design's stiffening ladder."""
    return [f"{LADDER_EFFECT}={share * design.material.c10_mpa:.4g}" for share in LADDER_C30_PER_C10]


def stiffening_ladder(design: Design, *, size: MeshSize | None = None,
                      max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA,
                      progress: Callable[[str], None] | None = None) -> Characterisation:
    """The characterisation with the stiffening ladder: free runs (no gravity) with Yeoh C30 added at
    :data:`LADDER_C30_PER_C10` x C10, each to its own end (a limit point, full bend or the pressure
    limit), kept among the variants (cached with the rest).

    Why: a design whose free run ends at a pressure maximum cannot show, by a factor on its own law, a
    stiffening that moves the maximum to a larger bend; recordings past that maximum need the law of the
    stiffer rubber itself (:meth:`pnmold.physics.rom.ReducedModel.laddered`). Minutes of FE, once."""
    return _with_runs_to_their_end(design, ladder_keys(design), size, max_pressure_kpa, progress)


def blocked_force_probe(design: Design, *, size: MeshSize | None = None,
                        max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA,
                        progress: Callable[[str], None] | None = None) -> Characterisation:
    """The characterisation with the FE's blocked tip force at one small pressure (``blocked``): the tip
    against a rigid frictionless plane at its rest height, no gravity, at :data:`BLOCKED_PROBE_SHARE` of the
    free run's last pressure, where the force is still linear in it. One FE step (seconds), once, cached."""
    size = replace(size or DEFAULT_SIZE, half=True)
    result = characterise(design, size=size, max_pressure_kpa=max_pressure_kpa, progress=progress)
    if result.blocked is not None or result.source != "fe":
        return result
    p = BLOCKED_PROBE_SHARE * result.max_pressure_kpa
    (progress or (lambda stage: None))(f"{design.name}: blocked tip at {p:.3g} kPa (FE, no gravity)")
    result = replace(result, blocked=_blocked_tip(design, p, size))
    write_json(cache_path(design, size, max_pressure_kpa), result.to_json())
    return result


def _blocked_tip(design: Design, pressure_kpa: float, size: MeshSize) -> dict[str, float]:
    """The FE's blocked tip (a rigid frictionless plane at its rest height, no gravity) at one pressure."""
    from pnmold.design_fe import run_fe

    t0 = time.perf_counter()
    run = run_fe(design, orientation=NO_GRAVITY, kind="force", pressures_kpa=[pressure_kpa], size=size)
    step = run.solution.steps[-1]
    return {"pressure_kpa": float(step.pressure_kpa), "force_n": float(step.force_n),
            "seconds": round(time.perf_counter() - t0, 2)}


def variant_keys() -> list[str]:
    """``effect=value`` of every variant run in :data:`VARIANTS`."""
    return [f"{name}={value:g}" for name, values in VARIANTS.items() for value in values]


def self_contact_run(design: Design, *, size: MeshSize | None = None,
                     max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA,
                     progress: Callable[[str], None] | None = None) -> Characterisation:
    """The characterisation with the free run (no gravity) solved again with the FE's self-contact on
    (:data:`CONTACT_KEY`), at the free run's pressures, to its own end (full bend, the tip meeting the
    base or another named stop), kept among the variants (cached with the rest): the law the reduced
    model's ``self_contact`` reads (:mod:`pnmold.physics.rom_effects`). A minute or two of FE, once."""
    size = replace(size or DEFAULT_SIZE, half=True)
    result = characterise(design, size=size, max_pressure_kpa=max_pressure_kpa, progress=progress)
    if result.variants.get(CONTACT_KEY, {}).get("format") == VARIANT_FORMAT or result.source != "fe":
        return result
    pressures = [float(p) for p in result.pressure_kpa[1:]]
    result = _with_variants(result, _run_variants(design, size, [CONTACT_KEY], progress or (lambda stage: None),
                                                  pressures_kpa=pressures))
    write_json(cache_path(design, size, max_pressure_kpa), result.to_json())
    return result


def uncertainty_runs(design: Design, uncertain: Mapping[str, float], *, size: MeshSize | None = None,
                     max_pressure_kpa: float = DEFAULT_MAX_PRESSURE_KPA, blocked: bool = False,
                     progress: Callable[[str], None] | None = None) -> Characterisation:
    """The characterisation with a free run (no gravity) of the design with each uncertain dimension
    (``field -> standard uncertainty``, :func:`pnmold.physics.uncertainty.check_uncertain`) moved up by
    it, each to its own end, kept among the variants (cached with the rest): what
    :class:`pnmold.physics.uncertainty.DesignFloor` reads. Another geometry, so each its own mesh: a
    minute or two of FE per dimension, once. ``blocked`` (for a blocked-force recording): also the design's
    blocked tip (:func:`blocked_force_probe`) and each moved design's at the same pressure
    (``blocked_force_n`` in its variant; seconds each)."""
    keys = uncertainty_keys(uncertain)
    if blocked:
        blocked_force_probe(design, size=size, max_pressure_kpa=max_pressure_kpa, progress=progress)
    result = _with_runs_to_their_end(design, keys, size, max_pressure_kpa, progress)
    missing = [k for k in keys if k in result.variants and "blocked_force_n" not in result.variants[k]]
    if not blocked or result.blocked is None or result.source != "fe" or not missing:
        return result
    size, p = replace(size or DEFAULT_SIZE, half=True), float(result.blocked["pressure_kpa"])
    variants = dict(result.variants)
    for key in missing:
        field, value = key.removeprefix(UNCERTAIN_PREFIX).partition("=")[::2]
        (progress or (lambda stage: None))(f"{design.name}: blocked tip with {field} + {value} at {p:.3g} kPa "
                                           "(FE, no gravity)")
        tip = _blocked_tip(moved_design(design, field, float(value)), p, size)
        variants[key] = {**variants[key], "blocked_force_n": tip["force_n"]}
    result = replace(result, variants=variants)
    write_json(cache_path(design, size, max_pressure_kpa), result.to_json())
    return result


def _with_runs_to_their_end(design: Design, keys: Sequence[str], size: MeshSize | None, max_pressure_kpa: float,
                            progress: Callable[[str], None] | None) -> Characterisation:
    """The characterisation with the variant runs ``keys`` (each to its own end), those it lacks run and cached."""
    size = replace(size or DEFAULT_SIZE, half=True)
    result = characterise(design, size=size, max_pressure_kpa=max_pressure_kpa, progress=progress)
    missing = [k for k in keys if result.variants.get(k, {}).get("format") != VARIANT_FORMAT]
    if not missing or result.source != "fe":
        return result
    say = progress or (lambda stage: None)
    result = _with_variants(result, _run_variants(design, size, missing, say, max_pressure_kpa=max_pressure_kpa))
    write_json(cache_path(design, size, max_pressure_kpa), result.to_json())
    return result


def _run_variants(design: Design, size: MeshSize, keys: Sequence[str], say: Callable[[str], None], *,
                  pressures_kpa: Sequence[float] | None = None, max_pressure_kpa: float | None = None
                  ) -> dict[str, dict]:
    """Free runs (no gravity) with one effect each (``effect=value`` keys): the curves at ``pressures_kpa``
    (the :data:`VARIANTS`: the free run's pressures and a little beyond, so that variant and nominal meet
    step by step and a variant's small change is not lost in interpolating the nominal between its
    steps), or each to its own end up to ``max_pressure_kpa`` (the ladder), with why it ended (``stop``).
    The effects change the material or the layer, not the geometry: one mesh serves them all. A
    ``design:<field>=<value>`` key solves the design with that dimension moved up by the value instead,
    on a mesh of its own (:func:`uncertainty_runs`)."""
    from pnmold.design_fe import run_fe
    from pnmold.fem import SelfContact, SolveOptions

    out, first = {}, None
    for key in keys:
        name, value = key.partition("=")[0], float(key.partition("=")[2])
        field = name.removeprefix(UNCERTAIN_PREFIX) if name.startswith(UNCERTAIN_PREFIX) else None
        solved = moved_design(design, field, value) if field else design
        say(f"{design.name}: free bending with {f'{field} + {value:g}' if field else f'{name} = {value:g}'} "
            "(FE, no gravity)")
        t0 = time.perf_counter()
        contact = key == CONTACT_KEY  # a solve option, not a change of the material or the layer
        run = run_fe(solved, orientation=NO_GRAVITY, effects=None if field or contact else {name: value},
                     pressures_kpa=pressures_kpa, max_pressure_kpa=max_pressure_kpa, size=size,
                     options=SolveOptions(self_contact=SelfContact()) if contact else None,
                     mesh_of=None if field else first, keep_partial=True)
        first = first or (None if field else run)
        steps = [s.as_dict() for s in run.solution.steps]
        out[key] = {"format": VARIANT_FORMAT, "value": value, **{k: [float(s[k]) for s in steps] for k in CURVES},
                    "reason": run.solution.reason, "stop": run.solution.stop,
                    "free_length_mm": solved.free_length_mm, "seconds": round(time.perf_counter() - t0, 2)}
    return out


def _with_variants(result: Characterisation, runs: dict[str, dict]) -> Characterisation:
    """``result`` with the variant ``runs`` of :func:`_run_variants` added (their seconds in the timings)."""
    timings = {**result.timings_s, **{f"variant {k}": v.pop("seconds") for k, v in runs.items() if "seconds" in v}}
    return replace(result, variants={**result.variants, **runs}, timings_s=timings)


def _run_fe(design: Design, size: MeshSize, max_pressure_kpa: float,
            say: Callable[[str], None]) -> Characterisation:
    """The free run and the gravity probe on its mesh; the rod's shape and compliance from them."""
    from pnmold.design_fe import run_fe

    t0 = time.perf_counter()
    say(f"{design.name}: free bending (FE, no gravity)")
    run = run_fe(design, orientation=NO_GRAVITY, max_pressure_kpa=max_pressure_kpa, size=size, keep_partial=True)
    t1 = time.perf_counter()
    free = run.solution
    keep = distinct_steps([s.pressure_kpa for s in free.steps])
    free_steps, free_shapes = [free.steps[i] for i in keep], [free.shapes_mm[i] for i in keep]
    pressures = [s.pressure_kpa for s in free_steps[1:]]
    say(f"{design.name}: compliance probe (FE, {PROBE_G:g} g chambers up)")
    try:
        probe = run_fe(design, orientation="chambers_up", effects={"gravity": PROBE_G}, pressures_kpa=pressures,
                       mesh_of=run).solution
    except SolveError as err:
        probe = err.partial
        log.warning("compliance probe stopped: %s", err)
    t2 = time.perf_counter()
    steps = [s.as_dict() for s in free_steps]
    base = characterisation_from_steps(steps, design, free.reason)
    x, angle, length = bottom_line(run.mesh.nodes_mm, free_shapes)
    compliance, probe_doc = None, None
    if probe is not None and len(probe.steps) >= 2:
        _, p_angle, p_length = bottom_line(run.mesh.nodes_mm, probe.shapes_mm[:len(free_steps)])
        compliance = identify_compliance(design, x, angle, p_angle, p_length, PROBE_G)
        probe_doc = {k: [float(s.as_dict()[k]) for s in probe.steps] for k in CURVES}
    else:
        from pnmold.physics.section import slab_flexibility

        compliance = np.tile(slab_flexibility(design, x), (len(steps), 1))
    return Characterisation(
        **{k: getattr(base, k) for k in CURVES}, design_name=design.name, design_digest=digest(design),
        full_bend_pressure_kpa=free.full_bend_pressure_kpa, reason=free.reason, stop=free.stop,
        mesh={"nodes": run.quality.n_nodes, "tets": run.quality.n_tets, "wall_size_mm": size.wall_mm,
              "max_size_mm": size.max_mm, "band_mm": size.band_mm, "half_model": size.half},
        rod_x_mm=x, rod_angle_rad=angle, rod_length_mm=length, compliance_rad_per_n_mm=compliance,
        probe_gravity_g=PROBE_G if probe_doc else 0.0, probe=probe_doc, source="fe",
        timings_s={"free": round(t1 - t0, 2), "probe": round(t2 - t1, 2)})
