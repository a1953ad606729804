"""The reduced model: a planar rod of the bottom face, informed by the FE of the same design.

Per protocol row, in this order (every step vectorised over the rows):

1. **History** (:mod:`.history`): the viscoelastic filter gives the relaxed-equivalent
   pressure, the Mullins factor the row's first-loading stiffening.
2. **Material**: the free law is read at ``p_eff``: the pressure divided by
   ``modulus_scale`` x the Mullins factor, and by the strain-stiffening factor ``r``
   (``p = p_eff r(p_eff)``, inverted on a fine table). ``r`` comes from the FE's own run with
   stiffer rubber (:mod:`.response`), separately for the shape and for the volume.
3. **Free shape**: each bottom-line edge's angle and length at ``p_eff`` from the FE steps
   (linear in pressure between steps, the last slope beyond them); self-contact freezes
   the increments above its contact pressure down to 1/(1 + value).
4. **Loads** (:mod:`.rod`): weight (gravity x orientation, net of buoyancy submerged) and,
   for ``force``, a rigid plane at the tip's rest height z = 0 (supplement Fig. S6). The
   hinge compliance (FE probe) is divided by the same stiffness factors. Layer compliance
   reads the shape (and the compliance), and separately the volume, at ``p_eff`` x a factor
   from the FE's run with a stretching layer (:mod:`.response`).
5. **Observables**: tip = the last node; bend angle = last edge's angle plus the FE's
   end-face offset at ``p_eff``; cavity volume = the FE's at ``p_eff`` plus the work-
   conjugate change sum_k M_k dh_k/dp (Maxwell-Betti: dV/dM = dtheta/dp), the free part at
   the volume's own ``p_eff``; injected volume from the same model's 0 kPa state; largest
   stretch from the FE at the volume's ``p_eff``.

Assumed: the bend lives in the x-z plane (gravity out of plane does nothing), the hinge
compliance is linear in the moment (checked against 1 g by ``tests/test_rom.py``), the
pressure-side effects act on the whole actuator alike.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pnmold import effects as fx
from pnmold.conventions import NO_GRAVITY, gravity_direction
from pnmold.design import Design
from pnmold.errors import DesignError, RodError, SolveError
from pnmold.physics.characterisation import CURVES, Characterisation, distinct_steps
from pnmold.physics.characterise import LADDER_EFFECT, characterise
from pnmold.physics.history import mullins_factor, viscoelastic_pressure
from pnmold.physics.protocol import Protocol
from pnmold.physics.reading import FRAME, at_volumes, read_bend, read_tip, read_volume
from pnmold.physics.response import responses, solve_stiffened
from pnmold.physics.rod import RodLoads, RodState, solve_rod
from pnmold.physics.section import rod_loads, slab_flexibility

#: name -> (nominal, bounds): the rubber's modulus as a multiple of the design's (a wrong material shows as
#: 10x, assumed limits), and a camera frame's offset and rotation (:mod:`.reading`)
CALIBRATION = {"modulus_scale": (1.0, (0.02, 50.0)), **FRAME}
#: strain of the rubber that carries the bend, as a fraction of the FE's peak principal strain
#: (equibiaxial): fitted to the FE with Yeoh C20 + 0.05 MPa (fPN, coarse mesh), whose pressure
#: for a given bend rose 1, 4 and 8 % at 11, 23 and 34 kPa (``benchmarks/rom.py --fe-effects``);
#: the peak strain itself (fraction 1) would have predicted 10 times that
REPRESENTATIVE_STRAIN = 0.12
#: a row is beyond the FE's characterisation when its effective pressure passes the FE's last one by this share
BEYOND_FE_SHARE = 0.01
#: layer compliance: gain and strain scale of the lost stiffness share (see ``layer_softening``)
LAYER_SHARE_GAIN, LAYER_STRAIN_SCALE = 0.75, 0.2


@dataclass(frozen=True, eq=False)
class _Tables:
    """The free law on the FE's pressure grid."""

    p: np.ndarray  # (S,)
    angle: np.ndarray  # (S, K)
    length: np.ndarray  # (S, K)
    compliance: np.ndarray  # (S, K)
    offset_deg: np.ndarray  # (S,) FE bend angle minus the last edge's angle
    volume_ml: np.ndarray  # (S,)
    stretch: np.ndarray  # (S,)


