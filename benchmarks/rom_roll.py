"""Held on its side: the FE of the whole body against the reduced model with and without its roll.

For each design (templates named, and ``--random N`` valid designs drawn as ``benchmarks/fe_robust.py``
draws them, the library's rubbers in turn), the FE bends the actuator held horizontal (Earth's gravity
along -y, the whole body on the characterisation's mesh) at five pressures up to ``--share`` of the free
run's last pressure; the reduced model runs the same pressures with the roll
(:mod:`pnmold.physics.roll`, its compliance from the roll probe at rest: every pressure above 0 kPa is a
prediction) and without it (the roll compliance left out: the weight out of the plane does nothing).
Prints per design the rest tip of each, the probe's roll at the tip and the worst and mean tip miss as
a share of the length.

    .venv/bin/python benchmarks/rom_roll.py [TEMPLATE...] [--random 3] [--seed 1] [--share 0.85]
        [--write-test-data]

``--write-test-data`` writes the first template's FE steps to ``tests/data/`` (what ``tests/test_roll.py``
checks the reduced model against, without an FE run).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
from fe_robust import draw_designs, material_sets  # noqa: E402
from rom_scale import add_test_steps, fe_steps  # noqa: E402

from pnmold.design import load_design  # noqa: E402
from pnmold.errors import PnmoldError  # noqa: E402
from pnmold.materials.library import list_materials  # noqa: E402
from pnmold.physics import Protocol, ReducedModel  # noqa: E402
from pnmold.physics.probes import characterised_for  # noqa: E402

TEST_DATA = ROOT / "tests" / "data" / "fpn-horizontal-steps.json"


def tips(rom: ReducedModel, p: np.ndarray) -> np.ndarray:
    """The reduced model's tips (x, z) held horizontal at ``p`` (NaN where it has no equilibrium)."""
    out = rom.run(Protocol("bending", p, "horizontal"), partial=True)
    return np.column_stack([out["tip_x_mm"], out["tip_z_mm"]])


def compare(design, share: float) -> dict:
    """One design: the FE's horizontal steps and the reduced model's misses with and without the roll."""
    t0 = time.perf_counter()
    c = characterised_for(design, ["bending"], ["horizontal"])
    if c.roll_compliance_rad_per_n_mm is None:
        return {"design": design.name, "failed": c.probes_failed.get("roll", "no roll probe")}
    p = np.linspace(0.0, share * float(c.pressure_kpa[-1]), 5)
    steps = fe_steps(design, "horizontal", p[1:])
    if not steps:
        return {"design": design.name, "failed": "the FE held horizontal lost stability under its own weight at rest"}
    p = np.array([s["pressure_kpa"] for s in steps])
    fe = np.array([[s["tip_x_mm"], s["tip_z_mm"]] for s in steps])
    rolled = ReducedModel(design, c)
    flat = ReducedModel(design, dataclasses.replace(c, roll_compliance_rad_per_n_mm=None))
    with_roll, without = tips(rolled, p), tips(flat, p)
    miss = {name: np.hypot(*(t - fe).T) / design.length_mm for name, t in (("roll", with_roll), ("flat", without))}
    return {"design": design.name, "rubber": design.material.name, "p": p, "fe": fe, "roll": with_roll,
            "flat": without, "miss": miss, "tip_roll_deg": c.probe_roll["node_roll_deg"][-1], "steps": steps,
            "seconds": time.perf_counter() - t0}


def designs(args) -> list:
    out = [load_design(name) for name in args.templates]
    rubbers = [m.name for m in list_materials()]
    for index, sets in draw_designs(args.random, args.seed):
        out.append(load_design("fpn", [*sets, *material_sets(rubbers[index % len(rubbers)])]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("templates", nargs="*", default=["fpn", "spn"])
    parser.add_argument("--random", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--share", type=float, default=0.85)
    parser.add_argument("--write-test-data", action="store_true")
    args = parser.parse_args()
    for design in designs(args):
        try:
            r = compare(design, args.share)
        except PnmoldError as err:
            print(f"{design.name}: {err}", flush=True)
            continue
        if "failed" in r:
            print(f"{r['design']}: nothing to compare: {r['failed']}", flush=True)
            continue
        m = r["miss"]
        print(f"{r['design']} ({r['rubber']}), {r['p'][-1]:.3g} kPa top, probe's tip roll {r['tip_roll_deg']:.1f} deg, "
              f"{r['seconds']:.0f} s", flush=True)
        print(f"  rest tip: FE ({r['fe'][0, 0]:.1f}, {r['fe'][0, 1]:.1f}), with roll ({r['roll'][0, 0]:.1f}, "
              f"{r['roll'][0, 1]:.1f}), without ({r['flat'][0, 0]:.1f}, {r['flat'][0, 1]:.1f}) mm")
        for name in ("roll", "flat"):
            print(f"  {'with' if name == 'roll' else 'without'} roll: tip miss worst {100 * np.nanmax(m[name]):.1f} %, "
                  f"mean {100 * np.nanmean(m[name]):.1f} % of the length (NaN rows {int(np.isnan(m[name]).sum())})")
        if args.write_test_data and design.name == args.templates[0]:
            add_test_steps(TEST_DATA, {}, {"design": design.name}, "horizontal", r["steps"], "rom_roll.py")


if __name__ == "__main__":
    main()
