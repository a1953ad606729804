"""The quick FE of the default fPN: cost and mesh convergence, and an independent peer.

For the build's mesh and a 1.6x finer one, bends the fPN as ``pnmold build`` does (gravity
chambers up, to full bend) and prints unknowns, load steps, Newton iterations,
factorisations (per stage), time in assembly, in linear solves and in total, peak memory,
the full-bend pressure on both meshes and its change (the build's accuracy figure), and
the tip at a reference pressure (interpolated between the converged steps); then the same
problem solved by SfePy on the same mesh and tolerance (``benchmarks/fem_peer.py``;
`pip install -r benchmarks/requirements-peer.txt`).

    .venv/bin/python benchmarks/fem.py [--reference-kpa P] [--refine F] [--no-peer] [--self-contact]

``--self-contact`` solves both meshes with the FE's self-contact (``pnmold build --self-contact``);
the fPN's curve then ends where its tip meets its base before a full bend, and that end's pressure
is compared instead (no peer: SfePy's run has no contact).
"""

from __future__ import annotations

import argparse
import math
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pnmold.design import load_design  # noqa: E402
from pnmold.design_fe import BUILD_MESH, QUICK_MAX_PRESSURE_KPA, build_options, run_fe  # noqa: E402


def _tip_at(run, pressure_kpa):
    """Tip (x, z) at ``pressure_kpa``, linear between the converged steps around it."""
    steps = run.solution.steps
    p = [s.pressure_kpa for s in steps]
    return (float(np.interp(pressure_kpa, p, [s.tip_x_mm for s in steps])),
            float(np.interp(pressure_kpa, p, [s.tip_z_mm for s in steps])))


def _end_kpa(run) -> float | None:
    """The curve's end pressure: its full bend, or with self-contact the tip meeting the base."""
    sol = run.solution
    if sol.full_bend_pressure_kpa:
        return sol.full_bend_pressure_kpa
    return sol.steps[-1].pressure_kpa if sol.stop == "tip_meets_base" else None


def _one(design, step, size, reference_kpa, label, contact: bool = False):
    run = run_fe(design, step_path=step, size=size, max_pressure_kpa=QUICK_MAX_PRESSURE_KPA,
                 orientation="chambers_up", options=build_options(contact))
    sol = run.solution
    s = sol.stats
    its = s.get("newton_iterations", [])
    total = s.get("total_s", float("nan"))
    asm = s.get("assembly_s", float("nan"))
    lin = s.get("linear_solve_s", float("nan"))
    n_it = sum(its) if isinstance(its, list) else its
    stages = ", ".join(f"{k} {v}" for k, v in s.get("stage_factorizations", {}).items())
    print(f"[{label}] mesh {run.quality.n_tets} tets, {s.get('unknowns')} unknowns; "
          f"{s.get('increments')} load steps, {n_it} Newton iterations, "
          f"{s.get('factorizations')} factorisations ({stages})")
    print(f"[{label}] time: mesh {run.timings_s['mesh']:.1f} s, solve {total:.1f} s "
          f"(assembly {asm:.1f} s, linear solves {lin:.1f} s); assembly per Newton iteration "
          f"{asm / max(n_it, 1):.3f} s of {total / max(n_it, 1):.3f} s ({100 * asm / max(total, 1e-9):.0f}%)")
    fb = sol.full_bend_pressure_kpa
    print(f"[{label}] full bend at {fb:.2f} kPa" if fb else f"[{label}] no full bend: {sol.reason}")
    x, z = _tip_at(run, reference_kpa)
    print(f"[{label}] at {reference_kpa:g} kPa: tip ({x:.2f}, {z:.2f}) mm")
    return run


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--reference-kpa", type=float, default=20.0)
    parser.add_argument("--refine", type=float, default=1.6)
    parser.add_argument("--no-peer", action="store_true")
    parser.add_argument("--self-contact", action="store_true")
    args = parser.parse_args()
    design = load_design("fpn")
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "pnmold.cli", "build", "--no-fem", "--no-slicer", "--quiet",
                        "--out", str(Path(tmp) / "fpn")], check=True)
        step = Path(tmp) / "fpn" / "actuator.step"
        contact = args.self_contact
        coarse = _one(design, step, BUILD_MESH, args.reference_kpa, "build mesh", contact)
        fine = _one(design, step, BUILD_MESH.refined(args.refine), args.reference_kpa,
                    f"finer x{args.refine:g}", contact)
        fa, fb = _end_kpa(coarse), _end_kpa(fine)
        what = "full-bend pressure" if not contact else "end pressure (full bend or the tip on the base)"
        if fa and fb:
            print(f"mesh convergence{' with self-contact' if contact else ''}: {what} {fa:.2f} kPa on the "
                  f"build's mesh, {fb:.2f} kPa on the finer one: {100 * (fa - fb) / fb:+.1f}% (target within 3%)")
        (ax, az), (bx, bz) = _tip_at(coarse, args.reference_kpa), _tip_at(fine, args.reference_kpa)
        moved = math.hypot(ax - bx, az - bz)
        travel = math.hypot(bx - design.length_mm, bz)
        print(f"mesh convergence: tip at {args.reference_kpa:g} kPa differs by {moved:.2f} mm = "
              f"{100 * moved / travel:.1f}% of the tip's travel ({travel:.1f} mm) between the "
              f"build's mesh and the finer one (target < 5%)")
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"peak memory: {peak:.0f} MB")
        if not args.no_peer and not contact:
            try:
                from benchmarks.fem_peer import compare
            except ImportError as err:
                print(f"peer: skipped ({err}); pip install -r benchmarks/requirements-peer.txt")
            else:
                compare(design, step, size=(BUILD_MESH.wall_mm, BUILD_MESH.max_mm))


if __name__ == "__main__":
    main()
