"""The step response: the pneumatic network coupled to the bending mode.

:func:`simulate_step` opens the supply valve at t = 0 (and, with ``rig.vent_at_s``,
closes it and opens the vent valve then), integrates the network of
:mod:`pnmold.pneumatics.network` and the bending mode of
:mod:`pnmold.pneumatics.mechanics`, and returns a :class:`StepResponse`: the time series
and the time to full bend (the first time the bend angle reaches 360 degrees, located
exactly by the integrator; None with the reason when never reached). The chambers'
volumes follow their own pressure through the law (the walls' local inflation is taken
as quasi-static: their membrane modes are far faster than the global bending mode);
the bend lags the mean chamber pressure through the bending mode's inertia and damping.
At full bend the free end meets the fixed end: beyond 360 degrees a stiff, critically
damped contact stop acts (assumed: it holds twice the supply's pressure moment within
1 degree), so the recorded angle stays near 360 degrees while the pressure keeps rising.

The chamber law is known only up to the FE's last solved step (:class:`~pnmold.pneumatics.law.LawEnd`):
when a chamber's pressure or the bend reaches it, the response ends there, with why
(``reason``; the series stop at that time), and the quasi-static full-bend pressure is given
only when the solved range reaches full bend.

Both run on the compiled model of :mod:`pnmold.pneumatics.model` (the TR-BDF2 of
:mod:`pnmold.pneumatics.trbdf2` over :mod:`pnmold.pneumatics.rates`) at the tolerances
:data:`~pnmold.pneumatics.model.SIMULATION`; the tests check it against scipy's Radau over
the same right-hand side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pnmold.conventions import FULL_BEND_DEG
from pnmold.errors import UsageError
from pnmold.pneumatics.law import ChamberLaw, Pieces
from pnmold.pneumatics.mechanics import BendingDynamics
from pnmold.pneumatics.model import (
    SIMULATION,
    Lowered,
    StepModel,
    Trajectory,
    run_lowered,
)
from pnmold.pneumatics.network import ActuatorLine, Network, Rig
from pnmold.pneumatics.protocol import SUPPLY, valve_schedule
from pnmold.pneumatics.rates import ModeArrays
from pnmold.pneumatics.trbdf2 import Tolerances

OUTPUT_STEP_S = 5e-4


@dataclass(frozen=True, eq=False)
class StepResponse:
    """Time series (``series``: name -> array, units in the names), chamber pressures
    (n_times x N, gauge kPa), the time to full bend or the reason, and the model's numbers."""

    series: dict[str, np.ndarray]
    chamber_pressure_kpa: np.ndarray
    time_to_full_bend_s: float | None
    reason: str | None
    info: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.series[name]

    def recording_columns(self) -> dict[str, np.ndarray]:
        """The ``step`` recording's columns (docs/recording-format.md) plus two extras (kept, ignored by readers)."""
        keys = ("time_s", "supply_kpa", "pressure_kpa", "flow_slpm", "bend_angle_deg", "tip_x_mm", "tip_z_mm",
                "pressure_far_kpa", "volume_ml")
        return {k: self.series[k] for k in keys}


