"""A diagnosis from files to files: what ``pnmold diagnose`` does, as one library call."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from pnmold.design import Design
from pnmold.recording.reduce import Reduction

from .core import Diagnosis, diagnose
from .data import MODEL_FORM_SHARE, observables_of
from .inputs import DesignRef, DiagnosisModel, Reach
from .model import diagnosis_effects, diagnosis_forward, read_all, stiffening_top
from .rest import RestCheck, check_rest


def diagnose_recordings(design: Design, paths: Sequence[str | Path], *, seed: int = 0,
                        json_path: str | Path | None = None, report_dir: str | Path | None = None,
                        progress: Callable[[str], None] | None = None,
                        model_form_share: float = MODEL_FORM_SHARE,
                        uncertain: Mapping[str, float] | None = None, max_rows: int | None = None) -> Diagnosis:
    """Read and check every recording (a damaged one stops the run before anything is computed
    or written), characterise the design in the FE once (cached; templates ship theirs; its
    stages go to ``progress``; with a force recording also its blocked tip), diagnose, and write the
    JSON and the report folder. ``uncertain``: design dimension -> its standard uncertainty in mm (a
    design read off a drawing): each costs a free FE run once, and what it changes becomes a floor under
    the noise (:mod:`pnmold.physics.uncertainty`). A recording of more than ``max_rows`` rows (default by
    kind, :data:`pnmold.recording.reduce.MAX_ROWS`) is reduced as it is read (:mod:`pnmold.recording.reduce`),
    said in the summary and in its ``recordings`` entry."""
    from pnmold.physics.characterise import uncertainty_runs
    from pnmold.physics.probes import characterised_for
    from pnmold.physics.uncertainty import DesignFloor, check_uncertain

    from .output import write_json_doc, write_report

    recordings, reductions = read_all(paths, max_rows)
    uncertain = check_uncertain(design, uncertain or {})
    force = any(r.kind == "force" for r in recordings)  # the model's blocked tip matched to the FE's
    c = characterised_for(design, [r.kind for r in recordings], [r.orientation for r in recordings if r.kind != "step"],
                          layer=True, contact=any(r.kind != "step" for r in recordings),  # both effects tried
                          progress=progress)
    rest, recordings = check_rest(recordings, diagnosis_forward(design, recordings), design.free_length_mm)
    reach = Reach(c.max_pressure_kpa, c.full_bend_pressure_kpa, c.end_reason, c.how_ended)
    floor = None
    if uncertain:
        floor = DesignFloor.of(design, uncertainty_runs(design, uncertain, blocked=force, progress=progress),
                               uncertain)

    def design_floor(scale: float) -> list[dict]:
        return floor.per_recording(recordings, observables_of, scale)

    def run(top: float) -> Diagnosis:  # the forward after the ladder: its model reads it
        ref = DesignRef.of(design)  # as pnmold.report.build_report.design_entry names it
        model = DiagnosisModel(diagnosis_forward(design, recordings), diagnosis_effects(recordings), reach=reach,
                               stiffening_top_mpa=top, design_floor=design_floor if floor else None,
                               bootstrap_seed=seed, model_form_share=model_form_share)
        return diagnose(ref, recordings, model)

    top = stiffening_top(design, recordings, progress)
    diag = run(top)
    if not top and diag.past_maximum:  # past the calibrated model's maximum, though not the design rubber's
        top = stiffening_top(design, recordings, progress, past=True)
        diag = run(top) if top else diag
    if floor is not None:
        _say_floor(diag, floor)
    _say_rest(diag, rest)
    _say_reduced(diag, reductions)
    if json_path:
        write_json_doc(diag, json_path)
    if report_dir:
        write_report(diag, report_dir)
    return diag


def _say_floor(diag: Diagnosis, floor) -> None:
    """The design's stated uncertainty in the JSON (``design_uncertainty``) and the summary's words."""
    parts = {name: part["design_uncertainty"] for name, part in diag.doc["noise_parts"].items()}
    diag.doc["design_uncertainty"] = {"dimensions_mm": floor.uncertain, "not_read": list(floor.short),
                                      "floor_rms": parts}
    dims = ", ".join(f"{k} +-{v:g} mm" for k, v in floor.uncertain.items())
    said = "; ".join(f"{name} {value:.3g} RMS" for name, value in parts.items() if value > 0)
    tip = ", and a blocked tip each" if floor.blocked else ""
    note = (f"The design's stated uncertainty ({dims}; one free FE run each{tip}, the modulus left to absorb what "
            f"it can) is carried into the noise as a floor: {said or 'nothing on these recordings'}"
            + (f"; {', '.join(floor.short)} gave too short a run to read" if floor.short else "") + ".")
    diag.doc["calibration"]["notes"].append(note)
    diag.doc["summary"] = f"{diag.doc['summary']} {note}"


def _say_rest(diag: Diagnosis, checks: list[RestCheck]) -> None:
    """The rest rows' check in the JSON (``rest_check``) and, where one fails, its words first in the summary."""
    diag.doc["rest_check"] = [c.as_json() for c in checks]
    words = [c.words for c in checks if c.question]
    if words:
        diag.doc["summary"] = " ".join([*words, diag.doc["summary"]])


def _say_reduced(diag: Diagnosis, reductions: Sequence[Reduction | None]) -> None:
    """Each reduced recording's rule in its ``recordings`` entry (``reduction``) and, first, in the summary."""
    for entry, how in zip(diag.doc["recordings"], reductions, strict=True):
        if how is not None:
            entry["reduction"] = how.as_json()
    words = [how.words for how in reductions if how is not None]
    if words:
        diag.doc["summary"] = " ".join([*words, diag.doc["summary"]])
