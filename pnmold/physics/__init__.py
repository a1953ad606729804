"""The reduced model and the catalogue of physics effects, informed by the FE.

- :mod:`.characterise` -- the FE's free-bending law and hinge compliance of a design (cached).
- :mod:`.rom` -- :class:`ReducedModel`: a planar rod of the bottom face carrying that law with
  gravity, a blocking plane, and the catalogued effects; a curve in milliseconds.
- :mod:`.effects` -- the catalogue (CONTRACTS.md §5): parameters, units, bounds, fingerprints.
- :mod:`.protocol` -- :class:`Protocol`: the pressure sequence and history of a test.

    >>> from pnmold.physics import Protocol, ReducedModel                  # doctest: +SKIP
    >>> rom = ReducedModel.for_design(design)                               # doctest: +SKIP
    >>> rom.run(Protocol.ramp("bending", 40, 2), {"gravity": 1})["tip_z_mm"]  # doctest: +SKIP
"""

from pnmold.physics.characterise import Characterisation, characterisation_from_steps, characterise
from pnmold.physics.effects import EFFECTS, Effect, catalogue_json, check_effects
from pnmold.physics.protocol import Protocol
from pnmold.physics.rom import ReducedModel

__all__ = ["EFFECTS", "Characterisation", "Effect", "Protocol", "ReducedModel", "catalogue_json",
           "characterisation_from_steps", "characterise", "check_effects"]
