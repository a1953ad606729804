"""The stiffening ladder: the reduced model's law for a stiffer rubber, read off the FE's own runs.

A design whose free run ends at a pressure maximum cannot carry a strain stiffening as a factor on
its law past that maximum (the law ends there). The ladder (:func:`ladder_of`) holds the nominal law
and the FE's free runs with Yeoh C30 added (:func:`pnmold.physics.characterise.stiffening_ladder`),
which go on to their own limit points; :func:`ladder_characterisation` interpolates two neighbouring
runs linearly in C30 at the same share of each run's final bend (:func:`along`), so that limit point
meets limit point, and gives the rod the nominal's shape at the same bend
(:meth:`pnmold.physics.rom.ReducedModel.laddered`; docs/reduced-model.md, the effect: docs/effects.md).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pnmold.design import Design
from pnmold.physics.characterisation import CURVES, Characterisation, distinct_steps
from pnmold.physics.characterise import LADDER_EFFECT
from pnmold.physics.rom_law import rod_of

#: points along a laddered curve (shares of its final bend)
LADDER_POINTS = 61
#: how far past the end of ladder runs that met a bifurcation (pressure still rising) their law is
#: extrapolated, as a share of the end's pressure; beyond, no equilibrium (assumed: without a bound a fit
#: reaches for the cheap straight line, on the ribbed segment's P-V 45 % past the end). The one law the
#: reduced model still reads past the FE's last solved step (issue 43): cut at the end, the real segment's
#: diagnosis (tests/test_real_segment.py) loses its Boyle-consistent air column and its one C30 for two
#: recordings, so it is kept, flagged ``beyond_fe`` and said, until the FE's runs go past the bifurcation.
#: The FE does not bear the 10 % out: the runs end where their pressure flattens, and a switch onto the path
#: past the first critical point (tried on the segment, benchmarks/README.md) gave at most 2.5 % more
LADDER_EXTRAPOLATION = 0.1


def ladder_of(c: Characterisation) -> list[dict]:
    """The stiffening ladder of ``c``: the nominal law and the FE's free runs with Yeoh C30 added, by
    C30; only where the free run ends at a pressure maximum (else none, an empty list)."""
    rungs = c.variant_runs(LADDER_EFFECT) if c.ends_at_pressure_maximum else []
    return [{**{k: getattr(c, k) for k in CURVES}, "value": 0.0, "stop": "pressure_maximum"}, *rungs
            ] if rungs else []


def along(run: Mapping[str, np.ndarray], share: np.ndarray) -> dict[str, np.ndarray]:
    """A run's curves at ``share`` of its final bend (the bend kept rising: a stalled step is skipped)."""
    bend = np.maximum.accumulate(np.asarray(run["bend_angle_deg"], float))
    keep = np.concatenate([[True], np.diff(bend) > 0])
    at = share * bend[keep][-1]
    return {k: np.interp(at, bend[keep], np.asarray(run[k], float)[keep]) for k in CURVES}


def ladder_characterisation(design: Design, c: Characterisation, ladder: list[dict], c30_mpa: float
                            ) -> Characterisation:
    """The characterisation at Yeoh C30 + ``c30_mpa`` from the ``ladder`` (:func:`ladder_of`) of the
    design's characterisation ``c`` (see :meth:`pnmold.physics.rom.ReducedModel.laddered`)."""
    values = np.array([r["value"] for r in ladder])
    j = int(np.clip(np.searchsorted(values, c30_mpa) - 1, 0, len(ladder) - 2))
    w = (c30_mpa - values[j]) / (values[j + 1] - values[j])
    share = np.linspace(0.0, 1.0, LADDER_POINTS)
    lo, hi = along(ladder[j], share), along(ladder[j + 1], share)
    curves = {k: (1.0 - w) * lo[k] + w * hi[k] for k in CURVES}
    top = int(np.argmax(curves["pressure_kpa"]))
    keep = distinct_steps(curves["pressure_kpa"][:top + 1])
    curves = {k: v[keep] for k, v in curves.items()}
    bend = curves["bend_angle_deg"]
    # the rod: the nominal's shape at the same bend, its last shape scaled beyond its own end
    nominal = np.maximum.accumulate(c.bend_angle_deg)
    at = np.minimum(bend, nominal[-1])
    scale = np.where(at > 0, bend / np.where(at > 0, at, 1.0), 1.0)

    def rows(table: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(at, nominal, col) for col in table.T], axis=1)

    x, angle, length, comp = rod_of(design, c)
    p, b = curves["pressure_kpa"][-1], bend[-1]
    # a maximum where the pressure peaks inside, or where both runs end at one; a run that ends where the FE
    # meets a bifurcation (``instability``, the pressure still rising) leaves the law beyond to extrapolation
    # (:data:`LADDER_EXTRAPOLATION`)
    ends = [ladder[j + 1]] if w >= 1.0 else [ladder[j], ladder[j + 1]]
    maximum = top < LADDER_POINTS - 1 or all(r.get("stop") == "pressure_maximum" for r in ends)
    runs = f"Yeoh C30 + {c30_mpa:.3g} MPa, between the FE's runs at {values[j]:g} and {values[j + 1]:g} MPa"
    return Characterisation(
        **curves, design_name=c.design_name, design_digest=c.design_digest, full_bend_pressure_kpa=None,
        stop="pressure_maximum" if maximum else "instability",
        reason=(f"pressure maximum of {p:.4g} kPa at {b:.1f} deg bend ({runs})" if maximum else
                f"the FE's runs end where their path meets a critical point (their pressure still rising): "
                f"{p:.4g} kPa at {b:.1f} deg bend ({runs})"),
        mesh=c.mesh, rod_x_mm=x, rod_angle_rad=rows(angle) * scale[:, None], rod_length_mm=rows(length),
        compliance_rad_per_n_mm=rows(comp), source="ladder", blocked=c.blocked,
        compliance_down_rad_per_n_mm=None if c.compliance_down_rad_per_n_mm is None else rows(
            c.compliance_down_rad_per_n_mm), probe_down_gravity_g=c.probe_down_gravity_g,
        compliance_layer_rad_per_n_mm=None if c.compliance_layer_rad_per_n_mm is None else rows(
            c.compliance_layer_rad_per_n_mm),
        compliance_down_layer_rad_per_n_mm=None if c.compliance_down_layer_rad_per_n_mm is None else rows(
            c.compliance_down_layer_rad_per_n_mm), probe_layer_mm_per_n=c.probe_layer_mm_per_n,
        compliance_contact_rad_per_n_mm=None if c.compliance_contact_rad_per_n_mm is None else rows(
            c.compliance_contact_rad_per_n_mm),
        compliance_down_contact_rad_per_n_mm=None if c.compliance_down_contact_rad_per_n_mm is None else rows(
            c.compliance_down_contact_rad_per_n_mm))
