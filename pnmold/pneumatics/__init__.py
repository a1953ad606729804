"""Pneumatic dynamics: a supply step through valves, tubing and the connecting channel
into the chambers, coupled to the bending mode (``pnmold simulate --dynamic`` and the
diagnosis of ``step`` recordings).

gas + flow (restrictions) -> network (volumes and edges) -> rates + trbdf2 (compiled) ->
model (StepModel) -> dynamics (StepResponse); :mod:`pnmold.simulate.dynamic` writes ``simulate --dynamic``'s files.
"""

from pnmold.pneumatics.dynamics import StepResponse, simulate_network, simulate_step
from pnmold.pneumatics.effects import dead_volume_pv_offset_ml, with_effects
from pnmold.pneumatics.gas import Duct, Orifice
from pnmold.pneumatics.law import BeyondLaw, ChamberLaw, CurveLaw, LawEnd, chamber_law_for, chamber_law_from_curve
from pnmold.pneumatics.mechanics import BendingDynamics
from pnmold.pneumatics.model import DIAGNOSIS, SIMULATION, StepModel
from pnmold.pneumatics.network import ActuatorLine, Network, Rig, bench_network
from pnmold.pneumatics.protocol import StepProtocol
from pnmold.pneumatics.trbdf2 import Tolerances

__all__ = [
    "DIAGNOSIS", "SIMULATION", "ActuatorLine", "BendingDynamics", "BeyondLaw", "ChamberLaw", "CurveLaw", "Duct",
    "LawEnd", "Network", "Orifice", "Rig", "StepModel", "StepProtocol", "StepResponse", "Tolerances", "bench_network",
    "chamber_law_for", "chamber_law_from_curve", "dead_volume_pv_offset_ml",
    "simulate_network", "simulate_step", "with_effects",
]
