"""Real data: a lab's own actuator and rig, diagnosed as that lab would.

The "ribbed" bending segment of Marchese, Katzschmann & Rus, "A Recipe for Soft Fluidic
Elastomer Robots", Soft Robotics 2(1), 2015, measured in a volume-controlled rig: a motorised
piston pushes air into one side's channels, the pressure is read after each increment, the
curvature from the tip and base positions (bend angle = curvature x 43 mm). The data are read
from ``../shared/data/`` (no licence: never copied into the repository) and written as pnmold
recordings with the metadata that says how they were measured: the bend angle over the lab's
43 mm, the piston's volume through air (one loading ramp that the piston drives: read by its volume,
the model's pressure at each recorded stroke against the recorded pressure). The design is the segment as built,
``benchmarks/designs/marchese2015-ribbed-two-sided.toml`` (both actuated layers about the constraint, one
driven; Table 1 of the paper, the rest assumed and stated there), with the dimensions the paper does
not give stated with their uncertainty (:data:`UNCERTAIN_MM`, ``pnmold diagnose --uncertain``: a free FE
run each, once); ``--exact-design`` takes them as exact; ``--design
benchmarks/designs/marchese2015-ribbed.toml`` is the first approximation, one side over the constraint
(the side it leaves out keeps its bending curve "unexplained", pointing at the design). The recordings
past the model's pressure maximum make the diagnosis run the stiffening ladder (FE, about 3 minutes once).

Prints: the design used, the calibrated values, what the diagnosis names on the bending and the
P-V recording (and on both together, and on the blocked-force recording of the same segment), the
RMS bend-angle error after calibration as a share of the measured range, and the dead volume
against what Boyle's law alone says of the rig's air column from the first increments (where the
segment has barely bent, nearly all the piston's volume compresses air: V_air ~ dV (p_atm + p) / p,
an upper bound).

    .venv/bin/python benchmarks/diagnose_real.py [--out out/real] [--design FILE] [--exact-design]
        [--model-error SHARE]
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pnmold.physics.reading import P_ATM_KPA  # noqa: E402
from pnmold.recording import write_recording  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
BENDING = DATA / "marchese2015_ribbed_bending.csv"
#: the blocked tip force, measured with another piston (a plate on a load cell at the tip)
FORCE = DATA / "marchese2015_ribbed_blocked_force.csv"
#: the first approximation (one side) and the segment as built (both sides; the default)
ONE_SIDED = ROOT / "benchmarks" / "designs" / "marchese2015-ribbed.toml"
DESIGN = ROOT / "benchmarks" / "designs" / "marchese2015-ribbed-two-sided.toml"
#: the paper's bending length: bend angle = curvature x 0.043 m (the data file's header)
BENDING_LENGTH_MM = 43.0
#: the rig's stated accuracy, from the lab's own error estimate in the script the data come from
#: (plotBACharacterizations_colored.m, calculateEnergyError): the pressure transducer (Honeywell
#: ASDXACX015PAAA5) 2 % of its 15 psi full scale, and the piston's 0.3 mm position accuracy (Firgelli L16)
#: times its area (3.81 cm bore: 11.40 cm^2; the script squares the diameter, 0.435 mL)
PRESSURE_ACCURACY_KPA = 0.02 * 15 * 6.894757
VOLUME_ACCURACY_ML = 0.03 * 3.141592653589793 * (3.81 / 2) ** 2
#: what the design does not know of the segment, as standard uncertainties (mm; `pnmold diagnose --uncertain`):
#: the dimensions the paper does not give and the design infers (each one's reasoning is in the design file).
#: Assumed: a wall read off a drawing's outer sizes is known to about a millimetre; the ribs to 0.3 mm (the
#: segment's 37.8 mm length in Table 1 holds them, the end walls' split of the rest is assumed)
UNCERTAIN_MM = {
    "chambers.outer_wall_mm": 1.0,  # the sides follow from Table 1's width; the roof is assumed as thick
    "chambers.inside_wall_mm": 0.3,  # ribs: Table 1's length less 13 channels and the assumed end walls
    "chambers.tip_wall_mm": 1.0,  # assumed: the distal wall stands in for the tip's printed support
    "paper.depth_mm": 1.0,  # assumed: the constraint at the centre layer's middle
}
SOURCE = "Marchese, Katzschmann & Rus, Soft Robotics 2015, ribbed segment (shared/data; no licence: testing only)"


def read_rows(path: Path) -> dict[str, np.ndarray]:
    lines = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    rows = list(csv.reader(lines))
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


def write_recordings(out: Path) -> dict[str, Path]:
    """The lab's data as pnmold recordings (docs/recording-format.md, with the measurement metadata)."""
    data = read_rows(BENDING)
    common = {"design": "marchese2015-ribbed", "orientation": "horizontal", "source": SOURCE.replace(",", ";")}
    paths = {"bending": out / "bending.csv", "pv": out / "pv.csv"}
    # the tip rests on a ball transfer: no gravity in the bending plane (orientation horizontal)
    write_recording(paths["bending"], "bending", {"pressure_kpa": data["pressure_kpa"],
                                                  "bend_angle_deg": data["bend_angle_deg"]},
                    {**common, "bending_length_mm": f"{BENDING_LENGTH_MM:g}"})
    write_recording(paths["pv"], "pv", {"volume_ml": data["volume_ml"], "pressure_kpa": data["pressure_kpa"]},
                    {**common, "rig": "volume", "medium": "air",
                     "pressure_accuracy_kpa": f"{PRESSURE_ACCURACY_KPA:.4g}",
                     "volume_accuracy_ml": f"{VOLUME_ACCURACY_ML:.4g}"})
    force = read_rows(FORCE)
    paths["force"] = out / "force.csv"
    write_recording(paths["force"], "force", {"pressure_kpa": force["pressure_kpa"], "force_n": force["tip_force_n"]},
                    common)
    return paths


