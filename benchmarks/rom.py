"""The reduced model against the FE, template by template, and its speed.

For every template (or those named): the characterisation (the quick-FE solves of
:mod:`pnmold.physics.characterise` on the default mesh, cached in out/.cache/fe/), then the
FE with 1 g chambers up (and, with ``--orientations``, other orientations) over the same
pressure range; prints the worst tip distance between the reduced model and the FE over the
FE's steps (mm and % of the length), where it happens, the worst up to 3/4 of the FE's last
pressure (short of a pressure maximum's run-away), and the reduced model's CPU time per
curve (a 50-row chambers-up ramp with gravity, a 50-row ramp without, and a 50-row
blocked-force ramp). ``--force`` adds the FE's blocked force (supplement Fig. S6) at a few
pressures against the reduced model's; ``--fe-effects strain_stiffening=0.05`` the FE with
catalogued effects switched on (the data a diagnosis meets) against the reduced model with
the same effect.

    .venv/bin/python benchmarks/rom.py [TEMPLATE...] [--max-kpa P] [--orientations O,...] [--force]
        [--fe-effects NAME=VALUE,...]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pnmold.design import list_templates, load_design  # noqa: E402
from pnmold.physics import Protocol, ReducedModel  # noqa: E402
from pnmold.physics.characterise import DEFAULT_MAX_PRESSURE_KPA, DEFAULT_SIZE  # noqa: E402
from pnmold.physics.probes import characterised_for  # noqa: E402


def cpu_ms(rom, protocol, repeat: int = 30) -> float:
    """CPU milliseconds per ``rom.run(protocol)`` (process time: robust to other load on the machine)."""
    rom.run(protocol)
    t0 = time.process_time()
    for _ in range(repeat):
        rom.run(protocol)
    return (time.process_time() - t0) / repeat * 1000


def compare(design, rom, step, orientation: str, max_kpa: float) -> None:
    from pnmold.design_fe import run_fe

    t0 = time.perf_counter()
    fe = run_fe(design, step_path=step, size=DEFAULT_SIZE, orientation=orientation, max_pressure_kpa=max_kpa,
                keep_partial=True).solution
    fe_s = time.perf_counter() - t0
    p = np.array([s.pressure_kpa for s in fe.steps])
    out = rom.run(Protocol("bending", p, orientation))
    miss = np.hypot(out["tip_x_mm"] - [s.tip_x_mm for s in fe.steps], out["tip_z_mm"] - [s.tip_z_mm for s in fe.steps])
    i = int(np.argmax(miss))
    bend = np.abs(out["bend_angle_deg"] - [s.bend_angle_deg for s in fe.steps])
    print(f"  {orientation:<13} FE {len(p)} steps to {p[-1]:.1f} kPa ({fe.steps[-1].bend_angle_deg:.0f} deg, "
          f"{fe_s:.0f} s): worst tip miss {miss[i]:.2f} mm = {100 * miss[i] / design.length_mm:.2f} % of L at "
          f"{p[i]:.1f} kPa; mean {100 * miss.mean() / design.length_mm:.2f} %; worst bend {bend.max():.1f} deg; "
          f"up to 3/4 of {p[-1]:.1f} kPa worst {100 * miss[p <= 0.75 * p[-1]].max() / design.length_mm:.2f} %")


def blocked_force(design, rom, step, pressures) -> None:
    from pnmold.design_fe import run_fe

    t0 = time.perf_counter()
    sol = run_fe(design, step_path=step, size=DEFAULT_SIZE, kind="force", pressures_kpa=pressures).solution
    fe_s = time.perf_counter() - t0
    p = np.array([s.pressure_kpa for s in sol.steps])
    out = rom.run(Protocol("force", p, "chambers_up"))
    rows = ", ".join(f"{pi:g} kPa FE {s.force_n:.3f} / ROM {fr:.3f} N"
                     for pi, s, fr in zip(p, sol.steps, out["force_n"], strict=True))
    print(f"  blocked force ({fe_s:.0f} s): {rows}")


def effect_in_fe(design, rom, effects: dict[str, float], pressures) -> None:
    """The FE with an effect switched on (no gravity) against the reduced model with and without it."""
    from pnmold.simulate import SimulationRequest, simulate_fe

    t0 = time.perf_counter()
    request = SimulationRequest((0.0, *pressures), "fe", effects=tuple({**effects, "gravity": 0.0}.items()),
                                mesh_size=(DEFAULT_SIZE.wall_mm, DEFAULT_SIZE.max_mm))
    steps = simulate_fe(design, request)["steps"]
    fe_s = time.perf_counter() - t0
    p = np.array([s["pressure_kpa"] for s in steps])
    with_it = rom.run(Protocol("bending", p, "none"), {**effects, "gravity": 0.0})
    without = rom.run(Protocol("bending", p, "none"), {"gravity": 0.0})
    label = ",".join(f"{k}={v:g}" for k, v in effects.items())
    for i in range(1, len(p)):
        miss = np.hypot(with_it["tip_x_mm"][i] - steps[i]["tip_x_mm"], with_it["tip_z_mm"][i] - steps[i]["tip_z_mm"])
        print(f"  FE {label} at {p[i]:g} kPa ({fe_s:.0f} s): bend FE {steps[i]['bend_angle_deg']:.1f}, ROM with "
              f"{with_it['bend_angle_deg'][i]:.1f}, ROM without {without['bend_angle_deg'][i]:.1f} deg; tip miss "
              f"{miss:.2f} mm = {100 * miss / design.length_mm:.2f} % of L")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("templates", nargs="*", default=sorted(list_templates()))
    ap.add_argument("--max-kpa", type=float, default=DEFAULT_MAX_PRESSURE_KPA)
    ap.add_argument("--orientations", default="chambers_up")
    ap.add_argument("--force", action="store_true")
    ap.add_argument("--timing-only", action="store_true", help="only the reduced model's CPU time (cached FE)")
    ap.add_argument("--fe-effects", action="append", default=[], metavar="NAME=VALUE,...",
                    help="also solve the FE with these effects (no gravity) at 1/4, 1/2, 3/4 of the range")
    args = ap.parse_args()
    from pnmold.cad import export_parts, make_parts

    for name in args.templates:
        design = load_design(name)
        t0 = time.perf_counter()
        c = characterised_for(design, ["bending"], args.orientations.split(","), max_pressure_kpa=args.max_kpa,
                              progress=lambda s: print("  ...", s, flush=True))
        rom = ReducedModel.for_design(design, c)
        fb = f"{c.full_bend_pressure_kpa:.1f} kPa" if c.full_bend_pressure_kpa else c.reason
        print(f"{name}: L = {design.length_mm:g} mm; characterisation {time.perf_counter() - t0:.0f} s "
              f"(FE {c.timings_s}); {len(c.pressure_kpa)} steps, {c.rod_angle_rad.shape[1]} rod edges; "
              f"full bend (no gravity) {fb}")
        top, step_kpa = 0.98 * c.max_pressure_kpa, c.max_pressure_kpa / 50
        times = {label: cpu_ms(rom, Protocol.ramp(kind, top, step_kpa, orientation=o))
                 for label, kind, o in (("gravity", "bending", "chambers_up"), ("no gravity", "bending", "none"),
                                        ("blocked force", "force", "chambers_up"))}
        print("  ROM CPU per 50-row curve: " + ", ".join(f"{k} {v:.2f} ms" for k, v in times.items()))
        if args.timing_only:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            export_parts({"actuator": make_parts(design)["actuator"]}, Path(tmp))
            step = Path(tmp) / "actuator.step"
            for orientation in args.orientations.split(","):
                compare(design, rom, step, orientation, c.max_pressure_kpa)
            if args.force:
                blocked_force(design, rom, step, [c.max_pressure_kpa * f for f in (0.1, 0.25, 0.5)])
        for text in args.fe_effects:
            from pnmold.simulate import parse_effects

            effect_in_fe(design, rom, dict(parse_effects(text)),
                         [round(c.max_pressure_kpa * f, 3) for f in (0.25, 0.5, 0.75)])
        sys.stdout.flush()


if __name__ == "__main__":
    main()
