"""The diagnosis's batch nuisance against the FE: a rubber every Yeoh term of which is scaled, and whose
density differs, solved in the FE, beside the nominal reduced model with the same ``modulus_scale`` and
``density_scale`` (what the diagnosis calibrates).

For each template named (default: fpn, spn, fig-s2a-h5) and each batch (modulus x 0.9 and x 1.1, density
x 1.03 and x 0.97, assumed: batch-to-batch spreads of a platinum silicone, as ``diagnose_blind.py`` draws
them), the FE bends the batch's actuator chambers up and chambers down (Earth's gravity, the quick FE's
mesh of the characterisation) up to 0.75 of the nominal's full-bend pressure (or its FE's last step);
the reduced model of the nominal design then runs the same pressures with the batch's scales. Prints the
worst and mean tip miss (% of the length) of: the scaled reduced model; the same with the modulus scale
applied to the pressure alone (the weight's sag left at the nominal stiffness and density: what a scale
that is not "one scale for every term" would be); and the unscaled nominal, the size of the nuisance.

    .venv/bin/python benchmarks/rom_scale.py [TEMPLATE...] [--write-test-data]

``--write-test-data`` also writes the first template's first batch's FE steps, both orientations, to
``tests/data/`` (what ``tests/test_rom.py`` checks the scaled reduced model against, without an FE run).
Hanging chambers down the reduced model uses the compliance its FE probe identified there
(:func:`pnmold.physics.probes.downward_probe`).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from pnmold.design import load_design  # noqa: E402
from pnmold.fsutil import write_json  # noqa: E402
from pnmold.physics import Protocol, ReducedModel  # noqa: E402
from pnmold.physics.characterise import DEFAULT_SIZE  # noqa: E402
from pnmold.physics.probes import characterised_for  # noqa: E402

BATCHES = ((0.9, 1.03), (1.1, 0.97))
ORIENTATIONS = ("chambers_up", "chambers_down")
SHARE = 0.75
TEST_DATA = ROOT / "tests" / "data" / "fig-s2a-h5-batch-steps.json"


def batch_of(design, modulus: float, density: float):
    """The design cast in a batch of its rubber: every Yeoh constant x ``modulus``, density x ``density``."""
    m = design.material
    return design.replace("material", name=f"{m.name} (batch x{modulus:g})", c10_mpa=m.c10_mpa * modulus,
                          c20_mpa=m.c20_mpa * modulus, c30_mpa=m.c30_mpa * modulus,
                          density_g_per_ml=m.density_g_per_ml * density)


def fe_steps(design, orientation: str, pressures: np.ndarray, effects: dict | None = None,
             options=None) -> list[dict]:
    """The FE's tip and bend at ``pressures`` (the characterisation's mesh, Earth's gravity, ``effects``, the
    solver's ``options``); none where the body lost stability under its own weight before any pressure (its
    rest carries part of it)."""
    from pnmold.design_fe import run_fe

    sol = run_fe(design, size=DEFAULT_SIZE, orientation=orientation, effects=effects, pressures_kpa=list(pressures),
                 options=options, keep_partial=True).solution
    if sol.rest_weight_g is not None:
        print(f"{design.name} {orientation}: {sol.reason}", flush=True)
        return []
    return [{k: round(float(v), 6) for k, v in s.as_dict().items() if k in
             ("pressure_kpa", "tip_x_mm", "tip_z_mm", "bend_angle_deg")} for s in sol.steps]


def add_test_steps(path: Path, written: dict, head: dict, orientation: str, steps: list[dict], script: str) -> dict:
    """``written`` with ``orientation``'s FE ``steps`` added, written to ``path`` (test data); the new document."""
    written = {**head, "mesh": [DEFAULT_SIZE.wall_mm, DEFAULT_SIZE.max_mm],
               "produced_by": f"benchmarks/{script} --write-test-data",
               "steps": {**written.get("steps", {}), orientation: steps}}
    write_json(path, written)
    print(f"wrote {path.relative_to(ROOT)} ({orientation})")
    return written


def misses(design, rom: ReducedModel, steps: list[dict], orientation: str, calibration: dict) -> np.ndarray:
    """Tip distance of the reduced model from the FE at the FE's steps, as a share of the length."""
    p = np.array([s["pressure_kpa"] for s in steps])
    out = rom.run(Protocol("bending", p, orientation), None, None, calibration)
    fe = np.array([[s["tip_x_mm"], s["tip_z_mm"]] for s in steps])
    return np.hypot(out["tip_x_mm"] - fe[:, 0], out["tip_z_mm"] - fe[:, 1]) / design.length_mm


def pressure_only(rom: ReducedModel, steps: list[dict], orientation: str, modulus: float) -> np.ndarray:
    """The tip when the modulus scales the pressure alone: the nominal at p / modulus, its sag unscaled."""
    p = np.array([s["pressure_kpa"] for s in steps]) / modulus
    out = rom.run(Protocol("bending", p, orientation))
    fe = np.array([[s["tip_x_mm"], s["tip_z_mm"]] for s in steps])
    return np.hypot(out["tip_x_mm"] - fe[:, 0], out["tip_z_mm"] - fe[:, 1]) / rom.design.length_mm


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("templates", nargs="*", default=["fig-s2a-h5", "fpn", "spn"])
    parser.add_argument("--write-test-data", action="store_true")
    args = parser.parse_args()
    t0 = time.perf_counter()
    written: dict = {}
    for name in args.templates:
        design = load_design(name)
        c = characterised_for(design, ["bending"], ORIENTATIONS)
        top = SHARE * (c.full_bend_pressure_kpa or c.max_pressure_kpa)
        pressures = np.linspace(0.0, top, 9)
        rom = ReducedModel.for_design(design, c)
        for modulus, density in BATCHES:
            batch = batch_of(design, modulus, density)
            for orientation in ORIENTATIONS:
                steps = fe_steps(batch, orientation, pressures)
                if not steps:  # lost stability at rest: said by fe_steps
                    continue
                scales = {"modulus_scale": modulus, "density_scale": density}
                scaled = misses(design, rom, steps, orientation, scales)
                partial = pressure_only(rom, steps, orientation, modulus)
                nominal = misses(design, rom, steps, orientation, {})
                print(f"{name:<11} modulus x{modulus:g} density x{density:g} {orientation:<13} to "
                      f"{steps[-1]['pressure_kpa']:.1f} kPa: tip miss, % of the length (worst / mean): scaled "
                      f"{100 * scaled.max():.2f} / {100 * scaled.mean():.2f}; pressure alone "
                      f"{100 * partial.max():.2f} / {100 * partial.mean():.2f}; "
                      f"unscaled {100 * nominal.max():.2f} / {100 * nominal.mean():.2f}", flush=True)
                if args.write_test_data and name == args.templates[0] and (modulus, density) == BATCHES[0]:
                    written = add_test_steps(TEST_DATA, written, {"design": name, **scales}, orientation, steps,
                                             "rom_scale.py")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
