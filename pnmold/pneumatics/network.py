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

The gas is isothermal (polytropic exponent 1): the silicone walls are a heat sink far
larger than the gas, the chambers' smallest dimensions (the 1 mm channel, 1-6 mm chamber
widths) exchange heat in milliseconds to a few tenths of a second, the FE curve and the
lab's P-V curves are isothermal, and it is the slower bound (more gas per kPa). Per node,
with V(p) its volume and q_net its net mass inflow::

    dp/dt (V + p dV/dp) = R T q_net

:meth:`Network.lower` gives the compiled right-hand side (:mod:`pnmold.pneumatics.rates`)
the network as arrays; this module is the one place the topology is written.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pnmold.errors import UsageError
from pnmold.pneumatics.gas import MU_AIR, P_ATM_PA, R_AIR, T_REF_K, Duct, Orifice
from pnmold.pneumatics.law import ChamberLaw, CurveLaw, Pieces, as_curve_law
from pnmold.pneumatics.rates import DuctEdges, NetworkArrays, OrificeEdges

GAS_LAW = "isothermal"
#: why the step model has no other gas law (``--gas-law adiabatic`` and such recordings are refused)
ISOTHERMAL_WHY = ("the step model is isothermal: the silicone walls exchange heat with the gas within "
                  "milliseconds to tenths of a second and the FE and lab P-V curves it is built on are "
                  "isothermal; an adiabatic bound would need an energy balance the compiled model does not carry")
TUBING_LENGTH_MM = 300.0  # assumed: the supplement gives the tubing's bore, not its length
TUBING_ID_MM = 0.79375  # 1/32" (the supplement's tubing)
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
    tubing_id_mm: float = TUBING_ID_MM
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
                raise UsageError(f"rig.{name}: out of range ({value!r})")


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
    The flow meter sees the orifices and ducts that join a node to the supply or the
    atmosphere (signed into the line)."""

    rigid_m3: np.ndarray
    law_share: np.ndarray
    law: CurveLaw | None
    orifices: tuple
    ducts: tuple
    p_supply_pa: float
    p_atm_pa: float
    temperature_k: float = T_REF_K
    flow_scale: float = 1.0
    names: tuple[str, ...] = ()

    @property
    def n(self) -> int:
        return len(self.rigid_m3)

    def depends(self) -> np.ndarray:
        """n x n booleans: node i's rate depends on node j's pressure (itself and its neighbours)."""
        adj = np.eye(self.n, dtype=bool)
        for a, b, *_ in (*self.orifices, *self.ducts):
            if a < self.n and b < self.n:
                adj[a, b] = adj[b, a] = True
        return adj

    def chambers(self) -> np.ndarray:
        """The nodes that hold a share of the chamber law."""
        return np.flatnonzero(self.law_share > 0)

    def lower(self, pressure_scale: float = 1.0) -> NetworkArrays:
        """The network as arrays for :mod:`pnmold.pneumatics.rates` (the law read at p / ``pressure_scale``)."""
        depends = self.depends()
        colour = _colours(depends)
        phase = {"supply": 0, "vent": 1}
        o = self.orifices
        orifices = OrificeEdges(np.array([e[0] for e in o], np.int64), np.array([e[1] for e in o], np.int64),
                                np.array([e[2].choked_kg_per_s_pa(self.temperature_k) for e in o], float),
                                np.array([e[2].critical_ratio for e in o], float),
                                np.array([phase[e[3]] for e in o], np.int64))
        d = self.ducts
        c = np.array([e[2].coefficients(MU_AIR) for e in d], float).reshape(len(d), 5).T
        ducts = DuctEdges(np.array([e[0] for e in d], np.int64), np.array([e[1] for e in d], np.int64),
                          *(np.ascontiguousarray(row) for row in c))
        volume = self.law.volume_pieces() if self.law is not None else _NO_LAW
        return NetworkArrays(np.asarray(self.rigid_m3, float), np.asarray(self.law_share, float), volume,
                             float(pressure_scale), orifices, ducts, np.array([self.p_supply_pa, self.p_atm_pa]),
                             float(self.p_atm_pa), R_AIR * self.temperature_k, float(self.flow_scale), depends,
                             colour, int(colour.max()) + 1 if colour.size else 0)

    def stored_mass_kg(self, p_pa: np.ndarray, pressure_scale: float = 1.0) -> np.ndarray:
        """Gas mass in every node (kg) at absolute pressures ``p_pa`` (nodes along the first axis)."""
        p = np.asarray(p_pa, float)
        shape = (self.n,) + (1,) * (p.ndim - 1)
        v = np.broadcast_to(np.reshape(self.rigid_m3, shape), p.shape).copy()
        if self.law is not None:  # the law read on the chambers alone (the line's nodes may pass its end)
            chambers = self.chambers()
            gauge_kpa = (p[chambers] - self.p_atm_pa) / 1000 / pressure_scale
            v[chambers] += np.reshape(self.law_share[chambers], (-1,) + shape[1:]) * np.asarray(
                self.law.volume_ml(gauge_kpa), float) * 1e-6
        return p * v / (R_AIR * self.temperature_k)


#: the volume law of a network without chambers (never read: every share is 0)
_NO_LAW = Pieces(np.array([0.0, 1.0]), np.zeros((4, 1)), 0.0, 0.0, 0.0, 0.0)


def _colours(depends: np.ndarray) -> np.ndarray:
    """Finite-difference groups: greedy, no node's rate depends on two nodes of a group."""
    n = len(depends)
    conflict = (depends.T.astype(np.int64) @ depends.astype(np.int64)) > 0
    colour = np.full(n, -1, np.int64)
    for j in range(n):
        taken = set(colour[conflict[j] & (colour >= 0)].tolist())
        colour[j] = next(c for c in range(n + 1) if c not in taken)
    return colour


def bench_network(law: ChamberLaw, line: ActuatorLine, rig: Rig) -> Network:
    """The step-test network of the module docstring for an actuator and a bench (a law
    other than a :class:`CurveLaw` is sampled up to the supply, :func:`as_curve_law`)."""
    law = as_curve_law(law, rig.supply_kpa)
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
                   rig.temperature_k, 1.0 / (1.0 + rig.flow_restriction), names)
