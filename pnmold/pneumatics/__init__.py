"""Pneumatic dynamics: a supply step through valves, tubing and the connecting channel
into the chambers, coupled to the bending mode (``pnmold simulate --dynamic``).

gas (restrictions) -> network (volumes and edges) -> dynamics (+ mechanics) -> StepResponse.
"""

from pnmold.pneumatics.dynamics import StepResponse, simulate_network, simulate_step
from pnmold.pneumatics.effects import DYNAMIC_EFFECTS, dead_volume_pv_offset_ml, with_effects
from pnmold.pneumatics.gas import Duct, Orifice
from pnmold.pneumatics.law import ChamberLaw, CurveLaw, chamber_law_for, chamber_law_from_curve
from pnmold.pneumatics.mechanics import BendingDynamics
from pnmold.pneumatics.network import ActuatorLine, Network, Rig, bench_network

__all__ = [
    "ActuatorLine", "BendingDynamics", "ChamberLaw", "CurveLaw", "DYNAMIC_EFFECTS", "Duct", "Network", "Orifice",
    "Rig", "StepResponse", "bench_network", "chamber_law_for", "chamber_law_from_curve",
    "dead_volume_pv_offset_ml", "simulate_network", "simulate_step", "with_effects",
]
