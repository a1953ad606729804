"""``build``: design -> CAD -> STEP/STL -> checks -> quick FE -> report, in one folder.

The build is staged in a temporary folder that replaces ``out/<name>/`` only when every
stage has finished, so a failed run never leaves partial files or harms an earlier build.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pnmold.checks import check_parts
from pnmold.conventions import default_out_dir
from pnmold.design import Design, to_toml
from pnmold.errors import MeshingError, SolveError, UsageError
from pnmold.fsutil import read_json, staged_dir, write_json, write_text
from pnmold.report import build_report as rep
from pnmold.report import render
from pnmold.report.checklist import checklist_sections, render_markdown
from pnmold.report.html import picture_jobs, write_report

if TYPE_CHECKING:
    from pnmold.tetmesh import MeshSize

log = logging.getLogger(__name__)

Progress = Callable[[str], None]


@dataclass(frozen=True)
class BuildResult:
    """What a build wrote and found; ``exit_code`` is 1 when a design-rule check failed, 3
    when the quick FE failed (every part and the report are still written)."""

    design: Design
    out_dir: Path
    report: dict[str, Any]

    @property
    def failed_checks(self) -> list[dict[str, Any]]:
        return [c for c in self.report["checks"] if c["passed"] is False]

    @property
    def fem_failed(self) -> bool:
        return self.report["fem"].get("stop") == "failed"

    @property
    def exit_code(self) -> int:
        return 1 if self.failed_checks else 3 if self.fem_failed else 0

    def steps_frame(self):
        """The quick FE's steps (``report["fem"]["steps"]``) as a pandas DataFrame, one row per
        converged step (empty without the FE; UsageError without pandas: ``pnmold[pandas]``)."""
        from pnmold.frames import dataframe

        return dataframe(self.report["fem"].get("steps", []))

    def _summary(self) -> dict[str, str]:
        checks = self.report["checks"]
        passed = sum(c["passed"] is True for c in checks)
        skipped = sum(c["passed"] is None for c in checks)
        fem = self.report["fem"]
        bend = fem.get("full_bend_pressure_kpa")
        mass_g = sum(p["mass_g"] for p in self.report.get("pours", []))
        return {"design": f"{self.design.name} ({self.report['design']['digest']})", "folder": str(self.out_dir),
                "checks": f"{passed} passed, {len(self.failed_checks)} failed, {skipped} skipped",
                "full bend": f"{bend:.1f} kPa" if bend is not None else f"- ({fem.get('reason')})",
                "elastomer": f"{mass_g:.1f} g", "time": f"{sum(self.report['timings_s'].values()):.1f} s"}

    def __repr__(self) -> str:
        s = self._summary()
        return (f"<BuildResult {s['design']} in {s['folder']}: checks {s['checks']}; full bend {s['full bend']}; "
                f"elastomer {s['elastomer']}>")

    def _repr_html_(self) -> str:
        """The summary as a small table (Jupyter shows it for a build result)."""
        from pnmold.frames import summary_html

        failed = [f"{c['id']}: {c['message']}" for c in self.failed_checks]
        return summary_html("pnmold build", self._summary(), failed, "failed checks:")


def recheck(folder: str | Path, *, use_slicer: bool = True) -> dict[str, Any]:
    """Run the design-rule gate again on a build folder's files; update its ``report.json`` (the
    checks and the slicer's estimates, the rest kept) and return the new report."""
    path = Path(folder) / "report.json"
    report = read_json(path, "build report") if path.is_file() else {}
    checks = check_parts(folder, use_slicer=use_slicer)
    report = rep.record_checks(report, checks)
    write_json(path, report)
    return report


@contextmanager
def _stage(name: str, timings: dict[str, float], say: Progress) -> Iterator[None]:
    """Announce the build stage ``name`` and record its wall time in ``timings``."""
    say(name)
    t0 = time.perf_counter()
    yield
    timings[name] = round(time.perf_counter() - t0, 3)


