"""Concealed large-strain stiffening past a pressure maximum: does the stiffening ladder name it?

A design whose free run ends at a pressure maximum (the ribbed segment with both sides, the sPN)
is solved in the FE on a finer mesh (2.5/5 mm) than the one the ladder is read off (3.5/7 mm),
with its rubber off by a nuisance modulus factor and Yeoh C30 added at a share of C10 that lies
between the ladder's runs. Its bending recording (tip and bend angle, 15 rows up to 97 % of the
run's own last pressure, so past the nominal's maximum; Gaussian noise of 1 % of the tip's travel)
goes to ``pnmold diagnose``, which knows nothing of the key. Null cases: the same without C30 (the
nominal rubber, its curve up to 97 % of its own last pressure: at the model's maximum, which the
nuisance modulus may put past the calibrated model's), where nothing may be named. Prints, per case:
what is named first, the fitted C30 against the concealed one (divided by the modulus factor, as the
model reads it), the held-out RMSE before and after, and the time; then the shares.

    .venv/bin/python benchmarks/diagnose_ladder.py [--out out/ladder] [--shares 0.0015 0.004] [--null 1]

The first run characterises each design and its ladder in the FE (minutes, cached), then runs the
fine-mesh FE of each case (minutes each; kept in OUT, so a re-run only redraws nothing and diagnoses).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pnmold.design import load_design  # noqa: E402
from pnmold.fsutil import write_json  # noqa: E402
from pnmold.recording import write_recording  # noqa: E402
from pnmold.tetmesh import MeshSize  # noqa: E402

DESIGNS = (str(ROOT / "benchmarks" / "designs" / "marchese2015-ribbed-two-sided.toml"), "spn")
#: the concealed data's mesh: finer than the characterisation's 3.5/7 mm, so the model is not read off
#: the data's own FE
FE_MESH = MeshSize(2.5, 5.0)
ROWS = 15
NOISE_SHARE = 0.01  # of the tip's travel (assumed: a camera at about 0.5 mm over 50 mm)
TOP_SHARE = 0.97  # of the concealed run's last pressure


def concealed_run(design_ref: str, share: float, scale: float, folder: Path) -> dict:
    """The fine-mesh FE curve with the rubber x ``scale`` and C30 + share x C10 x scale (cached in ``folder``)."""
    path = folder / "fe.json"
    if path.is_file():
        doc = json.loads(path.read_text())
        if (doc["design"], doc["share"], doc["scale"]) == (design_ref, share, scale):
            return doc
    from pnmold.design_fe import run_fe

    design = load_design(design_ref)
    m = design.material
    scaled = design.replace("material", c10_mpa=m.c10_mpa * scale, c20_mpa=m.c20_mpa * scale,
                            c30_mpa=m.c30_mpa * scale)
    c30 = share * m.c10_mpa * scale
    t0 = time.perf_counter()
    run = run_fe(scaled, orientation="none", effects={"strain_stiffening.c30_mpa": c30}, size=FE_MESH,
                 max_pressure_kpa=300.0, keep_partial=True)
    steps = [s.as_dict() for s in run.solution.steps]
    doc = {"design": design_ref, "share": share, "scale": scale, "c30_mpa": c30,
           "expected_c30_mpa": share * m.c10_mpa, "stop": run.solution.stop, "reason": run.solution.reason,
           "seconds": round(time.perf_counter() - t0, 1),
           "curves": {k: [float(s[k]) for s in steps] for k in ("pressure_kpa", "bend_angle_deg", "tip_x_mm",
                                                                 "tip_z_mm")}}
    write_json(path, doc)
    return doc


def write_case(doc: dict, folder: Path, seed: int) -> Path:
    """The bending recording of the concealed run (the rising branch read at ROWS pressures)."""
    c = {k: np.asarray(v, float) for k, v in doc["curves"].items()}
    rising = np.concatenate([[True], np.diff(c["pressure_kpa"]) > 0])
    rising &= c["pressure_kpa"] >= np.maximum.accumulate(c["pressure_kpa"])
    p = np.linspace(0.0, TOP_SHARE * c["pressure_kpa"][rising][-1], ROWS)
    cols = {k: np.interp(p, c["pressure_kpa"][rising], v[rising]) for k, v in c.items() if k != "pressure_kpa"}
    rng = np.random.default_rng(seed)
    sigma = NOISE_SHARE * float(np.ptp(cols["tip_z_mm"]))
    out = {"pressure_kpa": p, **{k: v + rng.normal(0.0, sigma if k.startswith("tip") else sigma / 2.0, p.size)
                                  for k, v in cols.items()}}
    out["tip_x_mm"][0], out["tip_z_mm"][0] = cols["tip_x_mm"][0], cols["tip_z_mm"][0]
    path = folder / "bending.csv"
    write_recording(path, "bending", out, {"orientation": "horizontal"})
    return path


def diagnose(design_ref: str, recording: Path) -> tuple[dict | None, float, str]:
    out = recording.parent / "diagnosis.json"
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pnmold.cli", "diagnose", design_ref, str(recording), "--json",
                           str(out), "--quiet"], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        return None, seconds, proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else ""
    return json.loads(out.read_text()), seconds, ""


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "ladder")
    parser.add_argument("--shares", type=float, nargs="+", default=[0.0015, 0.004])
    parser.add_argument("--scales", type=float, nargs="+", default=[0.9, 1.1])
    parser.add_argument("--null", type=int, default=1, help="null cases per design (no C30)")
    args = parser.parse_args()
    rows = []
    shares = [*args.shares, *[0.0] * args.null]
    plan = [(d, s, args.scales[k % len(args.scales)]) for d in DESIGNS for k, s in enumerate(shares)]
    for i, (design_ref, share, scale) in enumerate(plan):
        folder = args.out / f"{Path(design_ref).stem}-c30-{share:g}-x{scale:g}"
        folder.mkdir(parents=True, exist_ok=True)
        doc = concealed_run(design_ref, share, scale, folder)
        recording = write_case(doc, folder, seed=i)
        diag, seconds, err = diagnose(design_ref, recording)
        name = Path(design_ref).stem
        if diag is None:
            print(f"{name} C30 {share:g} x C10 (scale {scale:g}): refused: {err}")
            rows.append({"named": None, "null": share == 0})
            continue
        named = [m["effect"] for m in diag["missing_physics"]]
        fitted = next((m["parameters"].get("strain_stiffening.c30_mpa") for m in diag["missing_physics"]
                       if m["effect"] == "strain_stiffening"), None)
        error = None if fitted is None or share == 0 else fitted / doc["expected_c30_mpa"] - 1.0
        fit = diag["fit"]
        ratio = fit["heldout_rmse_before"] / max(fit["heldout_rmse_after"], 1e-12)
        rows.append({"named": named[0] if named else None, "error": error, "ratio": ratio,
                     "unexplained": diag["unexplained"], "null": share == 0})
        print(f"{name} C30 {share:g} x C10 (scale {scale:g}; FE {doc['stop']} at "
              f"{doc['curves']['pressure_kpa'][-1]:.3g} kPa, {doc['curves']['bend_angle_deg'][-1]:.0f} deg; "
              f"{doc['seconds']:.0f} s): named {named or 'nothing'}; C30 {fitted} against "
              f"{doc['expected_c30_mpa']:.3g} MPa (error {'-' if error is None else f'{100 * error:+.0f} %'}); "
              f"modulus {diag['calibration']['final'].get('modulus_scale')} against {scale:g}; held-out "
              f"{fit['heldout_rmse_before']:.3g} -> {fit['heldout_rmse_after']:.3g} ({ratio:.1f}x); unexplained "
              f"{diag['unexplained']}; {seconds:.0f} s", flush=True)
    concealed = [r for r in rows if not r["null"]]
    first = [r["named"] == "strain_stiffening" for r in concealed]
    claims = [r["named"] is not None for r in rows if r["null"]]
    errors = [abs(r["error"]) for r in concealed if r.get("error") is not None]
    ratios = [r["ratio"] for r in concealed if "ratio" in r]
    print(f"null claims {sum(claims)}/{len(claims)}")
    print(f"named first {100 * np.mean(first):.0f}% ({sum(first)}/{len(concealed)}); C30 error median "
          f"{100 * np.median(errors) if errors else float('nan'):.0f}%; held-out ratio median "
          f"{np.median(ratios) if ratios else float('nan'):.1f}x (min {min(ratios) if ratios else float('nan'):.1f}x)")


if __name__ == "__main__":
    main()
