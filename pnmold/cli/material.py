"""``pnmold material fit|list``: hyperelastic fits of tensile tests, and the elastomer library."""

from __future__ import annotations

from rich.markup import escape

from pnmold.cli._common import out_console

HELP = "elastomer library and hyperelastic fits"
DESCRIPTION = "The elastomer library, and hyperelastic fits of tensile tests."


def add_args(parser) -> None:
    actions = parser.add_subparsers(dest="material_verb", required=True, metavar="ACTION")
    fit = actions.add_parser("fit", help="fit a uniaxial tensile test (CSV: eng_strain, eng_stress_mpa)",
                             description="Fit an incompressible hyperelastic model to engineering stress-strain "
                             "data; prints the constants, R2 and the strain range where the fit holds, and writes a "
                             "plot like the supplement's Fig. S4.")
    fit.add_argument("tensile", metavar="TENSILE.csv")
    fit.add_argument("--model", choices=["yeoh", "neo-hookean", "ogden"], default="yeoh")
    fit.add_argument("--json", metavar="FILE", help="write the fit as JSON (the plot goes beside it)")
    fit.set_defaults(handler=run_fit)
    listing = actions.add_parser("list", help="list the material library", description="List the material library.")
    listing.set_defaults(handler=run_list)


def run_fit(args) -> int:
    from pnmold.materials import fit_command

    result = fit_command(args.tensile, args.model, json_path=args.json)
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

