"""The FE's characterisation of a design, as data: :class:`Characterisation` and its JSON.

What :func:`pnmold.physics.characterise.characterise` finds (the free-bending law, the rod's
shape and hinge compliance, the FE's variant runs) and what the reduced model reads. Pure
values: no FE, no gmsh, no files.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from pnmold.conventions import full_bend_crossing
from pnmold.design import Design, digest
from pnmold.errors import SolveError, UsageError
from pnmold.physics.identify import chamber_bounds_mm

FORMAT = "pnmold.characterisation/1"
CURVES = ("pressure_kpa", "bend_angle_deg", "tip_x_mm", "tip_z_mm", "cavity_volume_ml", "max_principal_stretch")
ROD = ("rod_x_mm", "rod_angle_rad", "rod_length_mm", "compliance_rad_per_n_mm", "compliance_down_rad_per_n_mm",
       "compliance_layer_rad_per_n_mm", "compliance_down_layer_rad_per_n_mm", "roll_compliance_rad_per_n_mm",
       "compliance_contact_rad_per_n_mm", "compliance_down_contact_rad_per_n_mm")


@dataclass(frozen=True, eq=False)
class Characterisation:
    """The FE's free-bending law of one design (no gravity) and its hinge compliance.

    Curves (S,) per converged step from 0 kPa; the rod (None when built from steps only):
    ``rod_x_mm`` (K+1,) reference x of the bottom line's nodes, ``rod_angle_rad`` and
    ``rod_length_mm`` (S, K) each edge's free angle and length, ``compliance_rad_per_n_mm``
    (S, K) the hinge compliance at each edge's proximal node (identified chambers up: a weight that
    closes the bend); ``compliance_down_rad_per_n_mm`` (S, K) the same identified chambers down (a
    weight that opens it; :func:`pnmold.physics.probes.downward_probe`), None until asked for.
    """

    pressure_kpa: np.ndarray
    bend_angle_deg: np.ndarray
    tip_x_mm: np.ndarray
    tip_z_mm: np.ndarray
    cavity_volume_ml: np.ndarray
    max_principal_stretch: np.ndarray
    design_name: str = ""
    design_digest: str = ""
    full_bend_pressure_kpa: float | None = None
    reason: str | None = None
    #: how the free run ended, one of :data:`pnmold.fem.STOPS` (None in files written before it was kept:
    #: :attr:`how_ended` reads it from ``reason``)
    stop: str | None = None
    mesh: dict = field(default_factory=dict)
    rod_x_mm: np.ndarray | None = None
    rod_angle_rad: np.ndarray | None = None
    rod_length_mm: np.ndarray | None = None
    compliance_rad_per_n_mm: np.ndarray | None = None
    probe_gravity_g: float = 0.0
    probe: dict | None = None
    source: str = "fe"
    timings_s: dict = field(default_factory=dict)
    variants: dict = field(default_factory=dict)  # "effect=value" -> {"value": v, curves...} (lists, FE)
    #: the FE's blocked tip (a rigid plane at its rest height, no gravity) at one small pressure:
    #: {"pressure_kpa", "force_n", "seconds"} (:func:`pnmold.physics.characterise.blocked_force_probe`), or None
    blocked: dict | None = None
    #: the hinges' compliance under a weight that opens the bend (chambers down), from an FE probe at
    #: ``probe_down_gravity_g`` (:func:`pnmold.physics.probes.downward_probe`), and that probe's curves
    compliance_down_rad_per_n_mm: np.ndarray | None = None
    probe_down_gravity_g: float = 0.0
    probe_down: dict | None = None
    #: the chambers-up and chambers-down compliances with the strain-limiting layer made compliant by
    #: ``probe_layer_mm_per_n`` (the ``layer_compliance`` effect), from a free run and probes with it
    #: (:func:`pnmold.physics.probes.layer_probe`); None until asked for
    compliance_layer_rad_per_n_mm: np.ndarray | None = None
    compliance_down_layer_rad_per_n_mm: np.ndarray | None = None
    probe_layer_mm_per_n: float = 0.0
    #: the chambers-up and chambers-down compliances with the FE's self-contact on (the ``self_contact`` effect),
    #: from a free run and probes with it (:func:`pnmold.physics.probes.contact_probe`); None until asked for
    compliance_contact_rad_per_n_mm: np.ndarray | None = None
    compliance_down_contact_rad_per_n_mm: np.ndarray | None = None
    #: held on its side: each rod edge's torsional compliance (K,) from the FE of the whole body at
    #: ``probe_roll_gravity_g`` horizontal, at rest, and that probe's rest state and section rolls
    #: (:func:`pnmold.physics.probes.roll_probe`, :mod:`pnmold.physics.roll`); None until asked for
    roll_compliance_rad_per_n_mm: np.ndarray | None = None
    probe_roll_gravity_g: float = 0.0
    probe_roll: dict | None = None
    #: held on its side: the factor on the torsional stiffness at the effective pressures the same probe was
    #: carried through (``pressure_kpa``, ``factor``; :func:`pnmold.physics.roll.stiffened`); None until that
    #: probe ran (an older characterisation, which held one law ``roll_stiffening_per_kpa``: the probe runs again)
    roll_stiffening: dict | None = None
    #: on-demand probes tried that did not serve (``down``, ``layer chambers_up``, ``layer chambers_down``,
    #: ``contact chambers_up``, ``contact chambers_down``, ``roll``) -> why: not tried again (the model keeps
    #: what it has without them)
    probes_failed: dict = field(default_factory=dict)

    def variant_runs(self, effect: str) -> list[dict[str, np.ndarray]]:
        """The FE variant runs of ``effect`` (arrays at distinct pressures, ``value``), by value."""
        out = []
        for key, doc in self.variants.items():
            keep = distinct_steps(doc["pressure_kpa"])
            if key.partition("=")[0] != effect or keep.size < 2:
                continue
            out.append({**{k: np.asarray(doc[k], float)[keep] for k in CURVES}, "value": float(doc["value"]),
                        "stop": doc.get("stop")})
        return sorted(out, key=lambda d: d["value"])

    @property
    def has_rod(self) -> bool:
        return self.rod_angle_rad is not None

    @property
    def max_pressure_kpa(self) -> float:
        return float(self.pressure_kpa[-1])

    @property
    def ends_at_pressure_maximum(self) -> bool:
        """The free run stopped at a pressure maximum (a limit point; the reason is the words of
        :meth:`pnmold.fem.results.PressureMaximum.describe`): past its last pressure the actuator has
        no equilibrium under pressure control, so the law there is not extrapolated."""
        return self.full_bend_pressure_kpa is None and (self.reason or "").startswith("pressure maximum")

    @property
    def how_ended(self) -> str:
        """How the free run ended: ``full_bend``, a named physical stop (``pressure_maximum``,
        ``stretch_limit``, ``tip_meets_base``, ``instability``), ``pressure_limit`` (merely the pressure
        cap, below full bend) or ``failed``; from ``stop`` when kept, else from the words of ``reason``
        (:func:`pnmold.fem.solver._stop`)."""
        if self.stop:
            return self.stop
        reason = self.reason or ""
        for start, stop in _REASON_STARTS:
            if reason.startswith(start):
                return stop
        if self.full_bend_pressure_kpa is not None:
            return "full_bend"
        return "pressure_limit" if "at the pressure limit" in reason else "failed"

    @property
    def ends_at_cap(self) -> bool:
        """The free run ended merely at its pressure cap, below full bend: solving on would go further."""
        return self.how_ended == "pressure_limit"

    @property
    def end_reason(self) -> str:
        """Why the free run's curve ends where it does, in words."""
        if self.reason:
            return self.reason
        if self.how_ended == "full_bend":
            return (f"the FE's curve ends at full bend (360 deg at {self.full_bend_pressure_kpa:.4g} kPa): the free "
                    "end meets the clamped end")
        return f"the FE's curve ends there ({self.how_ended})"

    def chamber_rotation_deg(self, design: Design) -> np.ndarray:
        """(S, n) rotation of each chamber's pitch of the bottom line (the first is clamped)."""
        if not self.has_rod:
            raise SolveError("a characterisation from steps has no rod shape (the FE's probe did not run)")
        bounds = chamber_bounds_mm(design)
        mid = (self.rod_x_mm[:-1] + self.rod_x_mm[1:]) / 2
        ends = [np.zeros(len(self.pressure_kpa))]
        for b in bounds[1:]:
            ends.append(np.array([np.interp(b, mid, a) for a in self.rod_angle_rad]))
        return np.degrees(np.diff(np.stack(ends, axis=1), axis=1))

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"format": FORMAT}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = v.tolist() if isinstance(v, np.ndarray) else v
        return out

    @classmethod
    def from_json(cls, doc: Mapping[str, Any]) -> Characterisation:
        if doc.get("format") != FORMAT:
            raise UsageError(f"not a {FORMAT} document")
        kw = {f.name: doc[f.name] for f in fields(cls) if f.name in doc}
        for name in (*CURVES, *ROD):
            if kw.get(name) is not None:
                kw[name] = np.asarray(kw[name], float)
        return cls(**kw)


