"""The lumped pneumatic network of a step test: supply, valves, tubing, channel, chambers.

Nodes are gas volumes with one pressure each (Pa, absolute); edges are restrictions
(:mod:`pnmold.pneumatics.gas`). The bench of the supplement's rapid-actuation test
(regulated supply, a supply and a vent solenoid valve, tubing, the actuator) becomes::

    supply --[supply valve]--> L0 --[tubing]--> L1 --[channel]--> C1 --[channel]--> ... --> CN
                               L0 --[vent valve]--> atmosphere

L0 holds the valve's outlet volume and half the tubing; L1 the other half, the inlet and
the ``dead_volume`` effect's extra volume; C1 ... CN are the chambers, each with 1/N of
the cavity's volume law, so the near chambers lead the far ones through the 1 mm
channel. The flow meter sits between the valves and the tubing (the supplement's
sensors measured "air transferred to and from the actuator"), so it sees the gas that
fills the tubing and any dead volume too.

Gas law: ``isothermal`` (default) or ``adiabatic``. Isothermal (polytropic exponent 1):
the silicone walls are a heat sink far larger than the gas, the chambers' smallest
dimensions (the 1 mm channel, 1-6 mm chamber widths) exchange heat in milliseconds to a
few tenths of a second, the FE curve and the lab's P-V curves are isothermal, and it is
the slower of the two bounds (more gas per kPa). Adiabatic (exponent gamma = 1.4) is the
energy balance without heat transfer, the fast bound. Per node, with V(p) its volume::

    isothermal  dp/dt (V + p dV/dp) = R T q_net
    adiabatic   dp/dt (V + gamma p dV/dp) = (gamma - 1) H_net,  dm/dt = q_net,  T = p V / (m R)

q_net is the net mass inflow and H_net = sum cp T_upstream q the net enthalpy inflow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pnmold.pneumatics.gas import (
    CP_AIR,
    GAMMA,
    P_ATM_PA,
    R_AIR,
    T_REF_K,
    Duct,
    DuctSet,
    Orifice,
)
from pnmold.pneumatics.law import ChamberLaw

GAS_LAWS = ("isothermal", "adiabatic")
TUBING_LENGTH_MM = 300.0  # assumed: the supplement gives the tubing's bore, not its length
VALVE_ORIFICE_MM = 1.0  # assumed effective orifice of the miniature solenoid valves
VALVE_CRITICAL_RATIO = 0.5  # assumed (sharp-edged orifices: 0.3-0.53)
VALVE_VOLUME_ML = 0.05  # assumed internal volume between the valve seat and the tubing


@dataclass(frozen=True)
class Rig:
    """The bench: regulated supply (gauge kPa), valves, tubing, and the dynamic effects.

    ``vent_at_s``: the supply valve closes and the vent valve opens at that time (None:
    the supply stays on). ``dead_volume_ml`` and ``flow_restriction`` are the effects of
    :mod:`pnmold.pneumatics.effects` (0 = off)."""

    supply_kpa: float
    supply_valve: Orifice = field(default_factory=lambda: Orifice.from_diameter_mm(VALVE_ORIFICE_MM,
                                                                                   VALVE_CRITICAL_RATIO))
    vent_valve: Orifice = field(default_factory=lambda: Orifice.from_diameter_mm(VALVE_ORIFICE_MM,
                                                                                 VALVE_CRITICAL_RATIO))
    tubing_length_mm: float = TUBING_LENGTH_MM
    tubing_id_mm: float = 0.79375  # 1/32" (the supplement's tubing)
    valve_volume_ml: float = VALVE_VOLUME_ML
    vent_at_s: float | None = None
    dead_volume_ml: float = 0.0
    flow_restriction: float = 0.0
    atmosphere_kpa: float = P_ATM_PA / 1000
    temperature_k: float = T_REF_K

    def __post_init__(self):
        checks = {"supply_kpa": self.supply_kpa > 0, "tubing_length_mm": self.tubing_length_mm > 0,
                  "tubing_id_mm": self.tubing_id_mm > 0, "valve_volume_ml": self.valve_volume_ml > 0,
                  "dead_volume_ml": self.dead_volume_ml >= 0, "flow_restriction": self.flow_restriction >= 0,
                  "atmosphere_kpa": self.atmosphere_kpa > 0, "temperature_k": self.temperature_k > 0,
                  "vent_at_s": self.vent_at_s is None or self.vent_at_s > 0}
        for name, ok in checks.items():
            value = getattr(self, name)
            if not ok or (value is not None and not math.isfinite(value)):
                raise ValueError(f"{name}: out of range ({value!r})")


@dataclass(frozen=True)
class ActuatorLine:
    """The actuator's air path: N chambers, the channel into the first and between them (mm)."""

    chambers: int
    channel_height_mm: float
    channel_width_mm: float
    inlet_channel_mm: float
    link_mm: float

    @classmethod
    def from_design(cls, design) -> ActuatorLine:
        """From the design: the channel runs from the inlet (half the end wall in) to the
        first cavity, and between neighbouring cavities over one pitch less a cavity."""
        c = design.chambers
        return cls(c.count, design.channel.height_mm, design.channel.width_mm,
                   design.cavity_x_mm(0)[0] - design.channel_x_mm[0], design.pitch_mm - c.length_mm)

    def inlet_duct(self) -> Duct:
        return Duct.rectangular(self.inlet_channel_mm, self.channel_height_mm, self.channel_width_mm)

    def link_duct(self) -> Duct:
        return Duct.rectangular(self.link_mm, self.channel_height_mm, self.channel_width_mm)


