"""The step model of an actuator, compiled: one for ``simulate --dynamic`` and ``diagnose``.

A :class:`StepModel` holds the actuator (chamber law, air path, bending mode); for a bench
(:class:`~pnmold.pneumatics.network.Rig`) and a modulus scale it lowers
:func:`~pnmold.pneumatics.network.bench_network` and the bending mode to the named arrays
of :mod:`pnmold.pneumatics.rates` and integrates them with the TR-BDF2 of
:mod:`pnmold.pneumatics.trbdf2` (a few ms per run of a recording once compiled; the
first run compiles, about 10 s, then numba caches it on disk). ``modulus_scale`` s is the exact scaling of an
elastomer whose constants all scale by s: the law at pressure p is the nominal law at
p / s. The contact stop at full bend holds twice the supply's pressure moment within one
degree (assumed), critically damped. The chamber law is read only within what the FE solved:
the integration stops at the first time a chamber's pressure or the bend reaches the law's
last (:class:`~pnmold.pneumatics.law.LawEnd`), and says so (:attr:`Trajectory.stopped_by`);
the rows after it are NaN.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pnmold.conventions import FULL_BEND_DEG
from pnmold.errors import SolveError
from pnmold.pneumatics.gas import RHO_STD, slpm_from_kg_s
from pnmold.pneumatics.law import ChamberLaw, CurveLaw, LawEnd, Pieces, as_curve_law
from pnmold.pneumatics.mechanics import BendingDynamics, inertia_pieces
from pnmold.pneumatics.network import TUBING_ID_MM, ActuatorLine, Network, Rig, bench_network
from pnmold.pneumatics.protocol import Schedule, StepProtocol
from pnmold.pneumatics.rates import ModeArrays, NetworkArrays, evaluate, observe
from pnmold.pneumatics.trbdf2 import OK, UNDERFLOW, Tolerances, integrate

FULL_BEND_RAD = math.radians(FULL_BEND_DEG)
CONTACT_MOMENT_FACTOR = 2.0  # assumed: the stop holds twice the supply's pressure moment ...
CONTACT_DEPTH_DEG = 1.0  # ... within 1 degree past full bend
MAX_SUPPLY_KPA = 1000.0
#: the diagnosis's tolerances (pressures to about 1 Pa): hundreds of runs per diagnosis
DIAGNOSIS = Tolerances(rtol=1e-6, atol_pa=1.0, atol_rad=1e-5, atol_rad_per_s=1e-3)
#: ``simulate --dynamic``'s: within about 1e-7 of each series' range of a tight Radau
#: solution, as accurate as the Radau (rtol 1e-7) it replaces (tests/test_pneumatics.py)
SIMULATION = Tolerances(rtol=1e-10, atol_pa=1e-5, atol_rad=1e-10, atol_rad_per_s=1e-8)
#: columns :meth:`StepModel.run` predicts (recording units)
COLUMNS = ("pressure_kpa", "flow_slpm", "bend_angle_deg", "pressure_far_kpa", "volume_ml")


@dataclass(frozen=True, eq=False)
class Lowered:
    """One bench and modulus scale lowered for the compiled model, with the mode's numbers."""

    network: Network
    net: NetworkArrays
    mode: ModeArrays
    y0: np.ndarray
    theta0_rad: float
    stiffness_nm_per_rad: float
    natural_frequency_hz: float
    #: the law's end: a chamber's absolute pressure (Pa) and the bend (rad) the integration stops at
    stop_pa: float = math.inf
    stop_rad: float = math.inf
    law_end: LawEnd | None = None
    modulus_scale: float = 1.0

    def stop_words(self, what: int) -> str:
        """Why the integration stopped at the law's end (``what``: the chamber's node, or n for the bend)."""
        end, s = self.law_end, self.modulus_scale
        scaled = ("" if abs(s - 1.0) < 1e-12 else
                  f" (the design's rubber's {end.pressure_kpa:.4g} kPa x modulus scale {s:.3g})")
        if what < self.network.n:
            head = (f"{self.network.names[what]} reached {end.pressure_kpa * s:.4g} kPa{scaled}, the last pressure "
                    f"the FE solved")
        else:
            head = f"the bend reached {end.angle_deg:.1f} deg, the last the FE solved"
        return f"{head} (the law {end.describe()}); past it the law is unknown, so the step model ends there"


