"""PARDISO against the fallback linear solver (SciPy's SuperLU) on the build's quick FE.

Runs ``pnmold build DESIGN --no-slicer`` once per solver, forced with
``PNMOLD_LINEAR_SOLVER``, and prints from each ``report.json`` the full-bend pressure, the FE
timings (``timings_s.fem``; ``fem.timings_s``: mesh, solve, blocked force) and the solver's
counters; then the relative difference of the full-bend pressures, which must stay within
0.5 % (exit 1 otherwise: the fallback must give the same curve within Newton's tolerance;
the adaptive load stepping may take other steps, and the full bend is interpolated between
steps). Timings on a shared machine are noisy: the load average is printed with them.

    .venv/bin/python benchmarks/linear_solver.py [DESIGN] [--solvers pardiso scipy] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TOLERANCE = 0.005


def _build(design: str, solver: str, out: Path) -> dict:
    env = {**os.environ, "PNMOLD_LINEAR_SOLVER": solver}
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pnmold.cli", "build", design, "--no-slicer", "--quiet", "--out", str(out)],
                   check=True, env=env)
    wall = time.perf_counter() - t0
    report = json.loads((out / "report.json").read_text())
    fem = report["fem"]
    s = fem["solver"]
    t = fem.get("timings_s", {})
    print(f"[{solver}] linear solver in report.json: {s.get('linear_solver')}; full bend "
          f"{fem['full_bend_pressure_kpa']} kPa; {s['unknowns']} unknowns, {s['increments']} load steps, "
          f"{s['factorizations']} factorisations ({s.get('stage_factorizations')}), {s['cuts']} cuts")
    print(f"[{solver}] time: build {wall:.1f} s (wall), fem stage {report['timings_s'].get('fem')} s = mesh "
          f"{t.get('mesh')} s + solve {t.get('solve')} s (assembly {s['assembly_s']} s, linear solves "
          f"{s['linear_solve_s']} s) + blocked force {t.get('blocked_force')} s; load {os.getloadavg()[0]:.2f}")
    return report


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("design", nargs="?", default="fpn")
    parser.add_argument("--solvers", nargs=2, default=["pardiso", "scipy"], metavar="NAME")
    parser.add_argument("--keep", metavar="DIR", help="keep the two build folders in DIR")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.keep or tmp)
        print(f"{args.design}: quick FE with {args.solvers[0]} and {args.solvers[1]}; load {os.getloadavg()[0]:.2f}, "
              f"{os.cpu_count()} cores")
        reports = [_build(args.design, name, root / name) for name in args.solvers]
    a, b = (r["fem"]["full_bend_pressure_kpa"] for r in reports)
    if a is None or b is None:
        print(f"no full bend to compare: {[r['fem']['reason'] for r in reports]}")
        return 1
    rel = abs(b - a) / a
    ta, tb = (r["timings_s"]["fem"] for r in reports)
    print(f"full bend: {args.solvers[0]} {a:.4f} kPa in {ta:.1f} s, {args.solvers[1]} {b:.4f} kPa in {tb:.1f} s; "
          f"difference {100 * rel:.4f} % ({'within' if rel <= TOLERANCE else 'NOT within'} "
          f"{100 * TOLERANCE:g} %), time ratio {tb / ta:.2f}")
    return 0 if rel <= TOLERANCE else 1


if __name__ == "__main__":
    sys.exit(main())