#: the first words of the FE's reasons (:func:`pnmold.fem.solver._stop`) -> the stop
_REASON_STARTS = (("pressure maximum", "pressure_maximum"), ("the largest principal stretch", "stretch_limit"),
                  ("the free end meets the clamped end", "tip_meets_base"), ("the actuator loses stability",
                                                                            "instability"))


def distinct_steps(pressure_kpa: Sequence[float], min_step_kpa: float = 0.01) -> np.ndarray:
    """Indices of the steps to keep: the first, then each at least ``min_step_kpa`` above the last kept
    (a solve that stalls repeats its last pressure; interpolation needs distinct pressures)."""
    keep, last = [], -np.inf
    for i, p in enumerate(pressure_kpa):
        if p >= last + min_step_kpa:
            keep.append(i)
            last = p
    return np.array(keep, int)


def characterisation_from_steps(steps: Sequence[Mapping[str, Any]], design: Design | None = None,
                                reason: str | None = None) -> Characterisation:
    """A characterisation from FE step dicts (``report.json`` ``fem.steps``, gravity off).

    Only the curves: the reduced model then assumes the bend spreads evenly over the free
    chambers and takes the compliance from the slab's beam estimate (no probe)."""
    if len(steps) < 2:
        raise SolveError("the FE curve needs at least two steps (0 kPa and one more)")
    cols = {k: np.array([float(s[k]) for s in steps]) for k in CURVES}
    if np.any(np.diff(cols["pressure_kpa"]) < 0):
        raise SolveError("the FE curve's pressures must increase")
    keep = distinct_steps(cols["pressure_kpa"])
    if keep.size < 2:
        raise SolveError("the FE curve needs at least two distinct pressures")
    cols = {k: v[keep] for k, v in cols.items()}
    fb, _ = full_bend_crossing(cols["pressure_kpa"], cols["bend_angle_deg"])
    return Characterisation(**cols, design_name=design.name if design else "",
                            design_digest=digest(design) if design else "", full_bend_pressure_kpa=fb,
                            reason=reason, source="steps")