@dataclass(frozen=True, eq=False)
class Trajectory:
    """The states at the output times (rows x [pressures, theta, omega, metered kg]; NaN after
    ``stop_t``), the first time the bend reached the event level (None if not), the steps taken,
    and when and why the integration stopped at the law's end (None: it did not)."""

    lowered: Lowered
    schedule: Schedule
    states: np.ndarray
    event_t: float | None
    steps: int
    stop_t: float | None = None
    stopped_by: str | None = None

    @property
    def solved_rows(self) -> int:
        """The output rows up to the law's end (all when the integration did not stop there)."""
        return int(np.count_nonzero(np.isfinite(self.states[:, 0])))

    def columns(self) -> dict[str, np.ndarray]:
        """The pneumatic and bending series at the output times (recording units): inlet,
        valve-side, first and last chamber pressures (gauge kPa), metered flow (SLPM) and gas
        (std mL), cavity volume and its change (mL), bend angle (deg); and ``chambers`` (rows x N)."""
        network, net = self.lowered.network, self.lowered.net
        n = network.n
        gauge = (self.states[:, :n] - network.p_atm_pa) / 1000
        chambers = gauge[:, network.chambers()]
        rows = self.solved_rows
        flow, cavity = np.full(len(self.states), np.nan), np.full(len(self.states), np.nan)
        flow[:rows], cavity[:rows] = observe(self.states[:rows], self.schedule.phase_rows()[:rows], net)
        rest, _ = evaluate(net.volume, 0.0)
        return {"pressure_kpa": gauge[:, network.names.index("inlet")],
                "pressure_valve_kpa": gauge[:, network.names.index("valve outlet")],
                "pressure_near_kpa": chambers[:, 0], "pressure_far_kpa": chambers[:, -1],
                "flow_slpm": slpm_from_kg_s(flow), "metered_std_ml": self.states[:, n + 2] / RHO_STD * 1e6,
                "volume_ml": cavity - rest, "cavity_volume_ml": cavity,
                "bend_angle_deg": np.degrees(self.states[:, n]), "chambers": chambers}


