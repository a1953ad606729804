"""``pnmold material fit|list``: hyperelastic fits of tensile tests, and the elastomer library."""

from __future__ import annotations

from rich.markup import escape

from pnmold.cli._common import emit_json, json_file, out_console, output_flags

HELP = "elastomer library and hyperelastic fits"
DESCRIPTION = "The elastomer library, and hyperelastic fits of tensile tests."


def add_args(parser) -> None:
    actions = parser.add_subparsers(dest="material_verb", required=True, metavar="ACTION")
    fit = actions.add_parser(
        "fit", parents=[output_flags()], help="fit a uniaxial tensile test (pnmold's CSV or a lab's file as published)",
        description="Fit an incompressible hyperelastic model to a uniaxial tensile test; prints the constants, R2 "
        "and the strain range where the fit holds, and writes a plot like the supplement's Fig. S4. By default it "
        "fits where actuators work: the points up to 150 % engineering strain (--max-strain 1.5; all of them when "
        "the test stops earlier), weighting the relative error so the small strains count as much as the large "
        "stresses at break; --max-strain full fits the whole test to break. Reads pnmold's "
        "CSV (eng_strain, eng_stress_mpa) and lab files as published, e.g. the Soft Robotics Materials Database's "
        "(';'-separated, a metadata block, 'Engineering Strain', 'Engineering Stress (MPa)'): delimiter and header "
        "found, columns by name or by the options below, units from the header (MPa, kPa, Pa, N/mm2, psi; strain "
        "as a ratio or %), true stress converted to engineering stress, or force and extension with the "
        "specimen's size. See `pnmold docs tensile-files`.")
    fit.add_argument("tensile", metavar="TENSILE.csv")
    fit.add_argument("--model", choices=["yeoh", "neo-hookean", "ogden"], default="yeoh")
    fit.add_argument("--json", metavar="FILE",
                     help="write the fit as JSON (the plot goes beside it); - for standard output")
    fit.add_argument("--max-strain", metavar="E|full",
                     help="fit the points up to this engineering strain (default 1.5, where actuators work, with "
                     "--weighting relative), or 'full': every point to break; with this option the fit weights "
                     "the stress error in MPa (--weighting absolute), as the library's constants were fitted")
    fit.add_argument("--weighting", choices=["relative", "absolute"],
                     help="what the fit minimises: the relative stress error (the default without --max-strain) "
                     "or the error in MPa (the default with it)")
    fit.add_argument("--allow-negative", dest="nonnegative", action="store_false",
                     help="Yeoh: let C20 and C30 go negative (by default they are kept >= 0, as a design's "
                     "[material] section requires; a term held at 0 is named with the unconstrained value)")
    cols = fit.add_argument_group("columns (default: found by name; NAME is a header name or a 1-based position)")
    cols.add_argument("--strain-column", metavar="NAME", help="engineering strain, or a true strain column")
    cols.add_argument("--stress-column", metavar="NAME", help="engineering (nominal) or true stress")
    cols.add_argument("--stress-kind", choices=["engineering", "true"],
                      help="what the stress column holds (default: what its name says; true stress is converted "
                      "with engineering = true / (1 + strain))")
    cols.add_argument("--force-column", metavar="NAME", help="force, when there is no stress column")
    cols.add_argument("--extension-column", metavar="NAME", help="extension, when there is no strain column")
    units = fit.add_argument_group("units (default: from the header; these override it)")
    units.add_argument("--strain-unit", metavar="UNIT",
                       help="ratio (the default without one) or %%; a strain read as a ratio that passes 20 "
                       "(2000 %%) is refused as a percentage unless this option says ratio")
    units.add_argument("--stress-unit", metavar="UNIT", help="MPa, kPa, Pa, N/mm2, psi, ...")
    units.add_argument("--force-unit", metavar="UNIT", help="N, kN or lbf")
    units.add_argument("--extension-unit", metavar="UNIT", help="mm, cm, m, um or in")
    size = fit.add_argument_group("specimen (force and extension; default: the file's metadata rows)")
    size.add_argument("--gauge-length-mm", type=float, metavar="L0", help="gauge length")
    size.add_argument("--area-mm2", type=float, metavar="A0", help="initial cross-section")
    size.add_argument("--width-mm", type=float, metavar="W", help="width (with --thickness-mm, instead of --area-mm2)")
    size.add_argument("--thickness-mm", type=float, metavar="T", help="thickness")
    fit.set_defaults(handler=run_fit, nonnegative=True)
    listing = actions.add_parser("list", parents=[output_flags()], help="list the material library",
                                 description="List the material library.")
    listing.set_defaults(handler=run_list)


def run_fit(args) -> int:
    from pnmold.materials import fit_command
    from pnmold.materials.fit import Specimen, TensileColumns

    columns = TensileColumns(args.strain_column, args.stress_column, args.stress_kind, args.force_column,
                             args.extension_column, args.strain_unit, args.stress_unit, args.force_unit,
                             args.extension_unit)
    specimen = Specimen(args.gauge_length_mm, args.area_mm2, args.width_mm, args.thickness_mm)
    result = fit_command(args.tensile, args.model, json_path=json_file(args), columns=columns, specimen=specimen,
                         nonnegative=args.nonnegative, max_strain=args.max_strain, weighting=args.weighting)
    emit_json(args, result.to_json())
    if not args.quiet:
        for what, how in (result.read or {}).items():
            out_console.print(f"{what}: {escape(how)}")
    out_console.print(escape(result.scope()))
    out_console.print(escape(result.summary()))
    if result.plot:
        out_console.print(f"plot: {result.plot}")
    return 0


def run_list(args) -> int:
    from pnmold.materials import list_materials

    for m in list_materials():
        out_console.print(f"{m.name:<18} Yeoh C10 {m.c10_mpa:g}, C20 {m.c20_mpa:g}, C30 {m.c30_mpa:g} MPa; "
                          f"{m.density_g_per_ml:g} g/mL; A:B {m.mix_ratio_a_to_b:g}")
    return 0

