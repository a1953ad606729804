"""pnmold's FE against CalculiX on pnmold's exported deck of the fPN, with timings.

Exports the default fPN's actuator, meshes it as the build does (``design_fe.BUILD_MESH``
unless ``--size``), solves the pressure curve with pnmold (mean-dilatation volumetric term,
the default) and with pnmold's pointwise penalty (the volumetric term of CalculiX's C3D10),
writes the deck of the same mesh and loads (``pnmold.export``) and runs ``ccx`` on it; prints
the tip (x, z) of each at every pressure and the differences as fractions of the tip's travel.
Needs ``ccx`` (Debian ``calculix-ccx``; ``scripts/install-system-deps.sh``).

    .venv/bin/python benchmarks/calculix.py [--pressures 2,4,6,8] [--size WALL,MAX] [--gravity]
                                            [--layer M3D6|S6|C3D15] [--threads N] [--keep DIR]
                                            [--contact K]

``--contact K``: pnmold solves with its self-contact (``SelfContact``, penalty K MPa/mm) and the
deck pairs the facing walls of each gap with a linear penalty of K (``pnmold export
--contact-mpa-per-mm``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pnmold.cad import export_actuator_step  # noqa: E402
from pnmold.design import load_design  # noqa: E402
from pnmold.design_fe import BUILD_MESH, run_fe  # noqa: E402
from pnmold.export.abaqus import DeckOptions  # noqa: E402
from pnmold.export.calculix import compare_with_calculix, find_ccx, read_displacements  # noqa: E402
from pnmold.export.contact_pairs import closest_walls_mm, gap_pairs  # noqa: E402
from pnmold.fem import SelfContact  # noqa: E402
from pnmold.fem.solver import SolveOptions  # noqa: E402
from pnmold.tetmesh import MeshSize  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--pressures", default="2,4,6,8", help="kPa, comma-separated")
    parser.add_argument("--size", help="mesh WALL,MAX in mm (default the build's)")
    parser.add_argument("--gravity", action="store_true", help="chambers up, gravity first (default: none)")
    parser.add_argument("--layer", default="M3D6", choices=["M3D6", "S6", "C3D15"])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--keep", metavar="DIR", help="keep the deck and CalculiX's files here")
    parser.add_argument("--contact", type=float, metavar="K", help="self-contact with this penalty (MPa/mm)")
    args = parser.parse_args()
    if find_ccx() is None:
        sys.exit("ccx not found: bash scripts/install-system-deps.sh (Debian calculix-ccx)")
    pressures = [float(p) for p in args.pressures.split(",")]
    size = MeshSize(*(float(v) for v in args.size.split(","))) if args.size else BUILD_MESH
    design = load_design("fpn")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(args.keep) if args.keep else Path(tmp)
        step = export_actuator_step(design, tmp)
        t0 = time.perf_counter()
        run = run_fe(design, step_path=step, size=size, pressures_kpa=pressures,
                     orientation="chambers_up" if args.gravity else "none",
                     options=SolveOptions(self_contact=SelfContact(penalty_mpa_per_mm=args.contact)
                                          if args.contact else None))
        fe_s = time.perf_counter() - t0
        deck = DeckOptions(layer=args.layer, contact_mpa_per_mm=args.contact)
        cmp = compare_with_calculix(run, folder, pressures, options=deck, threads=args.threads)
        walls = closest_walls(run, cmp, folder / "actuator.frd") if args.contact else None
    s = run.solution.stats
    print(f"fPN, mesh {size.wall_mm:g}/{size.max_mm:g} mm (half model): {run.quality.n_tets} tets, "
          f"{s.get('unknowns')} unknowns (pnmold), paper as {args.layer}, "
          f"{'gravity first' if args.gravity else 'no gravity'}"
          + (f", self-contact {args.contact:g} MPa/mm (pnmold's, the deck's gap walls)" if args.contact else ""))
    print(f"time: pnmold {fe_s:.1f} s (mesh {run.timings_s['mesh']:.1f} s), pnmold pointwise "
          f"{cmp.pointwise_s:.1f} s, CalculiX {cmp.calculix.seconds:.1f} s ({cmp.calculix.increments} increments, "
          f"{args.threads} threads)")
    print(f"{'kPa':>6} {'pnmold x, z (mm)':>18} {'pointwise x, z':>18} {'CalculiX x, z':>18} "
          f"{'vs pnmold':>10} {'vs pointwise':>13}")
    err, errp = cmp.error_fraction("pnmold"), cmp.error_fraction("pointwise")
    for i, p in enumerate(cmp.pressures_kpa):
        a, b, c = cmp.pnmold_mm[i], cmp.pointwise_mm[i], cmp.calculix_mm[i]
        print(f"{p:6.2f} {a[0]:8.2f} {a[1]:8.2f}  {b[0]:8.2f} {b[1]:8.2f}  {c[0]:8.2f} {c[1]:8.2f}  "
              f"{100 * err[i]:8.1f}%  {100 * errp[i]:11.1f}%")
    print("differences: |tip_CalculiX - tip| / the tip's travel from rest")
    if walls is not None:
        print("the gaps' walls: the smallest distance (mm) from a corner of a gap's +x wall to its -x wall, "
              "over the gaps (pnmold's contact acts from 0.1 mm; the deck's linear penalty from touch, 0)")
        print(f"{'kPa':>6} {'pnmold':>8} {'pointwise':>10} {'CalculiX':>9}")
        for p, row in zip(cmp.pressures_kpa, walls, strict=True):
            print(f"{p:6.2f} {row[0]:8.3f} {row[1]:10.3f} {row[2]:9.3f}")


def closest_walls(run, cmp, frd: Path) -> np.ndarray:
    """(pressures, 3): the smallest wall-to-wall distance over the gaps (:func:`closest_walls_mm`) in
    pnmold's, its pointwise solve's and CalculiX's deformed shapes at the compared pressures."""
    pairs, X = gap_pairs(run.mesh), run.mesh.nodes_mm
    ours = {round(s.pressure_kpa, 9): u for s, u in zip(run.solution.steps, run.solution.shapes_mm, strict=True)}
    times, disp = read_displacements(frd)  # the deck numbers the mesh's corner nodes first, as pnmold does
    ccx = {round(t, 9): d[:len(X)] for t, d in zip(times, disp, strict=True)}
    return np.array([[closest_walls_mm(pairs, X + ours[round(p, 9)]).min(),
                      closest_walls_mm(pairs, X + cmp.pointwise_shapes_mm[i]).min(),
                      closest_walls_mm(pairs, X + ccx[round(t, 9)]).min() if round(t, 9) in ccx else np.nan]
                     for i, (p, t) in enumerate(zip(cmp.pressures_kpa, cmp.calculix.times, strict=True))])


if __name__ == "__main__":
    main()