def simulate_network(network: Network, duration_s: float, *, vent_at_s: float | None = None,
                     tolerances: Tolerances = SIMULATION, out_step_s: float = OUTPUT_STEP_S,
                     initial_pa: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Pneumatics only (no bending): time_s, node pressures (Pa, abs; nodes x times), metered kg.

    ``initial_pa``: the nodes' initial pressures (default: atmospheric)."""
    _check_duration(duration_s)
    p0 = np.full(network.n, network.p_atm_pa) if initial_pa is None else np.array(initial_pa, float)
    idle = Pieces(np.array([0.0, 1.0]), np.zeros((4, 1)), 0.0, 0.0, 0.0, 0.0)
    mode = ModeArrays(False, 0.0, 1.0, idle, idle, 1.0, 0.0, 0.0, 0.0, math.inf, np.zeros(network.n),
                      network.p_atm_pa)
    lowered = Lowered(network, network.lower(), mode, np.concatenate([p0, [0.0, 0.0, 0.0]]), 0.0, 0.0, 0.0)
    traj = run_lowered(lowered, valve_schedule(vent_at_s, duration_s, out_step_s), tolerances)
    n = network.n
    return {"time_s": traj.schedule.time_s, "pressure_pa": traj.states[:, :n].T, "metered_kg": traj.states[:, n + 2]}


def simulate_step(law: ChamberLaw, line: ActuatorLine, bending: BendingDynamics, rig: Rig, *,
                  duration_s: float = 0.5, tolerances: Tolerances = SIMULATION,
                  out_step_s: float = OUTPUT_STEP_S) -> StepResponse:
    """The step response of an actuator on a bench (see the module docstring)."""
    _check_duration(duration_s)
    model = StepModel.from_parts(law, line, bending, tubing_id_mm=rig.tubing_id_mm, p_max_kpa=rig.supply_kpa)
    schedule = valve_schedule(rig.vent_at_s, duration_s, out_step_s)
    event = FULL_BEND_DEG if model.theta0 < math.radians(FULL_BEND_DEG) else None
    traj = model.integrate(rig, schedule, tolerances=tolerances, event_deg=event)
    return _response(model, rig, traj, duration_s, tolerances)


def _check_duration(duration_s: float) -> None:
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise UsageError(f"duration_s must be > 0, got {duration_s}")


def _response(model: StepModel, rig: Rig, traj: Trajectory, duration_s: float, tolerances: Tolerances) -> StepResponse:
    law, low = model.law, traj.lowered
    rows = traj.solved_rows
    cols = {k: v[:rows] for k, v in traj.columns().items()}
    chambers = cols.pop("chambers")
    t = traj.schedule.time_s[:rows]
    tip_x, tip_z = law.tip_for_angle_mm(cols["bend_angle_deg"])
    supply = np.where(traj.schedule.phase_rows()[:rows] == SUPPLY, rig.supply_kpa, 0.0)
    series = {"time_s": t, "supply_kpa": supply, **cols, "tip_x_mm": np.asarray(tip_x, float),
              "tip_z_mm": np.asarray(tip_z, float)}
    reason = None if traj.event_t is not None else _never_reason(model, rig, traj, cols["bend_angle_deg"],
                                                                 duration_s)
    n = low.network.n
    stored = low.network.stored_mass_kg(traj.states[[0, rows - 1], :n].T).sum(axis=0)
    full_bend_kpa = law.full_bend_kpa()
    info = {
        "gas_law": "isothermal", "method": "trbdf2", "dt_s": None, "rtol": tolerances.rtol, "steps": traj.steps,
        "duration_s": duration_s, "natural_frequency_hz": low.natural_frequency_hz,
        "damping_ratio": model.bending.damping_ratio, "damping_nms_per_rad": low.mode.damping_nms,
        "stiffness_nm_per_rad": low.stiffness_nm_per_rad, "mass_g": model.bending.mass_kg * 1000,
        "moment_per_kpa_nm": model.bending.moment_per_pa * 1000, "rest_angle_deg": math.degrees(model.theta0),
        "quasi_static_angle_at_supply_deg": float(law.bend_angle_deg(rig.supply_kpa))
        if law.within(rig.supply_kpa) else None,
        "full_bend_pressure_kpa": full_bend_kpa,
        "volume_change_at_full_bend_ml": None if full_bend_kpa is None
        else float(law.volume_ml(full_bend_kpa)) - float(law.volume_ml(0.0)),
        "law_end": {"pressure_kpa": law.end.pressure_kpa, "bend_angle_deg": law.end.angle_deg,
                    "cavity_volume_ml": law.end.volume_ml, "stop": law.end.stop, "reason": law.end.reason},
        "stopped_at_law_end_s": traj.stop_t, "stopped_by": traj.stopped_by,
        "mass_balance": {"metered_kg": float(traj.states[rows - 1, n + 2]), "stored_kg": float(stored[1] - stored[0])},
    }
    return StepResponse(series, chambers, traj.event_t, reason, info)


def _never_reason(model: StepModel, rig: Rig, traj: Trajectory, angle_deg, duration_s) -> str:
    law = model.law
    peak = float(np.max(angle_deg))
    if model.theta0 >= math.radians(FULL_BEND_DEG):
        return f"the actuator is already at {math.degrees(model.theta0):.0f} degrees at rest"
    if traj.stopped_by is not None:
        return f"at {traj.stop_t * 1000:.1f} ms {traj.stopped_by} (peak {peak:.0f} degrees)"
    full_kpa = law.full_bend_kpa()
    if full_kpa is None:
        held = (f"the supply ({rig.supply_kpa:g} kPa) holds {float(law.bend_angle_deg(rig.supply_kpa)):.0f} degrees "
                "quasi-statically; " if law.within(rig.supply_kpa) else "")
        return f"{held}full bend is {law.short_of_full_bend()}; peak {peak:.0f} degrees within {duration_s:g} s"
    if rig.supply_kpa < full_kpa:
        quasi = float(law.bend_angle_deg(rig.supply_kpa))
        return (f"the supply ({rig.supply_kpa:g} kPa) holds only {quasi:.0f} degrees quasi-statically "
                f"(full bend needs {full_kpa:.1f} kPa); peak {peak:.0f} degrees")
    if rig.vent_at_s is not None and rig.vent_at_s < duration_s:
        return f"the supply valve closed at {rig.vent_at_s:g} s, before full bend (peak {peak:.0f} degrees)"
    return f"not within {duration_s:g} s (peak {peak:.0f} degrees); try a longer duration"
