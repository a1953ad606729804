"""The reduced model as the diagnosis's forward model, and reading the user's recordings."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pnmold.design import Design
from pnmold.recording import Recording, read_recording

from .fitting import Forward


def read_all(paths: Sequence[str | Path]) -> list[Recording]:
    """Every recording, read and checked before anything is computed or written."""
    return [read_recording(p) for p in paths]


def candidate_effects(recordings: Sequence[Recording], model: str = "rom") -> list:
    """Catalogue entries the model carries that show in at least one recorded kind."""
    from pnmold.physics.effects import EFFECTS

    kinds = {r.kind for r in recordings}
    return [e for e in EFFECTS.values() if model in e.models and kinds & set(e.kinds)]


def rom_forward(design: Design, recordings: Sequence[Recording]) -> Forward:
    """forward(effects, calibration) on the reduced model: every catalogued effect off
    unless given (the baseline is the nominal model without any effect)."""
    from pnmold.physics.effects import EFFECTS
    from pnmold.physics.protocol import Protocol
    from pnmold.physics.rom import ReducedModel

    rom = ReducedModel.for_design(design)
    protocols = [Protocol.from_recording(r) for r in recordings]
    off = {name: 0.0 for name, e in EFFECTS.items() if "rom" in e.models}

    def forward(effects: dict[str, float], calibration: dict[str, float]) -> list[dict[str, np.ndarray]]:
        return [rom.run(p, {**off, **effects}, None, calibration) for p in protocols]

    return forward
