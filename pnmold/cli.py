"""The ``pnmold`` command line: parses, dispatches to one handler per verb, maps errors to
exit codes (CONTRACTS.md §1): 0 success, 1 a design-rule check failed, 2 bad usage or
input, 3 a geometry, meshing or solver failure."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence

from rich.console import Console
from rich.markup import escape

from pnmold.errors import PnmoldError, UsageError

err_console = Console(stderr=True, highlight=False, soft_wrap=True)
out_console = Console(highlight=False, soft_wrap=True)


def _progress(args) -> Callable[[str], None]:
    if args.quiet:
        return lambda stage: None
    return lambda stage: err_console.print(f"[dim]…[/dim] {stage}")


def cmd_build(args) -> int:
    from pnmold.design import load_design
    from pnmold.pipeline import build

    design = load_design(args.design, args.set)
    result = build(design, args.out, fem=not args.no_fem, use_slicer=not args.no_slicer,
                   progress=_progress(args))
    if not args.quiet:
        out_console.print(f"wrote {result.out_dir}/ ({len(result.report['parts'])} parts as "
                          f"STEP and STL, design.toml, report.json)")
    return _verdict(result.report["checks"], args.quiet)


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
    from pnmold.design import load_design
    from pnmold.fsutil import write_json
    from pnmold.recording import write_recording
    from pnmold.simulate import SimulationRequest, parse_effects, parse_pressures, recording_columns, simulate_fe

    if args.dynamic:
        raise UsageError("--dynamic: the pneumatic dynamics are not available in this version")
    if args.model != "fe":
        raise UsageError(f"--model {args.model}: the reduced model is not available in this version (use fe)")
    if args.cycles < 1:
        raise UsageError("--cycles must be at least 1")
    design = load_design(args.design, args.set)
    request = SimulationRequest(parse_pressures(args.pressures), args.model, args.kind, args.cycles,
                                args.orientation, parse_effects(args.effects))
    doc = simulate_fe(design, request)
    if args.json:
        write_json(args.json, doc)
    if args.recording:
        meta = {"design": design.name, "orientation": args.orientation, "model": doc["model"]}
        if args.effects:
            meta["effects"] = args.effects.replace(" ", "")
        if args.rate_kpa_per_s:
            meta["rate_kpa_per_s"] = f"{args.rate_kpa_per_s:g}"
        write_recording(args.recording, args.kind, recording_columns(doc), meta)
    if not args.quiet:
        for s in doc["steps"]:
            extra = f", force {s['force_n']:.3f} N" if "force_n" in s else ""
            out_console.print(f"{s['pressure_kpa']:8.2f} kPa: bend {s['bend_angle_deg']:7.1f} deg, tip "
                              f"({s['tip_x_mm']:.1f}, {s['tip_z_mm']:.1f}) mm, "
                              f"cavity {s['cavity_volume_ml']:.3f} mL{extra}")
        fb = doc["full_bend_pressure_kpa"]
        out_console.print(f"full bend: {fb:.1f} kPa" if fb is not None else f"full bend: not reached ({doc['reason']})")
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

    p = sub.add_parser("simulate", help="quasi-static response (FE) as JSON or a recording",
                       description="Solve the design's pressure curve with the FE model: free bending, "
                       "pressure-volume, or blocked tip force; write it as JSON (pnmold.simulation/1) and/or "
                       "as a recording in the lab format.")
    _add_design(p)
    p.add_argument("--pressures", default="0:40:5", metavar="A:B:STEP", help="kPa (default 0:40:5)")
    p.add_argument("--model", choices=["fe", "rom"], default="fe")
    p.add_argument("--kind", choices=["bending", "pv", "force"], default="bending")
    p.add_argument("--cycles", type=int, default=1, help="inflate and deflate N times")
    p.add_argument("--rate-kpa-per-s", type=float, default=None, help="ramp rate (recorded as metadata)")
    p.add_argument("--effects", metavar="NAME=VALUE,...", help="physics effects (FE: gravity=0|1)")
    p.add_argument("--orientation", choices=["chambers_up", "chambers_down", "horizontal", "submerged"],
                   default="chambers_up", help="where gravity points (default chambers_up)")
    p.add_argument("--dynamic", action="store_true", help="time response to a supply step")
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
