"""The reduced model: a planar rod of the bottom face, informed by the FE of the same design
(docs/reduced-model.md).

Per protocol row, in this order (every step vectorised over the rows):

1. **History** (:mod:`.history`): the viscoelastic filter gives the relaxed-equivalent
   pressure, the Mullins factor the row's first-loading stiffening.
2. **Material**: the free law (:mod:`.rom_law`) is read at ``p_eff``: the pressure divided by
   ``modulus_scale`` x the Mullins factor, and by the strain-stiffening factor ``r``
   (``p = p_eff r(p_eff)``, inverted on a fine table). ``r`` comes from the FE's own run with
   stiffer rubber (:mod:`.response`), separately for the shape and for the volume; past the FE's
   pressure maximum, from the stiffening ladder (:mod:`.rom_ladder`). The law is read only up to
   the FE's last solved step, whatever ended it (full bend, a physical stop, the pressure cap): a
   row past it is out of reach (:meth:`ReducedModel.run`'s ``partial``), not extrapolated; the
   one exception is a ladder run that met a bifurcation, read 10 % past its end (assumed, said).
3. **Free shape**: each bottom-line edge's angle and length at ``p_eff`` from the FE steps
   (linear in pressure between steps); self-contact makes the shape and the volume read the law
   where the FE's own run with it reaches the same bend and volume (:mod:`.rom_effects`).
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

How each effect enters: :mod:`.rom_effects` (the catalogue: docs/effects.md). Assumed: the bend
lives in the x-z plane (held horizontal, only the share of the weight the body's roll brings into each
hinge's plane bends it: :mod:`.roll`; docs/frame-and-units.md), the hinge
compliance is linear in the moment (checked against 1 g by ``tests/test_rom.py``), the
pressure-side effects act on the whole actuator alike.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from pnmold import effects as fx
from pnmold.conventions import NO_GRAVITY
from pnmold.design import Design
from pnmold.errors import DesignError, RodError, SolveError
from pnmold.physics.characterisation import Characterisation, distinct_steps
from pnmold.physics.characterise import CONTACT_KEY, LADDER_EFFECT, characterise
from pnmold.physics.history import mullins_factor, viscoelastic_pressure
from pnmold.physics.protocol import Protocol
from pnmold.physics.reading import FRAME, at_volumes, read_bend, read_tip, read_volume
from pnmold.physics.rod import RodLoads, RodState, solve_rod
from pnmold.physics.roll import roll_axis_mm, rolled, stiffened, world
from pnmold.physics.rom_effects import (
    contact_compliance,
    gravity_xz,
    layer_compliance,
    layer_softening,
    self_contact,
    stiffening,
    variant_responses,
)
from pnmold.physics.rom_ladder import LADDER_EXTRAPOLATION, ladder_characterisation, ladder_of
from pnmold.physics.rom_law import free_law, interp, slope
from pnmold.physics.section import rod_loads

#: name -> (nominal, bounds): the rubber's modulus as a multiple of the design's (a wrong material shows as
#: 10x, assumed limits; every Yeoh term alike, so a stiffer batch also sags less under its weight), the batch's
#: density as a multiple of the design's (assumed limits: a rubber full of air or of filler), and a camera
#: frame's offset and rotation (:mod:`.reading`)
CALIBRATION = {"modulus_scale": (1.0, (0.02, 50.0)), "density_scale": (1.0, (0.5, 2.0)), **FRAME}
#: a roll probe whose sections roll less than this (deg, at 1 g) leaves the weight out of the plane held on its side
#: (assumed: sin(1 deg) of the weight; a body symmetric about its mid-plane rolls nothing, and its rod solved under
#: so small a share, rather than not at all, lost rows the diagnosis of the real segment's two-sided design needed)
MIN_ROLL_DEG = 1.0
#: a row is past the FE's last solved step when its effective pressure passes it by more than this share (rounding)
PAST_END_SHARE = 1e-9
#: the pressure grid a recording read by its volume is solved on: up to this multiple of its top recorded
#: pressure (a model the calibration makes stiffer needs more to take the same volume), in this many points
#: (assumed: the curve read by linear interpolation between points about 1 kPa apart)
VOLUME_GRID_REACH, VOLUME_GRID_POINTS = 2.0, 81


@dataclass(frozen=True, eq=False)
class _LawPressures:
    """Where a run's rows read the free law, and the factors on their hinges' compliance. One row more
    than the protocol: the same load case at 0 kPa, the reference of the injected volume."""

    stiff: np.ndarray  # modulus scale x the Mullins factor
    ratio: np.ndarray  # the strain stiffening's factor on the shape's pressure
    soft: np.ndarray  # the layer compliance's factor on the shape's pressure
    stretch: np.ndarray  # the free part's stretch (strain stiffening x layer compliance)
    p_bend: np.ndarray  # the free law's pressure the shape reads
    p_vol: np.ndarray  # the free law's pressure the volume reads
    excess: np.ndarray  # the share of the row's pressure past the FE's last solved step (0: within reach)
    past: np.ndarray  # excess > 0


class ReducedModel:
    """Rod of chamber hinges with the FE's free law and compliance; see the module docstring."""

    def __init__(self, design: Design, characterisation: Characterisation):
        if len(distinct_steps(characterisation.pressure_kpa)) < 2:
            raise DesignError("characterisation", "needs at least two FE steps at distinct pressures")
        self.design, self.characterisation = design, characterisation
        x, self.tables = free_law(design, characterisation)
        self.x_mm = x
        self.loads: RodLoads = rod_loads(design, x)
        self.free_edge = x[:-1] >= design.clamp_end_mm - 1e-6
        #: effect -> {"bend", "volume", "length": Response} from the FE's variant runs
        self.responses = variant_responses(design, characterisation, self.tables)
        runs = characterisation.variant_runs("self_contact")
        #: the FE's run with self-contact: its response and where it ended (kPa), and why; None without one
        self.contact = (self.responses["self_contact"], float(runs[0]["pressure_kpa"][-1]),
                        characterisation.variants[CONTACT_KEY].get("reason") or "full bend") if runs else None
        #: the stiffening ladder (:func:`pnmold.physics.characterise.stiffening_ladder`): the nominal law and the
        #: FE's free runs with Yeoh C30 added, by C30; only where the free run ends at a pressure maximum
        self.ladder = ladder_of(characterisation)
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
        variants: a C20 or a layer compliance on top takes the analytic forms (:mod:`.rom_effects`), a
        self-contact the nominal's response."""
        if not self.ladder:
            raise DesignError("strain_stiffening.c30_mpa", "this model has no stiffening ladder")
        if not 0.0 < c30_mpa <= self.ladder_top_mpa * (1.0 + 1e-9):
            raise DesignError("strain_stiffening.c30_mpa", f"{c30_mpa:g} MPa is outside the stiffening ladder's "
                                                           f"(0, {self.ladder_top_mpa:g}] MPa")
        if c30_mpa not in self._laddered:
            if len(self._laddered) > 256:
                self._laddered.clear()
            model = ReducedModel(
                self.design, ladder_characterisation(self.design, self.characterisation, self.ladder, c30_mpa))
            model.contact = self.contact  # the nominal rubber's contact run, read on the stiffer law (assumed)
            self._laddered[c30_mpa] = model
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

    # -- the terms (:mod:`.rom_effects`) -------------------------------------------------------------
    def _contact_law(self) -> tuple[dict, float, str]:
        """:attr:`contact`; a :class:`SolveError` without the FE's run with self-contact."""
        if self.contact is None:
            raise SolveError(f"reduced model: self_contact is read from the FE's free run of {self.design.name} "
                             "with its self-contact on, which this characterisation lacks "
                             "(pnmold.physics.characterise.self_contact_run)")
        return self.contact

    def layer_softening(self, compliance_mm_per_n: float, p_eff: Mapping[str, np.ndarray]
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Factors on the pressure the shape and the volume read with an added layer compliance, and
        the stretch of the free part (:func:`pnmold.physics.rom_effects.layer_softening`)."""
        return layer_softening(self.design, self.tables, self.responses.get("layer_compliance"),
                               compliance_mm_per_n, p_eff)

    # -- the run ------------------------------------------------------------------------------------
    def run(self, protocol: Protocol, effects: Mapping[str, float] | None = None,
            params: Mapping[str, float] | None = None,
            calibration: Mapping[str, float] | None = None, partial: bool = False) -> dict[str, np.ndarray]:
        """Every protocol row's observables (recording columns of its kind, and more), read as the
        protocol's recording measures them (:mod:`.reading`); ``beyond_fe``: the rows whose
        pressure lies past what the FE solved (out of reach: the law is not read there).

        ``effects``: values by name (and ``NAME.PARAM``), unnamed ones at their catalogue
        default (gravity 1 g, the rest off); ``params``: more ``NAME.PARAM`` values;
        ``calibration``: nominal parameters (``modulus_scale`` and ``density_scale``, 1 = the design's
        rubber; a camera frame's offset and rotation). ``partial``: rows without an equilibrium (past a limit point)
        come back as NaN instead of raising :class:`SolveError`; rows past the FE's last solved step (its
        pressure maximum, full bend, a physical stop or its pressure cap; none without ``partial``: an
        error) carry the state there, the nearest the model comes, and ``pressure_excess`` > 0, the share
        of their pressure the model cannot hold."""
        if protocol.by_volume:
            return self._run_by_volume(protocol, effects, params, calibration, partial)
        values = fx.check_effects({**(effects or {}), **(params or {})}, model="rom")
        cal = _calibration(calibration or {})

        def v(key):
            return fx.value_of(values, key)

        if self.ladder and v(LADDER_EFFECT) > 0:  # the stiffer rubber's own law (see laddered)
            return self.laddered(v(LADDER_EFFECT)).run(protocol, {**values, LADDER_EFFECT: 0.0}, None, calibration,
                                                       partial)
        law = self._law_pressures(protocol, v, cal["modulus_scale"], partial)
        angle, length, comp, dhinge = self._hinges(law, protocol.kind, v, protocol.orientation)
        state = self._equilibrium(protocol, angle, length, comp, v, partial, cal["density_scale"], law)
        return self._observables(protocol, law, state, dhinge, cal, v)

    def _law_pressures(self, protocol: Protocol, v: Callable[[str], float], scale: float, partial: bool
                       ) -> _LawPressures:
        """Steps 1-2 of the module docstring: the history's pressure and stiffness, the stiffening's and the
        layer compliance's pressures on the free law, held at the FE's last solved step past it (with
        ``partial``; else :class:`SolveError`)."""
        p = protocol.pressure_kpa
        x = viscoelastic_pressure(p, protocol.times_s(), v("viscoelasticity"), v("viscoelasticity.tau_s"))
        stiff = scale * mullins_factor(p, v("mullins"), v("mullins.exponent"))
        # a last row: the same load case at 0 kPa, the reference of the injected volume
        p_m = np.append(x / stiff, 0.0)
        stiff = np.append(stiff, scale)
        p_eff, ratio, stretch = stiffening(self.design, self.tables, self.responses.get("strain_stiffening"), p_m,
                                           v("strain_stiffening"), v("strain_stiffening.c30_mpa"))
        layer = v("layer_compliance")
        soft, soft_v, layer_stretch = self.layer_softening(layer, p_eff) if layer > 0 else (1.0, 1.0, 1.0)
        p_bend = p_eff["bend"] * soft  # the shape reads the free law further on
        p_vol = p_eff["volume"] * soft_v
        touch = v("self_contact")
        beyond_contact = np.zeros_like(p_bend)
        if touch > 0:
            p_bend, p_vol, contact_stretch, beyond_contact = self_contact(
                *self._contact_law()[:2], touch, p_bend, p_vol)
            layer_stretch = layer_stretch * contact_stretch
        excess = np.maximum(self._past_end(np.maximum(p_bend, p_vol)), beyond_contact)
        past = excess > 0
        if past.any():  # out of reach: the state at the FE's last solved step, the nearest the model comes
            if not partial:
                at = ", ".join(f"{q:.4g}" for q in p[past[:-1]][:5])
                c = self.characterisation
                if beyond_contact.any():
                    _, end, why = self._contact_law()
                    raise SolveError(f"reduced model: {self.design.name} at {at} kPa lies past the end of the FE's "
                                     f"run with self-contact ({end:.4g} kPa on the design's rubber: {why}); the "
                                     "law is not read past it")
                if c.ends_at_pressure_maximum:
                    raise SolveError(f"reduced model: no equilibrium of {self.design.name} at {at} kPa: beyond the "
                                     f"FE's {c.reason}")
                raise SolveError(f"reduced model: {self.design.name} at {at} kPa lies past the last pressure the FE "
                                 f"solved ({self._reach_kpa():.4g} kPa on the design's rubber: {c.end_reason}); "
                                 "the law is not read past it")
            reach = self._reach_kpa()
            p_bend, p_vol = np.minimum(p_bend, reach), np.minimum(p_vol, reach)
        return _LawPressures(stiff, ratio, np.broadcast_to(soft, p_bend.shape),
                             np.broadcast_to(stretch * layer_stretch, p_bend.shape), p_bend, p_vol, excess, past)

    def _hinges(self, law: _LawPressures, kind: str, v: Callable[[str], float], orientation: str
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Step 3 of the module docstring: the edges' free angle and length, the hinges' compliance (the one
        identified under a weight that opens the bend where the orientation's weight does, chambers down)
        and their free rotation per kPa of ``p_eff``, self-contact applied."""
        t = self.tables
        angle = interp(t.p, t.angle, law.p_bend)
        length = interp(t.p, t.length, law.p_bend) * np.where(self.free_edge, law.stretch[:, None], 1.0)
        down = opens_the_bend(orientation, kind) and t.compliance_down is not None
        compliance, soft = layer_compliance(self.design, t, down, v("layer_compliance"), law.soft)
        compliance = contact_compliance(t, down, v("self_contact"), compliance)
        comp = interp(t.p, compliance, law.p_bend, extrapolate=False) * (soft / (law.stiff * law.ratio))[:, None]
        if kind == "force":
            comp = comp * self.blocked_compliance
        dhinge = np.diff(slope(t.p, t.angle, law.p_bend), axis=1, prepend=0.0) * law.soft[:, None]  # rad per kPa
        return angle, length, comp, dhinge

    def _equilibrium(self, protocol: Protocol, angle: np.ndarray, length: np.ndarray, comp: np.ndarray,
                     v: Callable[[str], float], partial: bool, density_scale: float, law: _LawPressures) -> RodState:
        """Step 4 of the module docstring: the rod's equilibria under the weight (and, for ``force``, the
        plane); held on its side and free, with the body's roll (:mod:`.roll`; its compliance stiffened at the
        row's effective pressure and divided by its stiffness factor) where the characterisation has the roll
        probe. A blocked tip held on its side keeps the weight out of its plane, as before the roll (assumed:
        the plane under the tip takes the roll's small sag; the blocked probe that scales the tip's compliance
        has no weight). A row without one raises :class:`SolveError` unless ``partial``."""
        gxz = gravity_xz(self.design, protocol.orientation, v("gravity"), density_scale)
        plane = 0.0 if protocol.kind == "force" else None
        roll = self.characterisation.roll_compliance_rad_per_n_mm
        probe = self.characterisation.probe_roll or {}
        if roll is not None and max(np.abs(probe.get("node_roll_deg", [0.0]))) < MIN_ROLL_DEG:
            roll = None  # no roll to speak of (a symmetric body): the weight stays out of the plane
        try:
            if protocol.orientation != "horizontal" or roll is None or v("gravity") == 0 or protocol.kind == "force":
                return self._equilibria(angle, length, comp, gxz, plane, partial)
            g = v("gravity") * density_scale

            def solve(share: np.ndarray, last: RodState | None) -> RodState:
                """The rod under the rolled weight, from the last state, else from the free shape."""
                if last is not None:
                    start = np.nan_to_num(np.diff(last.angle_rad - angle, axis=1, prepend=0.0))
                    try:
                        return self._equilibria(angle, length, comp, (0.0, g), plane, partial, start, share)
                    except RodError:
                        pass
                return self._equilibria(angle, length, comp, (0.0, g), plane, partial, None, share)

            roll = stiffened(roll, law.p_bend, self.characterisation.roll_stiffening) / law.stiff[:, None]
            return rolled(solve, roll, self.loads, g, roll_axis_mm(self.design), partial)
        except RodError as err:
            at = ", ".join(f"{q:.4g}" for q in np.append(protocol.pressure_kpa, 0.0)[err.rows][:5])
            why = (": past a limit point the blocked tip slides back on the frictionless plane"
                   if protocol.kind == "force" else "")
            raise SolveError(f"reduced model: no equilibrium of {self.design.name} at {at} kPa ({protocol.kind}, "
                             f"{protocol.orientation}, gravity {v('gravity'):g} g){why}") from err

    def _observables(self, protocol: Protocol, law: _LawPressures, state: RodState, dhinge: np.ndarray,
                     cal: Mapping[str, float], v: Callable[[str], float]) -> dict[str, np.ndarray]:
        """Step 5 of the module docstring: the protocol's rows' observables, read as its recording
        measures them (the reference row dropped)."""
        t, p = self.tables, protocol.pressure_kpa
        end = state.angle_rad[:, -1] + np.radians(interp(t.p, t.offset_deg, law.p_bend))
        nodes = state.nodes_mm
        if state.roll_rad is not None:  # held on its side and rolled: as the camera sees it (:func:`.roll.world`)
            nodes, end = world(nodes, end, state.roll_rad)
        tip, bend = nodes[:, -1], np.degrees(end)
        volume = interp(t.p, t.volume_ml, law.p_vol) + np.sum(state.moment_n_mm * dhinge, axis=1) / (
            law.stiff * law.ratio)
        m = protocol.measurement
        tip_x, tip_z = read_tip(tip[:-1, 0], tip[:-1, 1], (tip[-1, 0], tip[-1, 1]), m, cal)
        out = {"pressure_kpa": p.copy(), "tip_x_mm": tip_x, "tip_z_mm": tip_z,
               "bend_angle_deg": read_bend(bend[:-1], m, self.design.free_length_mm),
               "cavity_volume_ml": volume[:-1],
               "volume_ml": read_volume(volume[:-1] - volume[-1], volume[-1], p, m, v("dead_volume")),
               "max_principal_stretch": interp(t.p, t.stretch, law.p_vol[:-1]),
               "beyond_fe": law.past[:-1] | (law.p_bend[:-1] > t.p[-1] * (1.0 + PAST_END_SHARE)),
               "pressure_excess": law.excess[:-1]}
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

    def _past_end(self, p_read: np.ndarray) -> np.ndarray:
        """Per row, the share of its pressure past the FE's last solved step (1 - p_top / p, on the free
        law's pressure ``p_read``), else 0. The law is not read past that step, whatever ended it: at a
        pressure maximum the actuator has no equilibrium under pressure control (it snaps); at full bend
        the free end meets the clamped end; past a physical stop or the pressure cap the FE did not solve
        (:attr:`pnmold.physics.characterisation.Characterisation.how_ended`). The share says how far out
        of reach the row is. (A laddered model whose runs met a bifurcation: :meth:`_reach_kpa`.)"""
        top = self._reach_kpa()
        return np.where(p_read > top * (1.0 + PAST_END_SHARE), 1.0 - top / np.maximum(p_read, top), 0.0)

    def _reach_kpa(self) -> float:
        """The free law's last solved pressure: past it a row is out of reach. The one exception: a laddered
        model whose runs ended at a bifurcation is read :data:`LADDER_EXTRAPOLATION` past their end (assumed,
        flagged ``beyond_fe``; see there)."""
        c, top = self.characterisation, float(self.tables.p[-1])
        return top * (1.0 + LADDER_EXTRAPOLATION) if c.source == "ladder" and c.how_ended == "instability" else top

    def _equilibria(self, angle: np.ndarray, length: np.ndarray, comp: np.ndarray, gxz: tuple[float, float],
                    plane: float | None, partial: bool, start: np.ndarray | None = None,
                    share: np.ndarray | None = None) -> RodState:
        """The rod's equilibrium of every row (``start``: the hinges' rotations to start from; ``share``: the
        share of the weight's moment each hinge feels, :func:`.rod.solve_rod`); with ``partial`` the rows that
        have none are solved without and come back as NaN (the last row, the unloaded reference, must have
        one)."""
        rows = angle.shape[0]
        ok = np.ones(rows, bool)
        while True:
            try:
                state = solve_rod(angle[ok], length[ok], comp[ok], self.loads, gxz, plane,
                                  None if start is None else start[ok], None if share is None else share[ok])
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


def opens_the_bend(orientation: str, kind: str = "bending") -> bool:
    """The orientation's weight turns the actuator against its bend (toward +z): chambers down, and held on
    its side (free, not blocked: :meth:`ReducedModel._equilibrium`), where the rolled body's weight in its
    bending plane points toward the chambers (:mod:`.roll`)."""
    return orientation == "chambers_down" or (orientation == "horizontal" and kind != "force")


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