@dataclass(frozen=True, eq=False)
class Network:
    """A pneumatic network: node volumes, restrictions, boundary pressures (SI).

    Nodes 0..n-1 are gas volumes; index n is the supply, n + 1 the atmosphere.
    ``rigid_m3[i]`` is node i's fixed volume; nodes with ``law_share[i] > 0`` add that
    share of the chamber law's cavity volume. ``orifices``: (a, b, Orifice, phase) with
    phase "supply" (open before venting) or "vent" (open after); ``ducts``: (a, b, Duct).
    ``meter``: the orifices whose flow is metered (signed into the line)."""

    rigid_m3: np.ndarray
    law_share: np.ndarray
    law: ChamberLaw | None
    orifices: tuple
    ducts: tuple
    p_supply_pa: float
    p_atm_pa: float
    temperature_k: float = T_REF_K
    flow_scale: float = 1.0
    gas_law: str = "isothermal"
    names: tuple[str, ...] = ()

    def __post_init__(self):
        if self.gas_law not in GAS_LAWS:
            raise ValueError(f"gas law must be one of {', '.join(GAS_LAWS)}, got {self.gas_law!r}")
        d = self.ducts
        object.__setattr__(self, "_duct_a", np.array([e[0] for e in d], int))
        object.__setattr__(self, "_duct_b", np.array([e[1] for e in d], int))
        object.__setattr__(self, "_duct_set", DuctSet([e[2] for e in d]))
        incidence = np.zeros((self.n + 2, len(d)))  # +1 into b, -1 out of a, per duct
        for j, (a, b, _) in enumerate(d):
            incidence[a, j] -= 1.0
            incidence[b, j] += 1.0
        object.__setattr__(self, "_incidence", incidence)
        object.__setattr__(self, "_chambers", np.flatnonzero(self.law_share > 0))

    @property
    def n(self) -> int:
        return len(self.rigid_m3)

    def adjacency(self) -> np.ndarray:
        """n x n booleans: node i's rates depend on node j's state (itself and its neighbours)."""
        adj = np.eye(self.n, dtype=bool)
        for a, b, *_ in (*self.orifices, *self.ducts):
            if a < self.n and b < self.n:
                adj[a, b] = adj[b, a] = True
        return adj

    def metered_nodes(self) -> np.ndarray:
        """Nodes whose state sets the metered flow (those on a boundary orifice)."""
        return np.unique([a if a < self.n else b for a, b, *_ in self.orifices])

    # -- volumes ----------------------------------------------------------------
    def volumes(self, p_pa: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(V, dV/dp) of every node at absolute pressures ``p_pa`` (m^3, m^3/Pa)."""
        v, dv = self.rigid_m3.copy(), np.zeros(self.n)
        idx = self._chambers
        if len(idx):
            gauge_kpa = (p_pa[idx] - self.p_atm_pa) / 1000
            share = self.law_share[idx]
            v[idx] += share * np.asarray(self.law.volume_ml(gauge_kpa), float) * 1e-6
            dv[idx] = share * _compliance_ml_per_kpa(self.law, gauge_kpa) * 1e-9
        return v, dv

    def stored_mass_kg(self, p_pa: np.ndarray, t_k: np.ndarray | None = None) -> np.ndarray:
        v, _ = self.volumes(p_pa)
        return p_pa * v / (R_AIR * (self.temperature_k if t_k is None else t_k))

    # -- flows ------------------------------------------------------------------
    def flows(self, p_pa: np.ndarray, t_k: np.ndarray, phase: str):
        """(q_net kg/s per node, H_net W per node, metered kg/s) at node pressures and temperatures."""
        n = self.n
        p = np.concatenate([p_pa, [self.p_supply_pa, self.p_atm_pa]])
        t = np.concatenate([t_k, [self.temperature_k, self.temperature_k]])
        q_net, h_net, meter = np.zeros(n + 2), np.zeros(n + 2), 0.0
        for a, b, orifice, when in self.orifices:
            if when != phase:
                continue
            up, dn = (a, b) if p[a] >= p[b] else (b, a)
            q = self.flow_scale * float(orifice.mass_flow_kg_s(p[up], p[dn], t[up]))
            q = q if up == a else -q  # signed a -> b
            q_net[a] -= q
            q_net[b] += q
            h = CP_AIR * t[up] * q
            h_net[a] -= h
            h_net[b] += h
            meter += q if b < n and a >= n else (-q if a < n and b >= n else 0.0)
        if len(self.ducts):
            a, b = self._duct_a, self._duct_b
            forward = p[a] >= p[b]
            up, dn = np.where(forward, a, b), np.where(forward, b, a)
            q = self.flow_scale * self._duct_set.mass_flow_kg_s(p[up], p[dn], t[up])
            q = np.where(forward, q, -q)
            q_net += self._incidence @ q
            h_net += self._incidence @ (CP_AIR * t[up] * q)
        return q_net[:n], h_net[:n], meter

    def pressure_rates(self, p_pa, t_k, phase):
        """(dp/dt, dm/dt, metered flow): the node equations of the module docstring."""
        q_net, h_net, meter = self.flows(p_pa, t_k, phase)
        v, dv = self.volumes(p_pa)
        if self.gas_law == "isothermal":
            dp = R_AIR * self.temperature_k * q_net / (v + p_pa * dv)
        else:
            dp = (GAMMA - 1) * h_net / (v + GAMMA * p_pa * dv)
        return dp, q_net, meter


def _compliance_ml_per_kpa(law, p_kpa):
    fn = getattr(law, "compliance_ml_per_kpa", None)
    if fn is not None:
        return np.asarray(fn(p_kpa), float)
    h = 1e-3
    return (np.asarray(law.volume_ml(p_kpa + h), float) - np.asarray(law.volume_ml(p_kpa - h), float)) / (2 * h)


def bench_network(law: ChamberLaw, line: ActuatorLine, rig: Rig, gas_law: str = "isothermal") -> Network:
    """The step-test network of the module docstring for an actuator and a bench."""
    n_ch = line.chambers
    tube = Duct.tube(rig.tubing_length_mm, rig.tubing_id_mm)
    half_tube = tube.volume_m3 / 2
    rigid = np.zeros(2 + n_ch)
    rigid[0] = rig.valve_volume_ml * 1e-6 + half_tube
    rigid[1] = half_tube + rig.dead_volume_ml * 1e-6
    share = np.zeros(2 + n_ch)
    share[2:] = 1.0 / n_ch
    n = 2 + n_ch
    supply, atm = n, n + 1
    ducts = [(0, 1, tube), (1, 2, line.inlet_duct())]
    ducts += [(2 + i, 3 + i, line.link_duct()) for i in range(n_ch - 1)]
    orifices = ((supply, 0, rig.supply_valve, "supply"), (0, atm, rig.vent_valve, "vent"))
    names = ("valve outlet", "inlet") + tuple(f"chamber {i + 1}" for i in range(n_ch))
    p_atm = rig.atmosphere_kpa * 1000
    return Network(rigid, share, law, orifices, tuple(ducts), p_atm + rig.supply_kpa * 1000, p_atm,
                   rig.temperature_k, 1.0 / (1.0 + rig.flow_restriction), gas_law, names)
