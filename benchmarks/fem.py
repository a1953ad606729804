"""The quick FE of the default fPN: cost and mesh convergence, and an independent peer.

For the build's mesh and a finer one, prints unknowns, load steps, Newton iterations,
time in assembly, in linear solves and in total, peak memory, and the tip at a reference
pressure (the mesh-convergence figure); then the same problem solved by SfePy on the same
mesh and tolerance (``benchmarks/fem_peer.py``; `pip install -r benchmarks/requirements-peer.txt`).

    .venv/bin/python benchmarks/fem.py [--reference-kpa P] [--refine F] [--no-peer]
"""

from __future__ import annotations

import argparse
import math
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pnmold.design import load_design  # noqa: E402
from pnmold.quickfe import BUILD_MESH, run_fe  # noqa: E402


def _one(design, step, size, pressures, label):
    run = run_fe(design, step_path=step, size=size, pressures_kpa=pressures, orientation="chambers_up")
    s = run.solution.stats
    last = run.solution.steps[-1]
    its = s.get("newton_iterations", [])
    total = s.get("total_s", float("nan"))
    asm = s.get("assembly_s", float("nan"))
    lin = s.get("linear_solve_s", float("nan"))
    n_it = sum(its) if isinstance(its, list) else its
    print(f"[{label}] mesh {run.quality.n_tets} tets, {s.get('unknowns')} unknowns; "
          f"{s.get('increments')} load steps, {n_it} Newton iterations, {s.get('factorizations')} factorisations")
    print(f"[{label}] time: mesh {run.timings_s['mesh']:.1f} s, solve {total:.1f} s "
          f"(assembly {asm:.1f} s, linear solves {lin:.1f} s); assembly per Newton iteration "
          f"{asm / max(n_it, 1):.3f} s of {total / max(n_it, 1):.3f} s ({100 * asm / max(total, 1e-9):.0f}%)")
    print(f"[{label}] at {last.pressure_kpa:g} kPa: tip ({last.tip_x_mm:.2f}, {last.tip_z_mm:.2f}) mm, "
          f"bend {last.bend_angle_deg:.1f} deg, cavity {last.cavity_volume_ml:.3f} mL")
    return run


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--reference-kpa", type=float, default=20.0)
    parser.add_argument("--refine", type=float, default=1.5)
    parser.add_argument("--no-peer", action="store_true")
    args = parser.parse_args()
    design = load_design("fpn")
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "pnmold.cli", "build", "--no-fem", "--no-slicer", "--quiet",
                        "--out", str(Path(tmp) / "fpn")], check=True)
        step = Path(tmp) / "fpn" / "actuator.step"
        pressures = [args.reference_kpa]
        coarse = _one(design, step, BUILD_MESH, pressures, "build mesh")
        fine = _one(design, step, BUILD_MESH.refined(args.refine), pressures, f"finer x{args.refine:g}")
        a, b = coarse.solution.steps[-1], fine.solution.steps[-1]
        moved = math.hypot(a.tip_x_mm - b.tip_x_mm, a.tip_z_mm - b.tip_z_mm)
        travel = math.hypot(b.tip_x_mm - design.length_mm, b.tip_z_mm)
        print(f"mesh convergence: tip differs by {moved:.2f} mm = {100 * moved / travel:.1f}% of the tip's "
              f"travel ({travel:.1f} mm) between the build's mesh and the finer one (target < 5%)")
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"peak memory: {peak:.0f} MB")
        if not args.no_peer:
            try:
                from benchmarks.fem_peer import compare
            except ImportError as err:
                print(f"peer: skipped ({err}); pip install -r benchmarks/requirements-peer.txt")
            else:
                compare(design, step, size=(BUILD_MESH.wall_mm, BUILD_MESH.max_mm))


if __name__ == "__main__":
    main()
