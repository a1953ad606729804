"""The physics of the two pneumatic effects of the catalogue (:mod:`pnmold.effects`).

``dead_volume`` -- extra compressible gas volume (mL) in series with the chambers: a
fitting, a pressure-sensor tee, a longer tube. In the step model it is added to the
inlet node (between the tubing and the actuator, downstream of the flow meter). It
changes no final state: the chambers end at the supply pressure and the same bend, but
more gas must flow first, so the step is slower; the metered gas against the inlet
pressure (a P-V curve) gains an offset growing with pressure, ``V_d (p / p_std)
(T_std / T)`` standard mL (isothermal; standard = 0 degC, 101.325 kPa). In a hydraulic
P-V test (water from a syringe pump) a trapped air bubble of V_d at atmospheric pressure
takes ``V_d p / (p_atm + p)`` more water.

``flow_restriction`` -- extra pneumatic resistance of the path (valve, tubing and the
connecting channel) as a multiple of the nominal: every restriction's conductance is
divided by (1 + value). The pneumatic response is then the nominal one with time
stretched by (1 + value) (every flow scales alike), the peak flow falls by the same
factor, the final state and the P-V relation (gas against pressure) are unchanged; the
near chambers lead the far ones by proportionally longer, and the bend, whose inertia does
not stretch, lags the pressure less in relative terms.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from pnmold.effects import check_effects
from pnmold.errors import UsageError
from pnmold.pneumatics.gas import P_ATM_PA, T_REF_K, T_STD_K
from pnmold.pneumatics.network import Rig


def with_effects(rig: Rig, effects: Mapping[str, float]) -> Rig:
    """The bench with the dynamic effects switched on (0 = off)."""
    e = check_effects(effects, model="dynamic")
    return dataclasses.replace(rig, dead_volume_ml=e.get("dead_volume", rig.dead_volume_ml),
                               flow_restriction=e.get("flow_restriction", rig.flow_restriction))


def dead_volume_pv_offset_ml(pressure_kpa, volume_ml: float, medium: str = "water",
                             atmosphere_kpa: float = P_ATM_PA / 1000, temperature_k: float = T_REF_K):
    """Extra volume a P-V test sees from a dead gas volume ``volume_ml`` at gauge pressure.

    ``water`` (the supplement's hydraulic test): the bubble's isothermal compression,
    V p / (p_atm + p), in mL of water. ``air`` (gas metered in standard mL, 0 degC and
    101.325 kPa): V (p / p_std) (T_std / T), p_std = 101.325 kPa."""
    p = np.asarray(pressure_kpa, float)
    if medium == "water":
        return volume_ml * p / (atmosphere_kpa + p)
    if medium == "air":
        return volume_ml * p * 1000 / P_ATM_PA * T_STD_K / temperature_k
    raise UsageError(f"medium must be water or air, got {medium!r}")
