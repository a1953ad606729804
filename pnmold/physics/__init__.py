"""The reduced model, informed by the FE, carrying the catalogue of effects (:mod:`pnmold.effects`).

- :mod:`.characterise` -- the FE runs that characterise a design (cached): :mod:`.characterisation`
  holds the result (free-bending law, hinge compliance, variant runs), :mod:`.identify` the pure
  identification of the hinges from the FE's shapes; :mod:`.probes` the on-demand probes a use
  needs (a blocked tip, a hanging weight, a compliant layer under the weight).
- :mod:`.rom` -- :class:`ReducedModel`: a planar rod of the bottom face carrying that law with
  gravity, a blocking plane, and the catalogued effects; a curve in milliseconds
  (docs/reduced-model.md). :mod:`.rom_law` reads the FE's free law at any pressure,
  :mod:`.rom_effects` holds how each effect enters it (docs/effects.md), :mod:`.rom_ladder` the
  law of a stiffer rubber from the FE's stiffening ladder.
- :mod:`.protocol` -- :class:`Protocol`: the pressure sequence and history of a test.

    >>> from pnmold.physics import Protocol, ReducedModel                  # doctest: +SKIP
    >>> rom = ReducedModel.for_design(design)                               # doctest: +SKIP
    >>> rom.run(Protocol.ramp("bending", 40, 2), {"gravity": 1})["tip_z_mm"]  # doctest: +SKIP
"""

from pnmold.physics.characterisation import Characterisation, characterisation_from_steps
from pnmold.physics.characterise import characterise
from pnmold.physics.protocol import Protocol
from pnmold.physics.rom import ReducedModel

__all__ = ["Characterisation", "Protocol", "ReducedModel", "characterisation_from_steps", "characterise"]
