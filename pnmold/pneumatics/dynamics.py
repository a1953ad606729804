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

States (SI): node pressures (Pa, absolute), node gas masses when adiabatic (kg), the
metered gas (kg), the bend angle (rad) and its rate (rad/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pnmold.pneumatics.gas import R_AIR, RHO_STD, slpm_from_kg_s
from pnmold.pneumatics.integrate import RTOL, integrate
from pnmold.pneumatics.law import ChamberLaw, _Linear
from pnmold.pneumatics.mechanics import BendingDynamics
from pnmold.pneumatics.network import ActuatorLine, Network, Rig, bench_network

FULL_BEND_DEG = 360.0
FULL_BEND_RAD = math.radians(FULL_BEND_DEG)
CONTACT_MOMENT_FACTOR = 2.0  # assumed: the stop holds twice the supply's pressure moment ...
CONTACT_DEPTH_DEG = 1.0  # ... within 1 degree past full bend
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
        """The ``step`` recording's columns (CONTRACTS.md §4) plus two extras (kept, ignored by readers)."""
        keys = ("time_s", "supply_kpa", "pressure_kpa", "flow_slpm", "bend_angle_deg", "tip_x_mm", "tip_z_mm",
                "pressure_far_kpa", "volume_ml")
        return {k: self.series[k] for k in keys}


class _AngleMap:
    """Angle <-> pressure and angle -> tip for the bending mode, from any ChamberLaw."""

    def __init__(self, law: ChamberLaw, p_hi_kpa: float):
        self.law = law
        if hasattr(law, "pressure_for_angle_kpa"):
            self.p_of = law.pressure_for_angle_kpa
            self.dp_of = law.dpressure_dangle_kpa_per_deg
        else:
            p = np.linspace(-20.0, max(p_hi_kpa, 1.0) * 1.2, 600)
            a = np.asarray(law.bend_angle_deg(p), float)
            if np.any(np.diff(a) <= 0):
                raise ValueError("the law's bend angle must increase strictly with pressure")
            inverse = _Linear(a, p)
            self.p_of, self.dp_of = inverse, inverse.derivative

    def tip_mm(self, angle_deg):
        fn = getattr(self.law, "tip_for_angle_mm", None)
        if fn is not None:
            return fn(angle_deg)
        return self.law.tip_mm(self.p_of(angle_deg))


def _segments(vent_at_s: float | None, duration_s: float, out_step_s: float):
    """Output times of each valve phase: [(phase, t_out)], sharing the switch time."""
    n = int(round(duration_s / out_step_s))
    t_all = np.linspace(0.0, n * out_step_s, n + 1)
    if vent_at_s is None or vent_at_s >= t_all[-1]:
        return [("supply", t_all)]
    k = int(round(vent_at_s / out_step_s))
    if not math.isclose(k * out_step_s, vent_at_s, rel_tol=0, abs_tol=1e-12) or k == 0:
        raise ValueError(f"vent_at_s ({vent_at_s}) must be a positive multiple of the output step {out_step_s} s")
    return [("supply", t_all[:k + 1]), ("vent", t_all[k:])]


def simulate_network(network: Network, duration_s: float, *, vent_at_s: float | None = None,
                     method: str = "radau", dt_s: float | None = None, rtol: float = RTOL,
                     out_step_s: float = OUTPUT_STEP_S, initial_pa: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Pneumatics only (no bending): time_s, node pressures (Pa, abs), metered kg, node masses.

    ``initial_pa``: the nodes' initial pressures (default: atmospheric)."""
    model = _Model(network, None, None, None, initial_pa)
    t, y, _ = model.run(_segments(vent_at_s, duration_s, out_step_s), method, dt_s, rtol)
    p, metered, masses = model.unpack(y)
    return {"time_s": t, "pressure_pa": p, "metered_kg": metered, "mass_kg": masses}


class _Model:
    """The coupled right-hand side; ``bending`` None = pneumatics only."""

    def __init__(self, network: Network, law, bending: BendingDynamics | None, angles: _AngleMap | None,
                 initial_pa: np.ndarray | None = None):
        self.net, self.law, self.bending, self.angles = network, law, bending, angles
        self.n = network.n
        self.adiabatic = network.gas_law == "adiabatic"
        self.chambers = np.flatnonzero(network.law_share > 0)
        p0 = np.full(self.n, network.p_atm_pa) if initial_pa is None else np.array(initial_pa, float)
        m0 = network.stored_mass_kg(p0)
        self.theta0 = math.radians(float(law.bend_angle_deg(0.0))) if bending is not None else 0.0
        mech = [self.theta0, 0.0] if bending is not None else []
        self.y0 = np.concatenate([p0, m0 if self.adiabatic else [], [0.0], mech])
        self.m0 = m0
        if bending is not None:
            dp = float(angles.dp_of(math.degrees(self.theta0))) * 1000 * 180 / math.pi  # Pa/rad
            self.damping = bending.damping_nms(self.theta0, dp)
            self.stiffness = bending.stiffness_nm_per_rad(dp)
            self.natural_hz = bending.natural_frequency_hz(self.theta0, dp)
            # the end-to-end contact stop at full bend (module docstring)
            full = math.radians(FULL_BEND_DEG)
            drive = bending.moment_per_pa * max(network.p_supply_pa - network.p_atm_pa, 1e3)
            self.contact_k = CONTACT_MOMENT_FACTOR * drive / math.radians(CONTACT_DEPTH_DEG)
            self.contact_c = 2 * math.sqrt(self.contact_k * float(bending.inertia_kg_m2(full)[0]))
        m_scale = float(np.sum(m0))
        self.atol = np.concatenate([np.full(self.n, 1e-5), np.full(self.n, 1e-12 * m_scale) if self.adiabatic else [],
                                    [1e-12 * m_scale], [1e-10, 1e-8] if bending is not None else []])

    def sparsity(self) -> np.ndarray:
        """Which states each rate depends on (for the finite-difference Jacobian)."""
        n, adj = self.n, self.net.adjacency()
        k = 2 * n if self.adiabatic else n
        size = len(self.y0)
        pattern = np.zeros((size, size), bool)
        blocks = [slice(0, n)] + ([slice(n, 2 * n)] if self.adiabatic else [])
        for rows in blocks:
            for cols in blocks:
                pattern[rows, cols] = adj
        for cols in blocks:
            pattern[k, cols.start + self.net.metered_nodes()] = True
        if self.bending is not None:
            pattern[k + 1, k + 2] = True
            pattern[k + 2, k + 1:k + 3] = True
            pattern[k + 2, self.chambers] = True
        return pattern

    def unpack(self, y):
        n = self.n
        p = y[:n]
        k = n
        masses = None
        if self.adiabatic:
            masses = y[n:2 * n]
            k = 2 * n
        return p, y[k], masses

    def temperatures(self, p, masses):
        if not self.adiabatic:
            return np.full(self.n, self.net.temperature_k)
        v, _ = self.net.volumes(p)
        # clipped only for a solver's trial states far off the solution (never on it)
        return np.clip(p * v / (np.maximum(masses, 1e-30) * R_AIR), 20.0, 2000.0)

    def rhs(self, phase):
        net = self.net

        def f(t, y):
            p, _, masses = self.unpack(y)
            t_k = self.temperatures(p, masses)
            dp, dm, meter = net.pressure_rates(p, t_k, phase)
            out = [dp, dm] if self.adiabatic else [dp]
            out.append([meter])
            if self.bending is not None:
                theta, omega = y[-2], y[-1]
                p_mean = float(np.mean(p[self.chambers])) - net.p_atm_pa
                p_hold = float(self.angles.p_of(math.degrees(theta))) * 1000
                j, dj = self.bending.inertia_kg_m2(theta)
                moment = self.bending.moment_per_pa * (p_mean - p_hold) - self.damping * omega - 0.5 * dj * omega**2
                if theta > FULL_BEND_RAD:
                    moment -= self.contact_k * (theta - FULL_BEND_RAD) + self.contact_c * omega
                out.append([omega, moment / j])
            return np.concatenate(out)

        return f

    def run(self, segments, method, dt_s, rtol, event_level=None):
        y0 = self.y0
        ts, ys, event_t = [], [], None
        for i, (phase, t_out) in enumerate(segments):
            event = None
            if event_level is not None and event_t is None:
                def event(t, y, level=event_level):
                    return y[-2] - level
            traj = integrate(self.rhs(phase), y0, t_out, self.atol, method=method, dt_s=dt_s, event=event,
                             event_slot=len(y0) - 2, sparsity=self.sparsity(), rtol=rtol)
            if event_t is None:
                event_t = traj.event_t
            ts.append(traj.t if i == 0 else traj.t[1:])
            ys.append(traj.y if i == 0 else traj.y[:, 1:])
            y0 = traj.y[:, -1]
        return np.concatenate(ts), np.concatenate(ys, axis=1), event_t


def simulate_step(law: ChamberLaw, line: ActuatorLine, bending: BendingDynamics, rig: Rig, *,
                  duration_s: float = 0.5, gas_law: str = "isothermal", method: str = "radau",
                  dt_s: float | None = None, rtol: float = RTOL, out_step_s: float = OUTPUT_STEP_S) -> StepResponse:
    """The step response of an actuator on a bench (see the module docstring)."""
    if not duration_s > 0:
        raise ValueError(f"duration_s must be > 0, got {duration_s}")
    network = bench_network(law, line, rig, gas_law)
    angles = _AngleMap(law, rig.supply_kpa)
    model = _Model(network, law, bending, angles)
    full = math.radians(FULL_BEND_DEG)
    level = full if model.theta0 < full else None
    t, y, event_t = model.run(_segments(rig.vent_at_s, duration_s, out_step_s), method, dt_s, rtol, event_level=level)
    return _response(model, law, rig, t, y, event_t, duration_s, gas_law, method, dt_s)


def _response(model: _Model, law, rig: Rig, t, y, event_t, duration_s, gas_law, method, dt_s) -> StepResponse:
    net = model.net
    p, metered, masses = model.unpack(y)
    p_atm = net.p_atm_pa
    gauge = (p - p_atm) / 1000
    chambers = gauge[model.chambers].T
    v_rest = float(law.volume_ml(0.0))
    v_now = np.array([net.volumes(p[:, i])[0][model.chambers].sum() for i in range(len(t))]) * 1e6
    angle = np.degrees(y[-2])
    tip_x, tip_z = model.angles.tip_mm(angle)
    flow = np.array([model.rhs(_phase_at(rig, ti))(ti, y[:, i])[model.n * (2 if model.adiabatic else 1)]
                     for i, ti in enumerate(t)])
    supply = np.where(_supply_open(rig, t), rig.supply_kpa, 0.0)
    series = {
        "time_s": t, "supply_kpa": supply, "pressure_kpa": gauge[1], "pressure_valve_kpa": gauge[0],
        "pressure_near_kpa": chambers[:, 0], "pressure_far_kpa": chambers[:, -1],
        "flow_slpm": slpm_from_kg_s(flow), "metered_std_ml": metered / RHO_STD * 1e6,
        "volume_ml": v_now - v_rest, "cavity_volume_ml": v_now,
        "bend_angle_deg": angle, "tip_x_mm": np.asarray(tip_x, float), "tip_z_mm": np.asarray(tip_z, float),
    }
    if model.adiabatic:
        far = model.chambers[-1]
        series["gas_temperature_far_k"] = np.array([model.temperatures(p[:, i], masses[:, i])[far]
                                                    for i in range(len(t))])
    reason = None
    if event_t is None:
        reason = _never_reason(model, law, rig, angle, duration_s)
    info = {
        "gas_law": gas_law, "method": method, "dt_s": dt_s, "duration_s": duration_s,
        "natural_frequency_hz": model.natural_hz, "damping_ratio": model.bending.damping_ratio,
        "damping_nms_per_rad": model.damping, "stiffness_nm_per_rad": model.stiffness,
        "mass_g": model.bending.mass_kg * 1000, "moment_per_kpa_nm": model.bending.moment_per_pa * 1000,
        "rest_angle_deg": math.degrees(model.theta0),
        "quasi_static_angle_at_supply_deg": float(law.bend_angle_deg(rig.supply_kpa)),
        "full_bend_pressure_kpa": float(model.angles.p_of(FULL_BEND_DEG)),
        "volume_change_at_full_bend_ml": float(law.volume_ml(model.angles.p_of(FULL_BEND_DEG))) - v_rest,
        "mass_balance": {"metered_kg": float(metered[-1]), "stored_kg": _stored_change(model, p[:, -1],
                                                                                      None if masses is None
                                                                                      else masses[:, -1])},
    }
    return StepResponse(series, chambers, event_t, reason, info)


def _stored_change(model: _Model, p, masses) -> float:
    if masses is not None:
        return float(np.sum(masses) - np.sum(model.m0))
    return float(np.sum(model.net.stored_mass_kg(p)) - np.sum(model.m0))


def _supply_open(rig: Rig, t):
    return np.ones_like(t, bool) if rig.vent_at_s is None else np.asarray(t) < rig.vent_at_s


def _phase_at(rig: Rig, t: float) -> str:
    return "supply" if rig.vent_at_s is None or t < rig.vent_at_s else "vent"


def _never_reason(model: _Model, law, rig: Rig, angle_deg, duration_s) -> str:
    peak = float(np.max(angle_deg))
    quasi = float(law.bend_angle_deg(rig.supply_kpa))
    if model.theta0 >= math.radians(FULL_BEND_DEG):
        return f"the actuator is already at {math.degrees(model.theta0):.0f} degrees at rest"
    if quasi < FULL_BEND_DEG:
        return (f"the supply ({rig.supply_kpa:g} kPa) holds only {quasi:.0f} degrees quasi-statically "
                f"(full bend needs {float(model.angles.p_of(FULL_BEND_DEG)):.1f} kPa); peak {peak:.0f} degrees")
    if rig.vent_at_s is not None and rig.vent_at_s < duration_s:
        return f"the supply valve closed at {rig.vent_at_s:g} s, before full bend (peak {peak:.0f} degrees)"
    return f"not within {duration_s:g} s (peak {peak:.0f} degrees); try a longer duration"
