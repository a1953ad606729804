"""The ``pnmold`` command line: parses, dispatches to one handler per verb, maps errors to
exit codes (CONTRACTS.md §1): 0 success, 1 a design-rule check failed, 2 bad usage or
input, 3 a geometry, meshing or solver failure."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from rich.console import Console
from rich.markup import escape

from pnmold.errors import PnmoldError, UsageError

err_console = Console(stderr=True, highlight=False, soft_wrap=True)
out_console = Console(highlight=False, soft_wrap=True)


def cmd_build(args) -> int:
    from pnmold.design import load_design
    from pnmold.pipeline import build
    from pnmold.progress import stage_progress

    design = load_design(args.design, args.set)
    with stage_progress(err_console, args.quiet, title=f"build {design.name}") as say:
        result = build(design, args.out, fem=not args.no_fem, use_slicer=not args.no_slicer, progress=say)
    if not args.quiet:
        out_console.print(f"wrote {result.out_dir}/ ({len(result.report['parts'])} parts as "
                          f"STEP and STL, design.toml, report.json, report.html)")
    return _verdict(result.report["checks"], args.quiet)


def cmd_report(args) -> int:
    from pnmold.report_html import write_report

    path = write_report(args.dir)
    if not args.quiet:
        out_console.print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0


def _verdict(checks: list[dict], quiet: bool) -> int:
    """Print the failed checks in plain words; 1 when any failed."""
    failed = [c for c in checks if c["passed"] is False]
    skipped = [c for c in checks if c["passed"] is None]
    for check in failed:
        err_console.print(f"[red]FAILED[/red] {check['id']}: {escape(check['message'])}")
    if not quiet:
        for check in skipped:
            err_console.print(f"[yellow]skipped[/yellow] {check['id']}: {escape(check['message'])}")
        passed = len(checks) - len(failed) - len(skipped)
        out_console.print(f"checks: {passed} passed, {len(failed)} failed, {len(skipped)} skipped")
    return 1 if failed else 0


def cmd_check(args) -> int:
    import json
    from pathlib import Path

    from pnmold.checks import check_parts
    from pnmold.fsutil import write_json
    from pnmold.pipeline import record_checks

    checks = check_parts(args.dir, use_slicer=not args.no_slicer)
    path = Path(args.dir) / "report.json"
    report = json.loads(path.read_text()) if path.is_file() else {}
    write_json(path, record_checks(report, checks))
    return _verdict(record_checks({}, checks)["checks"], args.quiet)


def cmd_templates(args) -> int:
    from pnmold.design import list_templates

    for name, description in list_templates().items():
        out_console.print(f"{name:<14} {escape(description)}")
    return 0


def cmd_material_fit(args) -> int:
    from pnmold.materials import fit_command

    result = fit_command(args.tensile, args.model, json_path=args.json)
    out_console.print(escape(result.summary()))
    if result.plot:
        out_console.print(f"plot: {result.plot}")
    return 0


def cmd_material_list(args) -> int:
    from pnmold.materials import list_materials

    for m in list_materials():
        out_console.print(f"{m.name:<18} Yeoh C10 {m.c10_mpa:g}, C20 {m.c20_mpa:g}, C30 {m.c30_mpa:g} MPa; "
                          f"{m.density_g_per_ml:g} g/mL; A:B {m.mix_ratio_a_to_b:g}")
    return 0


def cmd_simulate(args) -> int:
    if args.dynamic:
        from pnmold.pneumatics.cli import cmd_simulate_dynamic

        return cmd_simulate_dynamic(args)
    from pnmold.design import load_design
    from pnmold.fsutil import write_json
    from pnmold.recording import write_recording
    from pnmold.simulate import (
        SimulationRequest,
        noisy_columns,
        parse_effects,
        parse_pressures,
        recording_columns,
        simulate_fe,
        simulate_rom,
    )

    if args.cycles < 1:
        raise UsageError("--cycles must be at least 1")
    if args.rate_kpa_per_s is not None and not args.rate_kpa_per_s > 0:
        raise UsageError(f"--rate-kpa-per-s must be > 0, got {args.rate_kpa_per_s:g}")
    design = load_design(args.design, args.set)
    request = SimulationRequest(parse_pressures(args.pressures), args.model, args.kind, args.cycles,
                                args.orientation, parse_effects(args.effects), args.rate_kpa_per_s)
    if args.model == "rom":
        doc = simulate_rom(design, request, _characterise_once(design, args.quiet))
    else:
        doc = simulate_fe(design, request)
    if args.json:
        write_json(args.json, doc)
    if args.recording:
        meta = {"design": design.name, "orientation": args.orientation, "model": doc["model"]}
        if args.effects:
            meta["effects"] = args.effects.replace(" ", "")
        if args.rate_kpa_per_s:
            meta["rate_kpa_per_s"] = f"{args.rate_kpa_per_s:g}"
        columns = noisy_columns(recording_columns(doc), noise_mm=args.noise_mm, noise_ml=args.noise_ml,
                                noise_n=args.noise_n, seed=args.seed)
        if args.noise_mm or args.noise_ml or args.noise_n:
            meta["noise"] = f"mm={args.noise_mm:g};ml={args.noise_ml:g};n={args.noise_n:g};seed={args.seed}"
        write_recording(args.recording, args.kind, columns, meta)
    if not args.quiet:
        for s in doc["steps"]:
            extra = f", force {s['force_n']:.3f} N" if "force_n" in s else ""
            out_console.print(f"{s['pressure_kpa']:8.2f} kPa: bend {s['bend_angle_deg']:7.1f} deg, tip "
                              f"({s['tip_x_mm']:.1f}, {s['tip_z_mm']:.1f}) mm, "
                              f"cavity {s['cavity_volume_ml']:.3f} mL{extra}")
        fb = doc["full_bend_pressure_kpa"]
        out_console.print(f"full bend: {fb:.1f} kPa" if fb is not None else f"full bend: not reached ({doc['reason']})")
    return 0


def cmd_effects(args) -> int:
    import json

    from pnmold.physics.effects import EFFECTS, catalogue_json

    if args.json:
        sys.stdout.write(json.dumps(catalogue_json(), indent=2) + "\n")
        return 0
    for e in EFFECTS.values():
        lo, hi = e.bounds
        out_console.print(f"[bold]{e.name}[/bold] {e.parameter} [{lo:g}, {hi:g}] {e.unit}, default {e.default:g} "
                          f"({', '.join(e.kinds)}; {', '.join(e.models)}): {escape(e.description)}")
        for param, unit, default, (plo, phi) in e.extra:
            out_console.print(f"    {e.name}.{param} [{plo:g}, {phi:g}] {unit}, default {default:g}")
    return 0


def _characterise_once(design, quiet: bool):
    """The FE characterisation the reduced model reads: cached or shipped with pnmold (the
    templates'), else run now (minutes, with progress shown)."""
    from pnmold.physics.characterise import DEFAULT_MAX_PRESSURE_KPA, DEFAULT_SIZE, characterise, stored_path
    from pnmold.progress import stage_progress

    stored = stored_path(design, DEFAULT_SIZE, DEFAULT_MAX_PRESSURE_KPA) is not None
    with stage_progress(err_console, quiet or stored, title=f"characterise {design.name} (once)") as say:
        return characterise(design, progress=say)


def cmd_diagnose(args) -> int:
    from pnmold.design import load_design
    from pnmold.diagnose import diagnose
    from pnmold.diagnose.model import diagnosis_effects, diagnosis_forward, read_all
    from pnmold.diagnose.output import write_json_doc, write_report
    from pnmold.report import design_entry

    recordings = read_all(args.recordings)  # every file checked before anything is computed or written
    design = load_design(args.design, args.set)
    _characterise_once(design, args.quiet)
    diag = diagnose(design_entry(design), recordings, diagnosis_forward(design, recordings),
                    diagnosis_effects(recordings), seed=args.seed)
    if args.json:
        write_json_doc(diag, args.json)
    if args.report:
        write_report(diag, args.report)
    if not args.quiet:
        out_console.print(escape(diag.doc["summary"]))
        for m in diag.doc["mismatch"]:
            out_console.print(f"  mismatch: {escape(m['description'])}")
    return 0


def cmd_checklist(args) -> int:
    from pnmold.checklist import checklist_sections, render_html, render_markdown
    from pnmold.design import load_design
    from pnmold.fsutil import write_text
    from pnmold.pipeline import report_for

    design = load_design(args.design, args.set)
    sections = checklist_sections(design, report_for(design))
    text = (render_html if args.format == "html" else render_markdown)(design, sections)
    if args.out:
        write_text(args.out, text)
        out_console.print(f"wrote {args.out}")
    else:
        out_console.print(text, markup=False)
    return 0


def cmd_sweep(args) -> int:
    import contextlib

    from pnmold.sweep import default_db, load_sweep, run_sweep
    from pnmold.sweep.plot import plot_sweep
    from pnmold.sweep.progress import SweepProgress

    spec = load_sweep(args.sweep)
    if args.scheduler and args.workers is not None:
        raise UsageError("--workers sizes the local pool; with --scheduler the cluster's workers run the points")
    db = args.db or default_db(spec.name)
    view = contextlib.nullcontext(None) if args.quiet else SweepProgress(err_console, spec.name)
    try:
        with view as bar:
            result = run_sweep(spec, db, scheduler=args.scheduler, workers=args.workers, on_update=bar)
    except KeyboardInterrupt:
        err_console.print(f"interrupted: finished points are in {db}; run the same command to resume")
        return 130
    written = [str(db)]
    if args.export == "csv":
        from pnmold.sweep import SweepStore

        with SweepStore(db, spec.fields) as store:
            written.append(str(store.export_csv()))
    if len(spec.axes) == 1 and spec.run.fem:
        written.append(str(plot_sweep(spec, result.rows, result.db.with_suffix(".png"))))
    if not args.quiet:
        statuses = [r["status"] for r in result.rows]
        tally = ", ".join(f"{statuses.count(s)} {s}" for s in ("ok", "check_failed", "refused", "failed"))
        for row in result.rows[:40]:
            inputs = ", ".join(f"{f}={row[f]}" for f in spec.fields)
            bend = row["full_bend_pressure_kpa"]
            what = f"full bend {bend:.1f} kPa" if bend is not None else (row["error"] or row["reason"] or "")
            out_console.print(f"  {inputs}: {row['status']}, {escape(what)}")
        out_console.print(f"{spec.name}: {len(result.points)} points ({tally}); {result.counts.done} computed now, "
                          f"{result.counts.skipped} already done; wrote {', '.join(written)}")
    return 0


def _add_design(parser: argparse.ArgumentParser, default: str | None = None) -> None:
    if default is None:
        parser.add_argument("design", help="template name (see `pnmold templates`) or TOML file")
    else:
        parser.add_argument("design", nargs="?", default=default,
                            help=f"template name or TOML file (default {default})")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a design field (repeatable)")


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pnmold", description=(
        "PneuNet bending actuators: casting molds, design-rule checks, quick FE, diagnosis."))
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    sub = parser.add_subparsers(dest="verb", required=True, metavar="VERB")

    p = sub.add_parser("build", help="CAD, export, checks, quick FE into out/<design>/",
                       description="Build the actuator and its three molds as STEP and STL.")
    _add_design(p, default="fpn")
    p.add_argument("--out", metavar="DIR", help="output folder (default out/<design-name>/)")
    p.add_argument("--no-fem", action="store_true", help="skip the quick FE solve")
    p.add_argument("--no-slicer", action="store_true", help="skip PrusaSlicer (reported as skipped)")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(handler=cmd_build)

    p = sub.add_parser("check", help="re-run every design-rule check on a build folder",
                       description="Re-run the design-rule gate on the files of a build folder; "
                       "updates its report.json; exit 1 when a check fails.")
    p.add_argument("dir", help="a build folder (out/<design-name>/)")
    p.add_argument("--no-slicer", action="store_true", help="skip PrusaSlicer (reported as skipped)")
    p.add_argument("--quiet", action="store_true", help="print only failures")
    p.set_defaults(handler=cmd_check)

    p = sub.add_parser("report", help="(re)write report.html of a build folder",
                       description="Write DIR/report.html, the self-contained page of a build folder: part "
                       "pictures, a 3D view, the checks, the FE curves and strain, the slicer's estimates and "
                       "the checklist. Reads the folder's files; changes nothing else.")
    p.add_argument("dir", help="a build folder (out/<design-name>/)")
    p.add_argument("--quiet", action="store_true", help="print nothing")
    p.set_defaults(handler=cmd_report)

    p = sub.add_parser("simulate", help="quasi-static response (FE or reduced model) as JSON or a recording",
                       description="Solve the design's pressure curve with the FE model or the reduced model "
                       "(--model rom, characterised by the FE once: templates ship theirs, others are cached in "
                       "out/.cache/fe/): free bending, "
                       "pressure-volume, or blocked tip force, with physics effects switched on; write it as JSON "
                       "(pnmold.simulation/1) and/or as a recording in the lab format (synthetic data).")
    _add_design(p)
    p.add_argument("--pressures", default="0:40:5", metavar="A:B:STEP", help="kPa (default 0:40:5)")
    p.add_argument("--model", choices=["fe", "rom"], default="fe")
    p.add_argument("--kind", choices=["bending", "pv", "force"], default="bending")
    p.add_argument("--cycles", type=int, default=1, help="inflate and deflate N times")
    p.add_argument("--rate-kpa-per-s", type=float, default=None,
                   help="ramp rate: the rows' time_s (viscoelasticity needs it); recorded as metadata")
    p.add_argument("--effects", metavar="NAME=VALUE,...",
                   help="physics effects and NAME.PARAM=VALUE (see `pnmold effects`; FE: gravity, "
                   "strain_stiffening, layer_compliance)")
    p.add_argument("--noise-mm", type=float, default=0.0, metavar="SIGMA",
                   help="--recording: Gaussian noise on tip_x_mm and tip_z_mm (standard deviation, mm)")
    p.add_argument("--noise-ml", type=float, default=0.0, metavar="SIGMA",
                   help="--recording: Gaussian noise on volume_ml (mL)")
    p.add_argument("--noise-n", type=float, default=0.0, metavar="SIGMA", help="--recording: noise on force_n (N)")
    p.add_argument("--seed", type=int, default=None, help="seed of the recording's noise")
    p.add_argument("--orientation", choices=["chambers_up", "chambers_down", "horizontal", "submerged"],
                   default="chambers_up", help="where gravity points (default chambers_up)")
    p.add_argument("--dynamic", action="store_true", help="time response to a supply step (valve opens at t = 0)")
    p.add_argument("--supply-kpa", type=float, metavar="P", help="--dynamic: regulated supply, gauge kPa (required)")
    p.add_argument("--valve-orifice-mm", type=float, metavar="D",
                   help="--dynamic: effective orifice of the supply and vent valves (default 1.0, assumed)")
    p.add_argument("--valve-sonic-conductance", type=float, metavar="C",
                   help="--dynamic: the valves' ISO 6358 sonic conductance in dm3/(s bar), instead of the orifice")
    p.add_argument("--valve-critical-ratio", type=float, metavar="B",
                   help="--dynamic: the valves' ISO 6358 critical pressure ratio (default 0.5)")
    p.add_argument("--tubing-length-mm", type=float, help="--dynamic: tubing from valves to actuator (default 300)")
    p.add_argument("--tubing-id-mm", type=float,
                   help="--dynamic: tubing bore (default the design's inlet.tubing_id_mm, 1/32 in = 0.79375 mm)")
    p.add_argument("--vent-at-s", type=float, metavar="T", help="--dynamic: close supply, open vent at T s")
    p.add_argument("--duration-s", type=float, default=0.5, help="--dynamic: simulated time (default 0.5 s)")
    p.add_argument("--gas-law", choices=["isothermal", "adiabatic"], default="isothermal",
                   help="--dynamic: gas in the chambers (default isothermal)")
    p.add_argument("--plot", metavar="FILE.png", help="--dynamic: figure (default beside --json or --recording)")
    p.add_argument("--recording", metavar="FILE.csv", help="write the result in the recording format")
    p.add_argument("--json", metavar="FILE", help="write pnmold.simulation/1 JSON")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(handler=cmd_simulate)

    p = sub.add_parser("checklist", help="fabrication checklist with quantities from the geometry",
                       description="The fabrication and testing checklist of a design, with elastomer "
                       "amounts, paper size, inlet position, print settings and test pressures worked out. "
                       "Uses out/<design>/report.json when it was built from this design.")
    _add_design(p)
    p.add_argument("--format", choices=["md", "html"], default="md")
    p.add_argument("--out", metavar="FILE", help="write to FILE (default: print)")
    p.set_defaults(handler=cmd_checklist)

    p = sub.add_parser("material", help="elastomer library and hyperelastic fits",
                       description="The elastomer library, and hyperelastic fits of tensile tests.")
    msub = p.add_subparsers(dest="material_verb", required=True, metavar="ACTION")
    q = msub.add_parser("fit", help="fit a uniaxial tensile test (CSV: eng_strain, eng_stress_mpa)",
                        description="Fit an incompressible hyperelastic model to engineering "
                        "stress-strain data; prints the constants, R2 and the strain range where "
                        "the fit holds, and writes a plot like the supplement's Fig. S4.")
    q.add_argument("tensile", metavar="TENSILE.csv")
    q.add_argument("--model", choices=["yeoh", "neo-hookean", "ogden"], default="yeoh")
    q.add_argument("--json", metavar="FILE", help="write the fit as JSON (the plot goes beside it)")
    q.set_defaults(handler=cmd_material_fit)
    q = msub.add_parser("list", help="list the material library", description="List the material library.")
    q.set_defaults(handler=cmd_material_list)

    p = sub.add_parser("sweep", help="many designs from a sweep file, results in SQLite",
                       description="Build every point of a sweep file (a base design and axes over its "
                       "fields, grid or random) on local processes or a Dask cluster; one SQLite row per "
                       "point, committed as it arrives; re-running skips finished points.")
    p.add_argument("sweep", metavar="SWEEP.toml", help="the sweep file (see templates/sweeps/)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786 (default: "
                   "local processes)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes (default: the number of cores)")
    p.add_argument("--db", metavar="FILE", help="results database (default out/sweeps/<sweep-name>.sqlite)")
    p.add_argument("--export", choices=["csv"], help="also write the table beside the database")
    p.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    p.set_defaults(handler=cmd_sweep)

    p = sub.add_parser("diagnose", help="compare recordings with the model and name the missing physics",
                       description="Compare lab recordings (CONTRACTS.md §4) with the reduced model (step "
                       "recordings: with the pneumatic step model): recalibrate the modulus, locate the mismatch, "
                       "name the missing physics from the catalogue of effects (pnmold effects), fit it and show "
                       "the held-out improvement; or say nothing is missing.")
    _add_design(p)
    p.add_argument("recordings", nargs="+", metavar="RECORDING.csv", help="recordings (bending, pv, force, step)")
    p.add_argument("--json", metavar="FILE", help="write the diagnosis (schema pnmold.diagnosis/1)")
    p.add_argument("--report", metavar="DIR", help="write report.html with before/after plots into DIR")
    p.add_argument("--seed", type=int, default=0, help="seed of the bootstrap resampling (default 0)")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(handler=cmd_diagnose)

    p = sub.add_parser("effects", help="the catalogue of physics effects",
                       description="The catalogue of physics effects: name, parameter, unit, default, plausible "
                       "bounds, the recording kinds that show it, and its fingerprint.")
    p.add_argument("--json", action="store_true", help="print the catalogue as JSON")
    p.set_defaults(handler=cmd_effects)

    p = sub.add_parser("templates", help="list the design templates",
                       description="List the design templates with one line each.")
    p.set_defaults(handler=cmd_templates)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = make_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help -> 0, bad usage -> 2
        return int(exc.code or 0)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return args.handler(args)
    except PnmoldError as err:
        err_console.print(f"[red]error[/red] ({type(err).__name__}): {escape(str(err))}")
        return err.exit_code


if __name__ == "__main__":
    sys.exit(main())