def build(design: Design, out_dir: str | Path | None = None, *, fem: bool = True,
          use_slicer: bool = True, progress: Progress | None = None,
          fem_size: MeshSize | None = None, self_contact: bool = False) -> BuildResult:
    """Build every part of ``design`` into ``out_dir`` (default ``out/<name>/``).

    ``fem_size`` overrides the quick FE's mesh size (default :data:`pnmold.design_fe.BUILD_MESH`);
    ``self_contact`` keeps the quick FE's walls apart (:class:`pnmold.fem.SelfContact`, its defaults)."""
    from pnmold.cad import export_parts, make_parts

    say = progress or (lambda stage: None)
    final = Path(out_dir) if out_dir is not None else default_out_dir(design.name)
    timings: dict[str, float] = {}
    with staged_dir(final, "build") as tmp, render.Renderer() as renderer:
        with _stage("cad", timings, say):
            shapes = make_parts(design)
        with _stage("export", timings, say):
            export_parts(shapes, tmp)
        del shapes
        renderer.draw(picture_jobs(tmp))  # the part pictures are drawn while the checks and the FE run
        write_text(tmp / "design.toml", to_toml(design))
        with _stage("measure", timings, say):
            parts = rep.measure_parts(tmp, design.part_names)
        report = rep.new_report(design, parts, timings)
        with _stage("checks", timings, say):
            checks = check_parts(tmp, use_slicer=use_slicer)
        report = rep.record_checks(report, checks)
        if not fem:
            report["fem"]["reason"] = "skipped (--no-fem)"
        elif checks.failed:
            report["fem"]["reason"] = "skipped: a design-rule check failed"
        else:
            with _stage("fem", timings, say):
                report["fem"] = _quick_fe(design, tmp, fem_size, self_contact)
            if report["fem"].get("stop") == "failed":  # the parts stand; the FE's reason is reported
                say(f"quick FE failed: {report['fem']['reason']}")
        write_json(tmp / "report.json", report)
        write_text(tmp / "checklist.md", render_markdown(design, checklist_sections(design, report)))
        with _stage("report", timings, say):
            write_report(tmp, report, renderer)
        write_json(tmp / "report.json", report)  # again, with the report stage's time
    return BuildResult(design, final, report)


def _quick_fe(design: Design, folder: Path, size: MeshSize | None = None,
              self_contact: bool = False) -> dict[str, Any]:
    """Bend the exported actuator (:func:`pnmold.design_fe.run_fe`); its files and the report's ``fem`` section."""
    from pnmold.design_fe import BUILD_MESH, build_options, run_fe
    from pnmold.report.fem import failed_fe_section, write_fe_section

    try:
        run = run_fe(design, step_path=folder / "actuator.step", size=size or BUILD_MESH,
                     options=build_options(self_contact), keep_partial=True)
    except (MeshingError, SolveError) as err:  # nothing converged: no curve to report
        log.warning("quick FE failed: %s", err)
        return failed_fe_section(err)
    return write_fe_section(run, folder)


def report_for(design: Design, out_dir: str | Path | None = None) -> dict[str, Any]:
    """The build report of ``design``: the one in its build folder when that was built
    from exactly this design (same digest), else a fresh geometry-only build's."""
    import tempfile

    path = Path(out_dir or default_out_dir(design.name)) / "report.json"
    if path.is_file():
        report = read_json(path, "build report")
        if report.get("design", {}).get("digest") == rep.design_entry(design)["digest"]:
            return report
    with tempfile.TemporaryDirectory() as tmp:
        return build(design, Path(tmp) / design.name, fem=False, use_slicer=False).report


def checklist_text(design: Design, fmt: str = "md") -> str:
    """The fabrication checklist of ``design`` as Markdown (``md``) or printable HTML, with the
    quantities of its build report (:func:`report_for`)."""
    from pnmold.report.checklist import render_html

    if fmt not in ("md", "html"):
        raise UsageError(f"--format: md or html, got {fmt!r}")
    sections = checklist_sections(design, report_for(design))
    return (render_html if fmt == "html" else render_markdown)(design, sections)