def _interp(p: np.ndarray, table: np.ndarray, x: np.ndarray, extrapolate: bool = True) -> np.ndarray:
    """Piecewise linear in p (rows of ``table``), the end slopes beyond the ends unless clamped."""
    i = np.clip(np.searchsorted(p, x, side="right") - 1, 0, p.size - 2)
    t = (x - p[i]) / (p[i + 1] - p[i])
    if not extrapolate:
        t = np.clip(t, 0.0, 1.0)
    if table.ndim == 2:
        t = t[:, None]
    return table[i] + t * (table[i + 1] - table[i])


def _slope(p: np.ndarray, table: np.ndarray, x: np.ndarray) -> np.ndarray:
    i = np.clip(np.searchsorted(p, x, side="right") - 1, 0, p.size - 2)
    return (table[i + 1] - table[i]) / (p[i + 1] - p[i])[:, None]


class ReducedModel:
    """Rod of chamber hinges with the FE's free law and compliance; see the module docstring."""

    def __init__(self, design: Design, characterisation: Characterisation):
        if len(distinct_steps(characterisation.pressure_kpa)) < 2:
            raise DesignError("characterisation", "needs at least two FE steps at distinct pressures")
        self.design, self.characterisation = design, characterisation
        c = characterisation
        if c.has_rod:
            x, angle, length, comp = c.rod_x_mm, c.rod_angle_rad, c.rod_length_mm, c.compliance_rad_per_n_mm
        else:
            x, angle, length, comp = _even_rod(design, c)
        self.x_mm = x
        self.loads: RodLoads = rod_loads(design, x)
        offset = c.bend_angle_deg - np.degrees(angle[:, -1])
        k = distinct_steps(c.pressure_kpa)
        self.tables = _Tables(c.pressure_kpa[k], angle[k], length[k], comp[k], offset[k], c.cavity_volume_ml[k],
                              c.max_principal_stretch[k])
        self._onset: dict[float, float] = {}
        clamp_x = design.clamp_end_mm
        self.free_edge = x[:-1] >= clamp_x - 1e-6
        base = {"pressure_kpa": self.tables.p, "bend_angle_deg": c.bend_angle_deg[k],
                "cavity_volume_ml": self.tables.volume_ml, "tip_x_mm": c.tip_x_mm[k], "tip_z_mm": c.tip_z_mm[k],
                "clamp_x_mm": clamp_x}
        self.responses = {}  # effect -> {"bend", "volume", "length": Response} from the FE's variant runs
        layer = c.variant_runs("layer_compliance")
        if layer:
            self.responses["layer_compliance"] = responses(
                base, [(self._layer_share(r["value"]), r) for r in layer], softening=True)
        stiff = c.variant_runs("strain_stiffening")
        if stiff:
            self.responses["strain_stiffening"] = responses(base, [(r["value"], r) for r in stiff], softening=False)
        #: the stiffening ladder (:func:`pnmold.physics.characterise.stiffening_ladder`): the nominal law and the
        #: FE's free runs with Yeoh C30 added, by C30; only where the free run ends at a pressure maximum
        rungs = c.variant_runs(LADDER_EFFECT) if c.ends_at_pressure_maximum else []
        self.ladder = [{**{k: getattr(c, k) for k in CURVES}, "value": 0.0, "stop": "pressure_maximum"}, *rungs
                       ] if rungs else []
        self._laddered: dict[float, ReducedModel] = {}
        #: the hinges' compliance under a blocked tip, a multiple of the gravity probe's: the model's blocked
        #: force at the FE's blocked probe over the FE's (1 without the probe; :meth:`_blocked_factor`)
        self.blocked_compliance = 1.0
        self.blocked_compliance = self._blocked_factor()

    @classmethod
    def for_design(cls, design: Design, characterisation: Characterisation | None = None) -> ReducedModel:
        """The model of ``design``; without a characterisation, :func:`characterise` (cached)."""
        return cls(design, characterisation if characterisation is not None else characterise(design))

    # -- the stiffening ladder ---------------------------------------------------------------------
    @property
    def ladder_top_mpa(self) -> float:
        """The largest C30 the ladder holds (0 without a ladder)."""
        return self.ladder[-1]["value"] if self.ladder else 0.0

    def laddered(self, c30_mpa: float) -> ReducedModel:
        """The model of the design with Yeoh C30 + ``c30_mpa``, from the ladder's two neighbouring runs.

        Past the nominal's pressure maximum a factor on the nominal law cannot carry a stiffening (the
        law ends there); the ladder's runs go on to their own limit points. Between two runs the curves
        (pressure, tip, cavity volume, stretch) are interpolated linearly in C30 at the same share of each
        run's final bend, so that limit point meets limit point; the bend's end is interpolated alike.
        The rod's shape is the nominal's at the same bend (its last shape scaled beyond), the hinge
        compliance the nominal's there; the curve ends at its pressure maximum. The model has no
        variants: a C20 or a layer compliance on top takes the analytic forms (see the terms)."""
        if not self.ladder:
            raise DesignError("strain_stiffening.c30_mpa", "this model has no stiffening ladder")
        if not 0.0 < c30_mpa <= self.ladder_top_mpa * (1.0 + 1e-9):
            raise DesignError("strain_stiffening.c30_mpa", f"{c30_mpa:g} MPa is outside the stiffening ladder's "
                                                           f"(0, {self.ladder_top_mpa:g}] MPa")
        if c30_mpa not in self._laddered:
            if len(self._laddered) > 256:
                self._laddered.clear()
            self._laddered[c30_mpa] = ReducedModel(self.design, _ladder_characterisation(self, c30_mpa))
        return self._laddered[c30_mpa]

    def _blocked_factor(self) -> float:
        """The model's blocked tip force over the FE's at the characterisation's blocked probe (the same
        pressure, no gravity): to first order in the pressure the force is the free tip's travel over the
        tip's flexibility under a tip load, so scaling the hinges' compliance by it makes the two agree
        there. 1 without the probe."""
        probe = self.characterisation.blocked
        if not probe or probe["force_n"] <= 0:
            return 1.0
        p = np.array([0.0, probe["pressure_kpa"]])
        force = float(self.run(Protocol("force", p, NO_GRAVITY), {"gravity": 0.0})["force_n"][1])
        return force / probe["force_n"] if force > 0 else 1.0

    # -- the terms ----------------------------------------------------------------------------------
    def contact_pressure_kpa(self, gap_scale: float = 1.0) -> float:
        """Pressure (on the free law) where neighbouring fPN walls' bulges close the gap; inf if never."""
        if gap_scale not in self._onset:
            self._onset[gap_scale] = _contact_onset(self.design, self.characterisation, gap_scale)
        return self._onset[gap_scale]

    def _layer_share(self, compliance_mm_per_n: float) -> float:
        """The share of the bottom's stretching stiffness (N/mm) an added layer compliance c loses. With
        paper: k_r/(k_p' + k_r) - k_r/(k_p + k_r), k_p = E t the paper's, k_p' = 1/(1/k_p + c), k_r = 6 C10
        x thickness the bottom rubber's; without: the rubber limits the strain alone, 1 - k_r'/k_r."""
        d = self.design
        rubber = 6.0 * d.bottom_material.c10_mpa * d.bottom_layer.thickness_mm
        if not d.paper.present:
            return 1.0 - 1.0 / (1.0 + compliance_mm_per_n * rubber)
        paper = d.paper.modulus_mpa * d.paper.thickness_mm
        return rubber / (1.0 / (1.0 / paper + compliance_mm_per_n) + rubber) - rubber / (paper + rubber)

    def layer_softening(self, compliance_mm_per_n: float, p_eff: Mapping[str, np.ndarray]
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Factors on the pressure the shape and the volume read with an added layer compliance, and
        the stretch of the free part.

        From the FE variants (:mod:`.response`), the lost stiffness share as the intensity. Without a
        variant: the shape's factor 1 + share x B, B = 0.75 / (1 + e/0.2) with e the FE's peak strain
        (fitted to the FE: fPN, coarse mesh, c = 0.3 and 1 mm/N at 5-23 kPa: 6-24 % more pressure-
        equivalent bend, the same tip path and volume), the volume's factor and the stretch 1."""
        share = self._layer_share(compliance_mm_per_n)
        response = self.responses.get("layer_compliance")
        if response is not None:
            return (response["bend"](p_eff["bend"], share), response["volume"](p_eff["volume"], share),
                    response["length"](p_eff["bend"], share))
        strain = np.maximum(_interp(self.tables.p, self.tables.stretch, np.maximum(p_eff["bend"], 0.0)) - 1.0, 0.0)
        return 1.0 + share * LAYER_SHARE_GAIN / (1.0 + strain / LAYER_STRAIN_SCALE), 1.0, 1.0

    def _stiffening(self, p_m: np.ndarray, dc20: float, dc30: float
                    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray | float]:
        """p_eff of the shape and of the volume (``{"bend": .., "volume": ..}``) with p_m = p_eff r(p_eff),
        the shape's r there, and the stretch of the free part.

        From the FE variants (:mod:`.response`) with intensity dC20 + 1.5 dC30 I1 (MPa): the added Yeoh
        slope dW/dI1 / (2 I1) at the representative stretch, the variants' dC20 at C30 = 0. Without a
        variant r is the ratio of the slopes themselves, alike for shape and volume."""
        if not (dc20 or dc30):
            return {"bend": p_m, "volume": p_m}, np.ones_like(p_m), 1.0
        m = self.design.material

        def i1(p):
            peak = np.maximum(_interp(self.tables.p, self.tables.stretch, np.maximum(p, 0.0)), 1.0)
            lam = 1.0 + REPRESENTATIVE_STRAIN * (peak - 1.0)
            return 2 * lam ** 2 + lam ** -4 - 3.0

        response = self.responses.get("strain_stiffening")
        if response is None:
            def ratio(p):
                base = m.c10_mpa + 2 * m.c20_mpa * i1(p) + 3 * m.c30_mpa * i1(p) ** 2
                return 1.0 + (2 * dc20 * i1(p) + 3 * dc30 * i1(p) ** 2) / base

            q = solve_stiffened(p_m, ratio)
            return {"bend": q, "volume": q}, ratio(q), 1.0

        def intensity(p):
            return dc20 + 1.5 * dc30 * i1(p)

        q = {key: solve_stiffened(p_m, lambda x, f=response[key]: f(x, intensity(x))) for key in ("bend", "volume")}
        s = intensity(q["bend"])
        return q, response["bend"](q["bend"], s), response["length"](q["bend"], s)

    def _gravity_xz(self, orientation: str, g: float) -> tuple[float, float]:
        """The in-plane (x, z) gravity of the orientation, in g (out of plane: none)."""
        direction = gravity_direction(orientation, self.design.material.density_g_per_ml)
        if g == 0 or direction is None:
            return (0.0, 0.0)
        return (g * direction[0], g * direction[2])

    # -- the run ------------------------------------------------------------------------------------
    def run(self, protocol: Protocol, effects: Mapping[str, float] | None = None,
            params: Mapping[str, float] | None = None,
            calibration: Mapping[str, float] | None = None, partial: bool = False) -> dict[str, np.ndarray]:
        """Every protocol row's observables (recording columns of its kind, and more), read as the
        protocol's recording measures them (:mod:`.reading`); ``beyond_fe``: the rows whose
        pressure lies beyond what the FE characterised (the law is extrapolated there).

        ``effects``: values by name (and ``NAME.PARAM``), unnamed ones at their catalogue
        default (gravity 1 g, the rest off); ``params``: more ``NAME.PARAM`` values;
        ``calibration``: nominal parameters (``modulus_scale``, 1 = the design's rubber; a camera
        frame's offset and rotation). ``partial``: rows without an equilibrium (past a limit point)
        come back as NaN instead of raising :class:`SolveError`; rows beyond the FE's pressure maximum
        (none without ``partial``: an error) carry the state at the maximum, the nearest the model
        comes, and ``pressure_excess`` > 0, the share of their pressure the model cannot hold."""
        if protocol.by_volume:
            return self._run_by_volume(protocol, effects, params, calibration, partial)
        values = fx.check_effects({**(effects or {}), **(params or {})}, model="rom")
        scale = _calibration(calibration or {})["modulus_scale"]

        def v(key):
            return fx.value_of(values, key)

        if self.ladder and v(LADDER_EFFECT) > 0:  # the stiffer rubber's own law (see laddered)
            return self.laddered(v(LADDER_EFFECT)).run(protocol, {**values, LADDER_EFFECT: 0.0}, None, calibration,
                                                       partial)

        p = protocol.pressure_kpa
        x = viscoelastic_pressure(p, protocol.times_s(), v("viscoelasticity"), v("viscoelasticity.tau_s"))
        stiff = scale * mullins_factor(p, v("mullins"), v("mullins.exponent"))
        # a last row: the same load case at 0 kPa, the reference of the injected volume
        p_m = np.append(x / stiff, 0.0)
        stiff = np.append(stiff, scale)
        p_eff, ratio, stretch = self._stiffening(p_m, v("strain_stiffening"), v("strain_stiffening.c30_mpa"))
        t = self.tables
        layer = v("layer_compliance")
        soft, soft_v, layer_stretch = self.layer_softening(layer, p_eff) if layer > 0 else (1.0, 1.0, 1.0)
        p_bend = p_eff["bend"] * soft  # the shape reads the free law further on
        p_vol = p_eff["volume"] * soft_v
        excess = self._past_maximum(np.maximum(p_bend, p_vol))
        past = excess > 0
        if past.any():  # no equilibrium there: the state at the maximum, the nearest the model comes
            if not partial:
                at = ", ".join(f"{q:.4g}" for q in p[past[:-1]][:5])
                raise SolveError(f"reduced model: no equilibrium of {self.design.name} at {at} kPa: beyond the FE's "
                                 f"{self.characterisation.reason}")
            reach = self._reach_kpa()
            p_bend, p_vol = np.minimum(p_bend, reach), np.minimum(p_vol, reach)
        soft = np.broadcast_to(soft, p_bend.shape)
        stretch = np.broadcast_to(stretch * layer_stretch, p_bend.shape)
        angle = _interp(t.p, t.angle, p_bend)
        length = _interp(t.p, t.length, p_bend) * np.where(self.free_edge, stretch[:, None], 1.0)
        comp = _interp(t.p, t.compliance, p_bend, extrapolate=False) * (soft / (stiff * ratio))[:, None]
        if protocol.kind == "force":
            comp = comp * self.blocked_compliance
        dhinge = np.diff(_slope(t.p, t.angle, p_bend), axis=1, prepend=0.0) * soft[:, None]  # rad per kPa of p_eff
        k_contact = v("self_contact")
        if k_contact > 0:
            pc = self.contact_pressure_kpa(v("self_contact.gap_scale"))
            over = p_bend > pc
            if np.isfinite(pc) and over.any():
                at_pc = _interp(t.p, t.angle, np.full(int(over.sum()), pc))
                angle[over] = at_pc + (angle[over] - at_pc) / (1.0 + k_contact)
                comp[over] /= 1.0 + k_contact
                dhinge[over] /= 1.0 + k_contact
        gxz = self._gravity_xz(protocol.orientation, v("gravity"))
        try:
            state = self._equilibria(angle, length, comp, gxz, 0.0 if protocol.kind == "force" else None, partial)
        except RodError as err:
            at = ", ".join(f"{q:.4g}" for q in np.append(p, 0.0)[err.rows][:5])
            why = (": past a limit point the blocked tip slides back on the frictionless plane"
                   if protocol.kind == "force" else "")
            raise SolveError(f"reduced model: no equilibrium of {self.design.name} at {at} kPa ({protocol.kind}, "
                             f"{protocol.orientation}, gravity {v('gravity'):g} g){why}") from err
        tip = state.nodes_mm[:, -1]
        bend = np.degrees(state.angle_rad[:, -1]) + _interp(t.p, t.offset_deg, p_bend)
        volume = _interp(t.p, t.volume_ml, p_vol) + np.sum(state.moment_n_mm * dhinge, axis=1) / (stiff * ratio)
        m, cal = protocol.measurement, _calibration(calibration or {})
        tip_x, tip_z = read_tip(tip[:-1, 0], tip[:-1, 1], (tip[-1, 0], tip[-1, 1]), m, cal)
        out = {"pressure_kpa": p.copy(), "tip_x_mm": tip_x, "tip_z_mm": tip_z,
               "bend_angle_deg": read_bend(bend[:-1], m, self.design.free_length_mm),
               "cavity_volume_ml": volume[:-1],
               "volume_ml": read_volume(volume[:-1] - volume[-1], volume[-1], p, m, v("dead_volume")),
               "max_principal_stretch": _interp(t.p, t.stretch, p_vol[:-1]),
               "beyond_fe": past[:-1] | (p_bend[:-1] > t.p[-1] * (1.0 + BEYOND_FE_SHARE)),
               "pressure_excess": excess[:-1]}
        if protocol.kind == "force":
            out["force_n"] = state.force_n[:-1]
        return out

    def _run_by_volume(self, protocol: Protocol, effects, params, calibration, partial: bool
                       ) -> dict[str, np.ndarray]:
        """:meth:`run` of a protocol read by its volume (:func:`pnmold.physics.reading.at_volumes`): the model's
        curve on a pressure grid up to :data:`VOLUME_GRID_REACH` x the recorded top, read at the recorded volumes."""
        top = VOLUME_GRID_REACH * max(float(np.max(protocol.pressure_kpa)), 1.0)
        grid = Protocol(protocol.kind, np.linspace(0.0, top, VOLUME_GRID_POINTS), protocol.orientation,
                        measurement=protocol.measurement)
        out = at_volumes(self.run(grid, effects, params, calibration, partial=True), protocol.volume_ml)
        if not partial and np.any(out["volume_excess"] > 0):
            raise SolveError(f"reduced model: {self.design.name} cannot take "
                             f"{float(np.max(protocol.volume_ml)):.4g} mL: {self.characterisation.reason}")
        return out

    def _past_maximum(self, p_read: np.ndarray) -> np.ndarray:
        """Per row, the share of its pressure beyond the FE's pressure maximum (1 - p_max / p, on the
        free law's pressure ``p_read``) when the characterisation ended at one, else 0: under pressure
        control there is no equilibrium past a limit point (the actuator snaps), so the law is not
        extrapolated there; the share says how far out of reach the row is."""
        top = self._reach_kpa()
        if not np.isfinite(top):
            return np.zeros_like(p_read)
        return np.where(p_read > top, 1.0 - top / np.maximum(p_read, top), 0.0)

    def _reach_kpa(self) -> float:
        """The free law's pressure past which a row has no equilibrium: the FE's maximum when its run ended
        at one; for a laddered model whose runs ended at a bifurcation, :data:`LADDER_EXTRAPOLATION` past
        their end (the law extrapolated up to there); else none (inf)."""
        c, top = self.characterisation, float(self.tables.p[-1])
        if c.ends_at_pressure_maximum:
            return top
        return top * (1.0 + LADDER_EXTRAPOLATION) if c.source == "ladder" else float("inf")


    def _equilibria(self, angle: np.ndarray, length: np.ndarray, comp: np.ndarray, gxz: tuple[float, float],
                    plane: float | None, partial: bool) -> RodState:
        """The rod's equilibrium of every row; with ``partial`` the rows that have none are solved
        without and come back as NaN (the last row, the unloaded reference, must have one)."""
        rows = angle.shape[0]
        ok = np.ones(rows, bool)
        while True:
            try:
                state = solve_rod(angle[ok], length[ok], comp[ok], self.loads, gxz, plane)
                break
            except RodError as err:
                failed = np.flatnonzero(ok)[err.rows]
                if not partial or failed[-1] == rows - 1:
                    raise RodError(failed) from None
                ok[failed] = False
        if ok.all():
            return state

        def spread(a: np.ndarray) -> np.ndarray:
            out = np.full((rows, *a.shape[1:]), np.nan)
            out[ok] = a
            return out

        return RodState(spread(state.angle_rad), spread(state.nodes_mm), spread(state.moment_n_mm),
                        spread(state.force_n), state.iterations)


def _calibration(calibration: Mapping[str, float]) -> dict[str, float]:
    out = {k: nominal for k, (nominal, _) in CALIBRATION.items()}
    for key, value in calibration.items():
        if key not in CALIBRATION:
            raise DesignError(f"calibration.{key}", f"unknown; the reduced model calibrates {', '.join(CALIBRATION)}")
        lo, hi = CALIBRATION[key][1]
        if not (lo <= float(value) <= hi):
            raise DesignError(f"calibration.{key}", f"{value:g} is outside [{lo:g}, {hi:g}]")
        out[key] = float(value)
    return out


#: the pressure grid a recording read by its volume is solved on: up to this multiple of its top recorded
#: pressure (a model the calibration makes stiffer needs more to take the same volume), in this many points
#: (assumed: the curve read by linear interpolation between points about 1 kPa apart)
VOLUME_GRID_REACH, VOLUME_GRID_POINTS = 2.0, 81
#: points along a laddered curve (shares of its final bend)
LADDER_POINTS = 61
#: how far past the end of ladder runs that met a bifurcation (pressure still rising) their law is
#: extrapolated, as a share of the end's pressure; beyond, no equilibrium (assumed: without a bound a fit
#: reaches for the cheap straight line, on the ribbed segment's P-V 45 % past the end)
LADDER_EXTRAPOLATION = 0.1


def _along(run: Mapping[str, np.ndarray], share: np.ndarray) -> dict[str, np.ndarray]:
    """A run's curves at ``share`` of its final bend (the bend kept rising: a stalled step is skipped)."""
    bend = np.maximum.accumulate(np.asarray(run["bend_angle_deg"], float))
    keep = np.concatenate([[True], np.diff(bend) > 0])
    at = share * bend[keep][-1]
    return {k: np.interp(at, bend[keep], np.asarray(run[k], float)[keep]) for k in CURVES}


def _ladder_characterisation(model: ReducedModel, c30_mpa: float) -> Characterisation:
    """The characterisation at Yeoh C30 + ``c30_mpa`` from the ladder of ``model`` (see
    :meth:`ReducedModel.laddered`)."""
    ladder, c = model.ladder, model.characterisation
    values = np.array([r["value"] for r in ladder])
    j = int(np.clip(np.searchsorted(values, c30_mpa) - 1, 0, len(ladder) - 2))
    w = (c30_mpa - values[j]) / (values[j + 1] - values[j])
    share = np.linspace(0.0, 1.0, LADDER_POINTS)
    lo, hi = _along(ladder[j], share), _along(ladder[j + 1], share)
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

    x, angle, length, comp = ((c.rod_x_mm, c.rod_angle_rad, c.rod_length_mm, c.compliance_rad_per_n_mm)
                              if c.has_rod else _even_rod(model.design, c))
    p, b = curves["pressure_kpa"][-1], bend[-1]
    # a maximum where the pressure peaks inside, or where both runs end at one; a run that ends where the FE
    # meets a bifurcation (``instability``, the pressure still rising) leaves the law beyond to extrapolation
    ends = [ladder[j + 1]] if w >= 1.0 else [ladder[j], ladder[j + 1]]
    maximum = top < LADDER_POINTS - 1 or all(r.get("stop") == "pressure_maximum" for r in ends)
    runs = f"Yeoh C30 + {c30_mpa:.3g} MPa, between the FE's runs at {values[j]:g} and {values[j + 1]:g} MPa"
    return Characterisation(
        **curves, design_name=c.design_name, design_digest=c.design_digest, full_bend_pressure_kpa=None,
        reason=(f"pressure maximum of {p:.4g} kPa at {b:.1f} deg bend ({runs})" if maximum else
                f"the FE's runs end where their path meets a critical point (their pressure still rising): "
                f"{p:.4g} kPa at {b:.1f} deg bend ({runs})"),
        mesh=c.mesh, rod_x_mm=x, rod_angle_rad=rows(angle) * scale[:, None], rod_length_mm=rows(length),
        compliance_rad_per_n_mm=rows(comp), source="ladder", blocked=c.blocked)


def _even_rod(design: Design, c: Characterisation):
    """Rod for a characterisation from steps only: the bend spread evenly over the free length."""
    xc, L = design.clamp_end_mm, design.length_mm
    n = max(4 * (design.chambers.count - 1), 4)
    x = np.concatenate([[0.0], np.linspace(xc, L, n + 1)])
    mid = (x[:-1] + x[1:]) / 2
    frac = np.clip((mid - xc) / (L - xc), 0.0, None) * (mid > xc)
    angle = np.radians(c.bend_angle_deg)[:, None] * frac[None, :]
    length = np.tile(np.diff(x), (len(c.pressure_kpa), 1))
    comp = slab_flexibility(design, x) * (x[:-1] >= xc - 1e-9)
    return x, angle, length, np.tile(comp, (len(c.pressure_kpa), 1))


def _contact_onset(design: Design, c: Characterisation, gap_scale: float) -> float:
    """Pressure where 2 x the inside walls' bulge equals the gap opened at mid-height (fPN only)."""
    if design.gap_mm <= 0:
        return float("inf")
    ch = design.chambers
    n = ch.count
    z0 = design.top_z0_mm - design.bottom_z0_mm  # the top layer's base above the bottom layer's face
    theta = np.radians(c.bend_angle_deg) / max(n - 1, 1)
    dv = (c.cavity_volume_ml - c.cavity_volume_ml[0]) * 1000.0 / n
    wedge = theta * ch.width_mm * ((z0 + ch.height_mm) ** 2 - z0 ** 2) / 2
    bulge = 9.0 * np.maximum(dv - wedge, 0.0) / (8.0 * ch.width_mm * ch.height_mm)
    margin = 2 * bulge - (gap_scale * design.gap_mm + theta * (z0 + ch.height_mm / 2))
    hit = np.flatnonzero((margin[1:] >= 0) & (margin[:-1] < 0))
    if not hit.size:
        return float("inf")
    i = hit[0]
    p = c.pressure_kpa
    return float(p[i] + (0.0 - margin[i]) / (margin[i + 1] - margin[i]) * (p[i + 1] - p[i]))
