"""The build's FE of a design with self-contact against without: overlap, full bend, cost.

Bends the design as ``pnmold build`` does (its preview mesh and options, gravity chambers up, to
full bend or a stop) once without contact and once with :class:`pnmold.fem.SelfContact` (its
assumed defaults, or ``--penalty``/``--activation``), and prints for each the end of the curve,
the full-bend pressure, the wall time of the solve, factorisations and increments, and the
overlap table of every converged step (:mod:`pnmold.fem.overlap`; the contact force and pairs
with contact on).

    .venv/bin/python benchmarks/contact.py [--design fpn] [--only on|off] [--max-kpa 150]
                                           [--penalty 10] [--activation 0.1] [--past-ends]

``--max-kpa`` ends the curves at that pressure (the build's limit by default). With contact the
fPN's tip meets its base before a full bend, where the curve ends (``tip_meets_base``);
``--past-ends`` solves on with the tip pressed on the base.
"""

from __future__ import annotations

import argparse
import dataclasses
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pnmold.design import load_design  # noqa: E402
from pnmold.design_fe import BUILD_MESH, BUILD_OPTIONS, QUICK_MAX_PRESSURE_KPA, run_fe  # noqa: E402
from pnmold.export.p2 import quadratic_mesh  # noqa: E402
from pnmold.fem import SelfContact  # noqa: E402
from pnmold.fem.overlap import OVERLAP_DEPTH_MM, measure_overlap  # noqa: E402


def solve(design, step: Path, contact: SelfContact | None, label: str, max_kpa: float):
    """One build FE; prints its summary and overlap table; returns the run."""
    options = dataclasses.replace(BUILD_OPTIONS, self_contact=contact)
    t0 = time.perf_counter()
    run = run_fe(design, step_path=step, size=BUILD_MESH, max_pressure_kpa=max_kpa,
                 orientation="chambers_up", options=options, keep_partial=True)
    wall = time.perf_counter() - t0
    sol, stats = run.solution, run.solution.stats
    end = f"full bend at {sol.full_bend_pressure_kpa:.2f} kPa" if sol.full_bend_pressure_kpa else sol.reason
    print(f"[{label}] {end}; last step {sol.steps[-1].pressure_kpa:.2f} kPa, {sol.steps[-1].bend_angle_deg:.1f} deg; "
          f"solve {stats['total_s']:.1f} s (mesh {run.timings_s['mesh']:.1f} s, wall {wall:.1f} s), "
          f"{stats['increments']} increments, {stats['factorizations']} factorisations, {stats['cuts']} cuts")
    qmesh = quadratic_mesh(run.mesh)
    print(f"[{label}] {'kPa':>7} {'bend':>6} {'mL':>7} {'inside':>6} {'deeper':>6} {'max depth':>9}")
    for step_, state in zip(sol.steps, sol.states, strict=True):
        ov = measure_overlap(qmesh.nodes_mm, qmesh.cells, state)
        print(f"[{label}] {step_.pressure_kpa:>7.2f} {step_.bend_angle_deg:>6.1f} {step_.cavity_volume_ml:>7.3f} "
              f"{ov.nodes.size:>6} {ov.count(OVERLAP_DEPTH_MM):>6} {ov.max_depth_mm:>7.3f} mm")
    return run


def compare(off, on) -> None:
    """Bend and cavity volume (P-V) with contact against without at a quarter, half and three
    quarters of the lower of the two curves' last pressures (linear between converged steps)."""
    def at(run, p: float, key: str) -> float:
        steps = run.solution.steps
        return float(np.interp(p, [s.pressure_kpa for s in steps], [getattr(s, key) for s in steps]))

    top = min(off.solution.steps[-1].pressure_kpa, on.solution.steps[-1].pressure_kpa)
    for f in (0.25, 0.5, 0.75):
        p = f * top
        (b0, v0), (b1, v1) = ((at(r, p, "bend_angle_deg"), at(r, p, "cavity_volume_ml")) for r in (off, on))
        print(f"[with against without] {p:.1f} kPa: bend {b1:.1f} against {b0:.1f} deg ({b1 - b0:+.1f}), "
              f"volume {v1:.3f} against {v0:.3f} mL ({100 * (v1 - v0) / v0:+.1f} %)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", default="fpn")
    parser.add_argument("--only", choices=("on", "off"))
    parser.add_argument("--max-kpa", type=float, default=QUICK_MAX_PRESSURE_KPA)
    parser.add_argument("--penalty", type=float, default=SelfContact.penalty_mpa_per_mm)
    parser.add_argument("--activation", type=float, default=SelfContact.activation_mm)
    parser.add_argument("--past-ends", action="store_true", help="no tip_meets_base stop")
    args = parser.parse_args(argv)
    design = load_design(args.design)
    contact = SelfContact(penalty_mpa_per_mm=args.penalty, activation_mm=args.activation,
                          stop_where_ends_meet=not args.past_ends)
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "pnmold.cli", "build", args.design, "--no-fem", "--no-slicer",
                        "--quiet", "--out", str(Path(tmp) / "b")], check=True)
        step = Path(tmp) / "b" / "actuator.step"
        off = solve(design, step, None, "without contact", args.max_kpa) if args.only != "on" else None
        on = (solve(design, step, contact, f"contact {args.penalty:g} MPa/mm, {args.activation:g} mm", args.max_kpa)
              if args.only != "off" else None)
        if off is not None and on is not None:
            compare(off, on)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
