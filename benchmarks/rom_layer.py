"""A compliant strain-limiting layer under the actuator's weight: the FE against the reduced model.

For each template named (default: fpn, fig-s2a-h5, spn) and each layer compliance (default 0.5 and
0.95 mm/N, the blind benchmark's largest; the layer's probes are at 0.15 mm/N, so these are
predictions), the FE bends the actuator with that ``layer_compliance`` chambers up and hanging chambers
down (Earth's gravity, the characterisation's mesh) at five pressures up to half the nominal's full-bend
pressure (or its FE's last step); the reduced model runs the same pressures with the same layer. Prints the
worst and mean tip miss (% of the length) with the layer's compliance probes
(:func:`pnmold.physics.probes.layer_probe`) and without them (the hinge compliance grown by the
bend's factor alone), and the rest tip of each.

    .venv/bin/python benchmarks/rom_layer.py [TEMPLATE...] [--values 0.5,0.95] [--write-test-data]

``--write-test-data`` writes the first template's FE steps at the first value, both orientations, to
``tests/data/`` (what ``tests/test_rom.py`` checks the reduced model against, without an FE run).
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
from rom_scale import add_test_steps, fe_steps  # noqa: E402

from pnmold.design import load_design  # noqa: E402
from pnmold.physics import Protocol, ReducedModel  # noqa: E402
from pnmold.physics.probes import characterised_for  # noqa: E402

ORIENTATIONS = ("chambers_up", "chambers_down")
SHARE = 0.5
TEST_DATA = ROOT / "tests" / "data" / "fpn-layer-steps.json"


def misses(rom: ReducedModel, steps: list[dict], orientation: str, layer: float) -> tuple[np.ndarray, np.ndarray]:
    """Tip distance of the reduced model from the FE at the FE's steps (share of the length); its tips."""
    p = np.array([s["pressure_kpa"] for s in steps])
    out = rom.run(Protocol("bending", p, orientation), {"layer_compliance": layer})
    fe = np.array([[s["tip_x_mm"], s["tip_z_mm"]] for s in steps])
    tips = np.column_stack([out["tip_x_mm"], out["tip_z_mm"]])
    return np.hypot(*(tips - fe).T) / rom.design.length_mm, tips


def without_probes(rom: ReducedModel) -> ReducedModel:
    """``rom`` with the layer's compliance probes left out (the bend's factor alone)."""
    c = dataclasses.replace(rom.characterisation, compliance_layer_rad_per_n_mm=None,
                            compliance_down_layer_rad_per_n_mm=None)
    return ReducedModel.for_design(rom.design, c)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("templates", nargs="*", default=["fpn", "fig-s2a-h5", "spn"])
    parser.add_argument("--values", default="0.5,0.95", help="layer compliances, mm/N")
    parser.add_argument("--write-test-data", action="store_true")
    args = parser.parse_args()
    t0 = time.perf_counter()
    values = [float(v) for v in args.values.split(",")]
    written: dict = {}
    for name in args.templates:
        design = load_design(name)
        c = characterised_for(design, ["bending"], ORIENTATIONS, layer=True)
        rom = ReducedModel.for_design(design, c)
        bare = without_probes(rom)
        pressures = np.linspace(0.0, SHARE * (c.full_bend_pressure_kpa or c.max_pressure_kpa), 5)
        for layer in values:
            for orientation in ORIENTATIONS:
                steps = fe_steps(design, orientation, pressures, {"layer_compliance": layer})
                if not steps:  # lost stability at rest: said by fe_steps
                    continue
                probed, tips = misses(rom, steps, orientation, layer)
                alone, bare_tips = misses(bare, steps, orientation, layer)
                rest = steps[0]
                print(f"{name:<11} layer {layer:g} mm/N {orientation:<13} to {steps[-1]['pressure_kpa']:.1f} kPa: "
                      f"tip miss, % of the length (worst / mean): with the probes {100 * probed.max():.2f} / "
                      f"{100 * probed.mean():.2f}; bend's factor alone {100 * alone.max():.2f} / "
                      f"{100 * alone.mean():.2f}; rest tip FE ({rest['tip_x_mm']:.1f}, {rest['tip_z_mm']:.1f}), "
                      f"probes ({tips[0, 0]:.1f}, {tips[0, 1]:.1f}), alone ({bare_tips[0, 0]:.1f}, "
                      f"{bare_tips[0, 1]:.1f}) mm", flush=True)
                if args.write_test_data and name == args.templates[0] and layer == values[0]:
                    written = add_test_steps(TEST_DATA, written, {"design": name, "layer_compliance": layer},
                                             orientation, steps, "rom_layer.py")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