class StepModel:
    """The step response of an actuator, compiled: ``StepModel(design)`` (its FE chamber law)
    or :meth:`from_parts`; :meth:`run` replays a recording's protocol, :meth:`integrate`
    any schedule on any bench."""

    def __init__(self, design, law: ChamberLaw | None = None):
        from pnmold.pneumatics import law as laws

        law = law if law is not None else laws.chamber_law_for(design)
        self._setup(law, ActuatorLine.from_design(design), BendingDynamics.from_design(design),
                    design.inlet.tubing_id_mm, MAX_SUPPLY_KPA)

    @classmethod
    def from_parts(cls, law: ChamberLaw, line: ActuatorLine, bending: BendingDynamics, *,
                   tubing_id_mm: float = TUBING_ID_MM, p_max_kpa: float = MAX_SUPPLY_KPA) -> StepModel:
        """From a chamber law (any :class:`ChamberLaw`, sampled to ``p_max_kpa`` unless a
        :class:`CurveLaw`), an air path and a bending mode."""
        model = cls.__new__(cls)
        model._setup(law, line, bending, tubing_id_mm, p_max_kpa)
        return model

    def _setup(self, law: ChamberLaw, line: ActuatorLine, bending: BendingDynamics, tubing_id_mm: float,
               p_max_kpa: float) -> None:
        self.law: CurveLaw = as_curve_law(law, p_max_kpa)
        self.line, self.bending, self.tubing_id_mm = line, bending, float(tubing_id_mm)
        self.theta0 = math.radians(float(self.law.bend_angle_deg(0.0)))
        self._hold: Pieces = self.law.pressure_pieces()
        self._inertia: Pieces = inertia_pieces()
        self._dp0_kpa_per_deg = float(self.law.dpressure_dangle_kpa_per_deg(math.degrees(self.theta0)))
        self._j_full_kg_m2 = float(bending.inertia_kg_m2(FULL_BEND_RAD)[0])
        self.steps = 0  # integration steps of the last run

    def lower(self, rig: Rig, modulus_scale: float = 1.0) -> Lowered:
        """The bench network and the bending mode as the compiled model reads them."""
        network = bench_network(self.law, self.line, rig)
        net = network.lower(modulus_scale)
        bending, theta0 = self.bending, self.theta0
        dp = modulus_scale * self._dp0_kpa_per_deg * 1000 * 180 / math.pi  # Pa/rad
        stiffness, damping, natural_hz = bending.about_rest(theta0, dp)
        drive = bending.moment_per_pa * max(network.p_supply_pa - network.p_atm_pa, 1e3)
        contact_k = CONTACT_MOMENT_FACTOR * drive / math.radians(CONTACT_DEPTH_DEG)
        contact_c = 2 * math.sqrt(contact_k * self._j_full_kg_m2)
        weight = network.law_share / network.law_share.sum()
        mode = ModeArrays(True, bending.moment_per_pa, bending.mass_kg * bending.length_m ** 2, self._inertia,
                          self._hold, float(modulus_scale), damping, contact_k, contact_c, FULL_BEND_RAD, weight,
                          network.p_atm_pa)
        y0 = np.concatenate([np.full(network.n, network.p_atm_pa), [theta0, 0.0, 0.0]])
        law = self.law
        return Lowered(network, net, mode, y0, theta0, stiffness, natural_hz,
                       network.p_atm_pa + modulus_scale * law.top_kpa * 1000, math.radians(law.top_deg), law.end,
                       float(modulus_scale))

    def integrate(self, rig: Rig, schedule: Schedule, *, modulus_scale: float = 1.0,
                  tolerances: Tolerances = DIAGNOSIS, event_deg: float | None = None) -> Trajectory:
        """The states at the schedule's times on ``rig``; ``event_deg``: locate the first time
        the bend angle rises through it. SolveError when the integration fails."""
        lowered = self.lower(rig, modulus_scale)
        return run_lowered(lowered, schedule, tolerances, event_deg)

    def run(self, protocol: StepProtocol, effects: Mapping[str, float] | None = None,
            calibration: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
        """The recording's observables at its times (:data:`COLUMNS`): ``pressure_kpa``
        (inlet), ``flow_slpm`` (metered at the valves), ``bend_angle_deg``, ``pressure_far_kpa``
        (last chamber) and ``volume_ml`` (the cavity's volume change); effects
        ``dead_volume``, ``flow_restriction``; calibration ``modulus_scale``. Rows after the
        integration stopped at the law's end (a chamber or the bend reached the last the FE solved)
        are NaN: the model has no answer there (the diagnosis leaves them out as out of reach)."""
        effects = dict(effects or {})
        s = float((calibration or {}).get("modulus_scale", 1.0))
        dead = float(effects.get("dead_volume", 0.0))
        restriction = float(effects.get("flow_restriction", 0.0))
        if not (s > 0 and dead >= 0 and restriction >= 0):
            raise SolveError(f"step model: modulus_scale {s}, dead_volume {dead}, flow_restriction {restriction}")
        rig = protocol.rig(self.tubing_id_mm, dead_volume_ml=dead, flow_restriction=restriction)
        trajectory = self.integrate(rig, protocol.schedule, modulus_scale=s)
        self.steps = trajectory.steps
        cols = trajectory.columns()
        return {k: cols[k] for k in COLUMNS}


def run_lowered(lowered: Lowered, schedule: Schedule, tolerances: Tolerances,
                event_deg: float | None = None) -> Trajectory:
    """Integrate a lowered model over a schedule (:func:`pnmold.pneumatics.trbdf2.integrate`)."""
    level = math.radians(event_deg) if event_deg is not None else math.inf
    states, status, steps, event_t, stop_t, what = integrate(
        schedule.time_s, schedule.switch_s, schedule.phases, lowered.y0, lowered.net, lowered.mode,
        tolerances.atol(lowered.network.n), tolerances.rtol, tolerances.first_step_s, tolerances.max_steps, level,
        lowered.stop_pa, lowered.stop_rad)
    if status != OK:
        why = "step size underflow" if status == UNDERFLOW else f"more than {tolerances.max_steps} steps"
        raise SolveError(f"the step model's integration failed ({why})")
    stopped = not math.isnan(stop_t)
    return Trajectory(lowered, schedule, states, None if math.isnan(event_t) else float(event_t), int(steps),
                      float(stop_t) if stopped else None, lowered.stop_words(int(what)) if stopped else None)
