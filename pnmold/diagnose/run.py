"""A diagnosis from files to files: what ``pnmold diagnose`` does, as one library call."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from pnmold.design import Design

from .core import Diagnosis, diagnose
from .data import MODEL_FORM_SHARE
from .model import diagnosis_effects, diagnosis_forward, read_all, stiffening_top


def diagnose_recordings(design: Design, paths: Sequence[str | Path], *, seed: int = 0,
                        json_path: str | Path | None = None, report_dir: str | Path | None = None,
                        progress: Callable[[str], None] | None = None,
                        model_form_share: float = MODEL_FORM_SHARE) -> Diagnosis:
    """Read and check every recording (a damaged one stops the run before anything is computed
    or written), characterise the design in the FE once (cached; templates ship theirs; its
    stages go to ``progress``), diagnose, and write the JSON and the report folder."""
    from pnmold.physics.characterise import characterise
    from pnmold.report import design_entry

    from .output import write_json_doc, write_report

    recordings = read_all(paths)
    c = characterise(design, progress=progress)
    reach = {"max_pressure_kpa": c.max_pressure_kpa, "full_bend_pressure_kpa": c.full_bend_pressure_kpa,
             "reason": c.reason}
    def run(top: float) -> Diagnosis:  # the forward after the ladder: its model reads it
        return diagnose(design_entry(design), recordings, diagnosis_forward(design, recordings),
                        diagnosis_effects(recordings), seed=seed, reach=reach, model_form_share=model_form_share,
                        stiffening_top_mpa=top)

    top = stiffening_top(design, recordings, progress)
    diag = run(top)
    if not top and diag.past_maximum:  # past the calibrated model's maximum, though not the design rubber's
        top = stiffening_top(design, recordings, progress, past=True)
        diag = run(top) if top else diag
    if json_path:
        write_json_doc(diag, json_path)
    if report_dir:
        write_report(diag, report_dir)
    return diag
