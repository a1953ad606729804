"""The diagnosis's forward models (the reduced model for quasi-static recordings, the compiled
step model of :mod:`pnmold.pneumatics.model` for ``step`` recordings) and reading the user's recordings."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pnmold.design import Design
from pnmold.recording import Recording, read_recording
from pnmold.recording.reduce import Reduction, check_size, reduce_recording
from pnmold.recording.sanity import check_usable

from .fitting import Forward

log = logging.getLogger(__name__)


def read_all(paths: Sequence[str | Path], max_rows: int | None = None
             ) -> tuple[list[Recording], list[Reduction | None]]:
    """Every recording, read and checked before anything is computed or written; one longer than ``max_rows``
    (default by kind: :data:`pnmold.recording.reduce.MAX_ROWS`) reduced as it is read
    (:func:`pnmold.recording.reduce.reduce_recording`: its reduction, else None). A file too long to read is
    refused before any is read."""
    for p in paths:
        check_size(p)
    recordings = [read_recording(p) for p in paths]
    for rec in recordings:  # pressures a diagnosis cannot fit are refused here, doubtful ones said
        for doubt in check_usable(rec):
            log.warning("%s, column %s: %s", rec.path, doubt.column, doubt.message)
    read = [reduce_recording(rec, max_rows) for rec in recordings]
    return [rec for rec, _ in read], [how for _, how in read]


def candidate_effects(recordings: Sequence[Recording], model: str = "rom") -> list:
    """Catalogue entries the model carries that show in at least one recorded kind."""
    from pnmold.effects import EFFECTS

    kinds = {r.kind for r in recordings}
    return [e for e in EFFECTS.values() if model in e.models and kinds & set(e.kinds)]


def stiffening_top(design: Design, recordings: Sequence[Recording], progress=None, past: bool = False) -> float:
    """The largest Yeoh C30 of the design's stiffening ladder when the recordings need one, else 0.

    Needed when the design's free run ends at a pressure maximum and a quasi-static recording holds a
    higher pressure (with the design's rubber the model cannot reach it), or ``past``: rows lie past the
    calibrated model's maximum (:attr:`pnmold.diagnose.core.Diagnosis.past_maximum`): a stiffer rubber's
    law then goes on past the maximum, which a factor on the nominal law cannot show. The ladder is FE
    (minutes, once, cached; :func:`pnmold.physics.characterise.stiffening_ladder`)."""
    from pnmold.physics.characterise import characterise, stiffening_ladder
    from pnmold.physics.rom import ReducedModel

    c = characterise(design, progress=progress)
    quasi = [r for r in recordings if r.kind != "step"]
    top = max((float(np.max(r.columns["pressure_kpa"])) for r in quasi), default=0.0)
    if not (c.ends_at_pressure_maximum and (past or top > float(np.max(c.pressure_kpa)))):
        return 0.0
    return ReducedModel(design, stiffening_ladder(design, progress=progress)).ladder_top_mpa


def declared_effects(model: str = "rom") -> dict[str, float]:
    """The rig as the recordings declare it: every catalogued effect ``model`` carries at the value a
    simulation gives it when it is not named (its catalogue default: gravity 1 g along the recording's
    orientation, buoyancy when submerged; every other term off). The baseline of a diagnosis is this, as
    ``pnmold simulate`` and ``pnmold build`` are: an effect is named only where the data differ from it."""
    from pnmold.effects import EFFECTS

    return {name: e.default for name, e in EFFECTS.items() if model in e.models}


def rom_forward(design: Design, recordings: Sequence[Recording]) -> Forward:
    """forward(effects, calibration) on the reduced model: every catalogued effect as declared
    (:func:`declared_effects`) unless given; the protocol carries each recording's orientation, stated air
    column, tip frame and bending length."""
    from pnmold.physics.protocol import Protocol
    from pnmold.physics.rom import ReducedModel

    rom = ReducedModel.for_design(design)
    protocols = [Protocol.from_recording(r) for r in recordings]
    declared = declared_effects()

    def forward(effects: dict[str, float], calibration: dict[str, float]) -> list[dict[str, np.ndarray]]:
        return [rom.run(p, {**declared, **effects}, None, calibration, partial=True) for p in protocols]

    return forward


def has_step(recordings: Sequence[Recording]) -> bool:
    return any(r.kind == "step" for r in recordings)


def diagnosis_effects(recordings: Sequence[Recording]) -> list:
    """The candidates of a diagnosis: without a step recording exactly :func:`candidate_effects`
    (the reduced model's); with one, also the step model's (``dead_volume``,
    ``flow_restriction``), judged on the step recordings."""
    if not has_step(recordings):
        return candidate_effects(recordings)
    from pnmold.effects import EFFECTS

    quasi = [r for r in recordings if r.kind != "step"]
    rom = candidate_effects(quasi) if quasi else []
    dynamic = [e for e in EFFECTS.values() if "dynamic" in e.models and "step" in e.kinds]
    return rom + [e for e in dynamic if e not in rom]


def diagnosis_forward(design: Design, recordings: Sequence[Recording]) -> Forward:
    """Without a step recording exactly :func:`rom_forward`. With one: step recordings on the
    compiled step model (effects ``dead_volume``, ``flow_restriction``), the others on the
    reduced model (its effects); ``modulus_scale`` calibrates both. An effect acts only on
    the recordings whose model carries it."""
    if not has_step(recordings):
        return rom_forward(design, recordings)
    from pnmold.effects import EFFECTS
    from pnmold.pneumatics import StepModel, StepProtocol

    steps = [i for i, r in enumerate(recordings) if r.kind == "step"]
    quasi = [i for i, r in enumerate(recordings) if r.kind != "step"]
    protocols = [StepProtocol.from_recording(recordings[i]) for i in steps]
    step_model = StepModel(design)
    rom = rom_forward(design, [recordings[i] for i in quasi]) if quasi else None

    def model_of(key: str) -> tuple[str, ...]:
        effect = EFFECTS.get(key.partition(".")[0])
        return effect.models if effect is not None else ()

    last: dict[str, tuple] = {}  # per model, its last inputs and predictions: a fit varying only the
    # other model's parameters (a finite-difference step) does not run this one again

    def memo(name: str, key: tuple, run):
        if name not in last or last[name][0] != key:
            last[name] = (key, run())
        return last[name][1]

    def forward(effects: dict[str, float], calibration: dict[str, float]) -> list[dict[str, np.ndarray]]:
        out: list[dict[str, np.ndarray]] = [{} for _ in recordings]
        calib = tuple(sorted(calibration.items()))
        dynamic = {k: v for k, v in effects.items() if "dynamic" in model_of(k)}
        predicted = memo("step", (tuple(sorted(dynamic.items())), calib),
                         lambda: [step_model.run(p, dynamic, calibration) for p in protocols])
        for i, cols in zip(steps, predicted, strict=True):
            out[i] = cols
        if rom is not None:
            static = {k: v for k, v in effects.items() if "rom" in model_of(k)}
            predicted = memo("rom", (tuple(sorted(static.items())), calib), lambda: rom(static, calibration))
            for i, cols in zip(quasi, predicted, strict=True):
                out[i] = cols
        return out

    return forward
