"""Self-contact under the actuator's weight: the FE with its walls kept apart against the reduced model.

The reduced model's ``self_contact`` reads the FE's own free run with self-contact (no gravity; the
characterisation's variant, :func:`pnmold.physics.characterise.self_contact_run`). Here, for each template
named (default: fpn, fig-s2a-h5, fig-s2c-w2), the FE bends the actuator with its self-contact on chambers up
and hanging chambers down, or the ``--orientations`` given (``horizontal``: the whole body, as the roll
probe; Earth's gravity, the characterisation's mesh) at six pressures up to 0.85 of
where that free run ended; the reduced model runs the same pressures with ``self_contact`` = 1 (a
prediction: the weight and the contact together, which no run it reads had) and without it. Prints the
worst and mean tip miss (% of the length) of each and the FE's bend beside the two models'.

    .venv/bin/python benchmarks/rom_contact.py [TEMPLATE...] [--orientations ...] [--write-test-data]

``--write-test-data`` writes the first template's FE steps, both orientations, to ``tests/data/`` (what
``tests/test_rom.py`` checks the reduced model against, without an FE run).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
from rom_scale import add_test_steps, fe_steps  # noqa: E402

from pnmold.design import load_design  # noqa: E402
from pnmold.fem import SelfContact, SolveOptions  # noqa: E402
from pnmold.physics import Protocol, ReducedModel  # noqa: E402
from pnmold.physics.probes import characterised_for  # noqa: E402

ORIENTATIONS = ("chambers_up", "chambers_down")
SHARE = 0.85
TEST_DATA = ROOT / "tests" / "data" / "fpn-contact-steps.json"


def run(rom: ReducedModel, steps: list[dict], orientation: str, share: float) -> tuple[np.ndarray, np.ndarray]:
    """Tip distance of the reduced model from the FE at the FE's steps (share of the length); its bends."""
    p = np.array([s["pressure_kpa"] for s in steps])
    out = rom.run(Protocol("bending", p, orientation), {"self_contact": share})
    fe = np.array([[s["tip_x_mm"], s["tip_z_mm"]] for s in steps])
    return np.hypot(out["tip_x_mm"] - fe[:, 0], out["tip_z_mm"] - fe[:, 1]) / rom.design.length_mm, \
        out["bend_angle_deg"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("templates", nargs="*", default=["fpn", "fig-s2a-h5", "fig-s2c-w2"])
    parser.add_argument("--orientations", nargs="+", default=list(ORIENTATIONS),
                        choices=["chambers_up", "chambers_down", "horizontal"])
    parser.add_argument("--write-test-data", action="store_true")
    args = parser.parse_args()
    t0 = time.perf_counter()
    written: dict = {}
    for name in args.templates:
        design = load_design(name)
        rom = ReducedModel.for_design(design, characterised_for(design, ["bending"], args.orientations,
                                                                        contact=True))
        end = rom.contact[1]
        pressures = np.linspace(0.0, SHARE * end, 6)
        for orientation in args.orientations:
            steps = fe_steps(design, orientation, pressures, options=SolveOptions(self_contact=SelfContact()))
            if not steps:  # lost stability at rest: said by fe_steps
                continue
            with_it, bend = run(rom, steps, orientation, 1.0)
            without, bare = run(rom, steps, orientation, 0.0)
            fe = [s["bend_angle_deg"] for s in steps]
            print(f"{name:<11} {orientation:<13} to {steps[-1]['pressure_kpa']:.1f} kPa (the free run with contact "
                  f"ended at {end:.4g} kPa): tip miss, % of the length (worst / mean): with self_contact "
                  f"{100 * with_it.max():.2f} / {100 * with_it.mean():.2f}; without {100 * without.max():.2f} / "
                  f"{100 * without.mean():.2f}; bend FE {', '.join(f'{b:.1f}' for b in fe)}; with "
                  f"{', '.join(f'{b:.1f}' for b in bend)}; without {', '.join(f'{b:.1f}' for b in bare)} deg",
                  flush=True)
            if args.write_test_data and name == args.templates[0]:
                written = add_test_steps(TEST_DATA, written, {"design": name}, orientation, steps, "rom_contact.py")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
