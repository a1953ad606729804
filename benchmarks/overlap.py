"""Where a solved body passes through itself: the overlap table of build folders.

For each folder (a ``pnmold build --out DIR``, or a ``--vtu DIR`` of ``pnmold simulate``), reads
every step of its VTU series (``DIR/fem/bending.pvd`` or ``DIR/bending.pvd``) and prints, per
step, the boundary nodes inside another part of the body (:mod:`pnmold.fem.overlap`): how many
lie deeper than the threshold, the deepest (distance to that part's nearest surface vertex, and
to its surface), and where the deepest is (reference position).

    .venv/bin/python benchmarks/overlap.py DIR... [--threshold-mm 0.05] [--same-part-mm 1.0]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pnmold.export.vtu import read_vtu_series  # noqa: E402
from pnmold.fem.overlap import OVERLAP_DEPTH_MM, SAME_PART_MM, measure_overlap  # noqa: E402


def table(folder: Path, threshold_mm: float, same_part_mm: float) -> int:
    """Print the folder's table; return the steps with a node deeper than the threshold."""
    index = folder / "fem" if (folder / "fem").is_dir() else folder
    steps = read_vtu_series(index)
    print(f"{folder}: {len(steps)} steps; another part beyond {same_part_mm:g} mm (reference), "
          f"counted deeper than {threshold_mm:g} mm")
    print(f"{'step':>4} {'kPa':>7} {'inside':>6} {'deeper':>6} {'max depth (vertex)':>18} "
          f"{'max depth (surface)':>19}  deepest at (x, y, z) mm")
    bad, t0 = 0, time.perf_counter()
    for i, s in enumerate(steps):
        ov = measure_overlap(s.nodes_mm, s.cells, s.displacement_mm, same_part_mm=same_part_mm)
        deeper = ov.count(threshold_mm)
        bad += deeper > 0
        where = ""
        if ov.nodes.size:
            x, y, z = s.nodes_mm[ov.nodes[ov.depth_mm.argmax()]]
            where = f"({x:.1f}, {y:.1f}, {z:.1f})"
        surface = float(ov.surface_depth_mm.max()) if ov.nodes.size else 0.0
        print(f"{i:>4} {s.pressure_kpa:>7.2f} {ov.nodes.size:>6} {deeper:>6} {ov.max_depth_mm:>15.3f} mm "
              f"{surface:>16.3f} mm  {where}")
    print(f"{bad} of {len(steps)} steps overlap by more than {threshold_mm:g} mm "
          f"({time.perf_counter() - t0:.1f} s)\n")
    return bad


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--threshold-mm", type=float, default=OVERLAP_DEPTH_MM)
    parser.add_argument("--same-part-mm", type=float, default=SAME_PART_MM)
    args = parser.parse_args(argv)
    for folder in args.folders:
        table(folder, args.threshold_mm, args.same_part_mm)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