def boyle_bound_ml(rows: int = 2) -> list[float]:
    """The air column each of the first increments implies if the piston's volume all went into air."""
    data = read_rows(BENDING)
    p, v = data["pressure_kpa"][1:rows + 1], data["volume_ml"][1:rows + 1]
    return [float(vi * (P_ATM_KPA + pi) / pi) for pi, vi in zip(p, v, strict=True)]


def diagnose(design: Path, recordings: list[Path], out: Path, model_error: float | None,
             uncertain: dict[str, float]) -> dict:
    cmd = [sys.executable, "-m", "pnmold.cli", "diagnose", str(design), *map(str, recordings), "--json", str(out),
           "--quiet", *(f"--uncertain={k}={v:g}" for k, v in uncertain.items())]
    if model_error is not None:
        cmd += ["--model-error", f"{model_error:g}"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        return {"error": proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else f"exit {proc.returncode}",
                "seconds": time.perf_counter() - t0}
    doc = json.loads(out.read_text())
    doc["seconds"] = time.perf_counter() - t0
    return doc


def bend_rms_share(doc: dict, measured: np.ndarray) -> float:
    """RMS of the final model's bend-angle residual over the measured range (``fit`` in the JSON is the
    located observable's; the bending series is recomputed from the noise-scaled residual)."""
    fit = doc["fit"]
    if fit["observable"] != "bend_angle_deg":
        return float("nan")
    return fit["rmse_after"] / float(np.ptp(measured))


def report(label: str, doc: dict) -> None:
    if "error" in doc:
        print(f"[{label}] refused: {doc['error']} ({doc['seconds']:.0f} s)")
        return
    named = [(m["effect"], m["parameters"]) for m in doc["missing_physics"]]
    print(f"[{label}] calibrated {doc['calibration']['final']}; named {named or 'nothing'}; unexplained "
          f"{doc['unexplained']}; {doc['fit']['observable']} RMSE {doc['fit']['rmse_before']:.3g} -> "
          f"{doc['fit']['rmse_after']:.3g} (held out {doc['fit']['heldout_rmse_before']:.3g} -> "
          f"{doc['fit']['heldout_rmse_after']:.3g}); {doc['seconds']:.0f} s")
    for note in doc["calibration"]["notes"]:
        print(f"[{label}]   note: {note}")
    print(f"[{label}]   summary: {doc['summary']}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "real")
    parser.add_argument("--design", type=Path, default=DESIGN)
    parser.add_argument("--model-error", type=float, default=None, help="pnmold diagnose --model-error")
    parser.add_argument("--exact-design", action="store_true",
                        help="take the design's dimensions as exact (no --uncertain: the design is the segment)")
    args = parser.parse_args()
    if not BENDING.is_file():
        sys.exit(f"no real data at {DATA} (the shared folder beside the checkout)")
    args.out.mkdir(parents=True, exist_ok=True)
    paths = write_recordings(args.out)
    print(f"design: {args.design.relative_to(ROOT) if args.design.is_relative_to(ROOT) else args.design}")
    print("".join(f"  {ln}\n" for ln in args.design.read_text().splitlines() if ln and not ln.startswith("#")),
          end="")
    bound = boyle_bound_ml()
    print(f"rig: the first increments imply an air column of at most {', '.join(f'{b:.1f}' for b in bound)} mL "
          "(Boyle's law, all the piston's volume into air)")
    measured = read_rows(BENDING)["bend_angle_deg"]
    runs = {"bending": [paths["bending"]], "pv": [paths["pv"]], "both": [paths["bending"], paths["pv"]],
            "force": [paths["force"]]}
    uncertain = {} if args.exact_design else UNCERTAIN_MM
    print("uncertain dimensions (standard uncertainty): "
          + (", ".join(f"{k} {v:g} mm" for k, v in uncertain.items()) or "none, the design taken as exact"))
    docs = {k: diagnose(args.design, v, args.out / f"{k}.json", args.model_error, uncertain) for k, v in runs.items()}
    for label, doc in docs.items():
        report(label, doc)
    bend = docs["bending"]
    if "error" not in bend:
        print(f"bending: RMS bend-angle error after calibration {100 * bend_rms_share(bend, measured):.1f} % of the "
              f"measured range ({np.ptp(measured):.1f} deg); target 10 %")
    for label in ("pv", "both"):
        doc = docs[label]
        if "error" in doc:
            continue
        dead = [m for m in doc["missing_physics"] if m["effect"] == "dead_volume"]
        if not dead:
            print(f"{label}: dead_volume not named")
            continue
        check = dead[0].get("rig_check") or {}
        print(f"{label}: dead_volume {dead[0]['parameters']['dead_volume']:.1f} +- "
              f"{dead[0]['uncertainty']['dead_volume']:.1f} mL; the diagnosis's own rig check: at most "
              f"{check.get('air_bound_ml', float('nan')):.1f} mL of air within the rig's stated accuracy "
              f"({check.get('air_bound_as_recorded_ml', float('nan')):.1f} mL as recorded), consistent "
              f"{check.get('consistent')}")


if __name__ == "__main__":
    main()
