"""``pnmold simulate``: a design's response as a ``pnmold.simulation/1`` document and a recording.

- :mod:`.quasistatic` -- the pressure curve of the FE (``--model fe``) or the reduced model
  (``--model rom``): bending, P-V or blocked force, cycled, with catalogued effects;
- :mod:`.dynamic` -- the time response to a supply step through the pneumatic bench
  (``--dynamic``), on :mod:`pnmold.pneumatics`.
"""

from pnmold.simulate.quasistatic import (
    MODELS,
    SCHEMA,
    Noise,
    Simulation,
    SimulationRequest,
    noisy_columns,
    parse_effects,
    parse_pressures,
    recording_columns,
    simulate,
    simulate_fe,
    simulate_rom,
)

__all__ = ["MODELS", "SCHEMA", "Noise", "Simulation", "SimulationRequest", "noisy_columns", "parse_effects",
           "parse_pressures", "recording_columns", "simulate", "simulate_fe", "simulate_rom"]
