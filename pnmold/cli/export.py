"""``pnmold export``: a build folder's FE problem for Abaqus/CalculiX (an input deck) or SOFA."""

from __future__ import annotations

from pnmold.cli._common import out_console, stages
from pnmold.conventions import NO_GRAVITY, ORIENTATIONS
from pnmold.export import FORMATS, LAYER_ELEMENTS, SOLID_ELEMENTS, SOLVERS

HELP = "write a build's FE problem as an Abaqus/CalculiX deck or SOFA files"
DESCRIPTION = ("Re-mesh a build folder's actuator.step as its quick FE did and write the same problem for another "
               "solver: --format abaqus writes DIR/abaqus/actuator.inp (C3D10, Yeoh, the paper layer, clamp, "
               "symmetry, gravity then the cavity pressures in one nonlinear step; mm-N-MPa-tonne) and "
               "material.json; --format sofa writes DIR/sofa/ with the whole body's linear tet mesh (actuator.vtk), "
               "the closed cavity surface (cavity.stl), the node sets (boundaries.json) and material.json "
               "(neo-Hookean and Mooney-Rivlin constants for solvers without Yeoh).")


def add_args(parser) -> None:
    parser.add_argument("dir", help="a build folder (out/<design-name>/)")
    parser.add_argument("--format", choices=list(FORMATS), default="abaqus", help="default abaqus")
    parser.add_argument("--out", metavar="DIR", help="output folder (default DIR/<format>/)")
    deck = parser.add_argument_group("the deck (--format abaqus)")
    deck.add_argument("--pressures", metavar="A:B:STEP",
                      help="kPa, the target pressures > 0 (default: the build's converged FE pressures)")
    deck.add_argument("--orientation", choices=[*ORIENTATIONS, NO_GRAVITY],
                      help="where gravity points, or none (default: the build's, chambers_up)")
    deck.add_argument("--solver", choices=list(SOLVERS), default="calculix",
                      help="dialect of the output requests (default calculix)")
    deck.add_argument("--element", choices=list(SOLID_ELEMENTS), default="C3D10",
                      help="solid element (C3D10H: Abaqus' hybrid element; CalculiX has none)")
    deck.add_argument("--layer", choices=list(LAYER_ELEMENTS), default="M3D6",
                      help="the paper: M3D6 membranes (default, as pnmold), S6 shells or C3D15 wedges "
                      "(with the sheet's bending stiffness)")
    deck.add_argument("--contact-mpa-per-mm", type=float, metavar="K",
                      help="the facing walls of each gap between chambers as frictionless contact pairs with this "
                      "penalty (e.g. 10, pnmold's own); default: no contact")


def run(args) -> int:
    from pnmold.export.abaqus import DeckOptions
    from pnmold.export.folder import export_build
    from pnmold.simulate import parse_pressures

    if args.out:  # refused before the meshing, not after it
        from pnmold.fsutil import check_replaceable

        check_replaceable(args.out)
    pressures = parse_pressures(args.pressures) if args.pressures else None
    options = DeckOptions(solver=args.solver, solid=args.element, layer=args.layer,
                          contact_mpa_per_mm=args.contact_mpa_per_mm)
    with stages(args, f"export {args.format}") as say:
        say("mesh and write")
        done = export_build(args.dir, args.format, out_dir=args.out, pressures_kpa=pressures,
                            orientation=args.orientation, options=options)
    if not args.quiet:
        what = "half model" if done.size.half and done.format == "abaqus" else "whole body"
        out_console.print(f"wrote {', '.join(str(p) for p in done.files)}")
        out_console.print(f"{done.nodes} nodes, {done.elements} elements ({what}, mesh {done.size.wall_mm:g}/"
                          f"{done.size.max_mm:g} mm)"
                          + (f"; {len(done.pressures_kpa)} target pressures up to {max(done.pressures_kpa):g} kPa"
                             if done.format == "abaqus" else "")
                          + ("" if done.format == "sofa" or done.gravity_g is None else ", gravity first"))
    return 0
