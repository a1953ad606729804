"""Blind benchmark of ``pnmold diagnose`` on ``step`` recordings: a concealed pneumatic effect
(``dead_volume`` or ``flow_restriction``) or none, scored against a key kept apart.

Each case draws a design among the templates with a cached FE characterisation, the hidden
effect (or none) and its magnitude, a nuisance modulus error (+-12%: the diagnosis must
recalibrate it, not blame the pneumatics), the supply (100-345 kPa) and the noise. The pulse
is what the design can take: the supply valve closes and the vent opens when the nominal
actuator's inlet pressure reaches a drawn share (60-90%) of the highest pressure its FE
characterisation holds (its full-bend pressure, or the FE's last step), as the paper's fPN
was pulsed at 345 kPa; the recording runs on for 1.5 times the pulse (venting), at about
300 rows.

The data come from ``simulate_step`` (``pnmold simulate --dynamic``'s tolerances, rtol 1e-10,
on the FE chamber law scaled by the nuisance modulus) with the effect switched on; the
diagnosis runs the same compiled step model (``pnmold.pneumatics.StepModel``) at its own,
looser tolerances (rtol 1e-6): the same equations, so this tests identifiability and the
decision rules, not a gap in fidelity. They are written as
lab step recordings (``time_s, supply_kpa, pressure_kpa, flow_slpm, bend_angle_deg,
tip_x_mm, tip_z_mm``; ``--observed`` keeps fewer; metadata: design, orientation, the
tubing) with no label; the key goes to a separate folder. ``pnmold diagnose`` runs on each
as a user would (a subprocess); its wall time and its CPU time (user + system, what it
costs whatever else the machine runs) are reported.

Signal-to-noise, as ``diagnose_blind.py``: the effect's signature left after recalibrating
the modulus (the clean data against the best nominal model over the modulus), on the
recorded observable it affects most, has an RMS of ``snr`` (drawn in [4, 12]) times the
noise's standard deviation; every observable gets the same noise relative to its range.
Null cases draw that relative noise log-uniformly in [0.1%, 2%] of each observable's range.

    .venv/bin/python benchmarks/diagnose_blind_step.py [--per-effect 10] [--null 10] [--seed 1]
        [--out out/blind-step] [--jobs 1] [--observed pressure_kpa,flow_slpm,bend_angle_deg]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import diagnose_blind as blind  # noqa: E402
from pnmold.design import load_design  # noqa: E402
from pnmold.fsutil import write_json  # noqa: E402
from pnmold.recording import write_recording  # noqa: E402

#: the templates whose FE characterisation is cached in out/.cache/fe
DESIGNS = ("fpn", "spn", "fig-s2a-h5", "fig-s2b-n7", "fig-s2c-w2")
#: concealed effects and the magnitudes drawn (inside the catalogue bounds [0, 20])
MAGNITUDES = {"dead_volume": (0.5, 15.0), "flow_restriction": (0.2, 8.0)}
SUPPLY_KPA = (100.0, 345.0)
#: the pulse ends when the nominal inlet pressure reaches this share of the design's FE range
PULSE_SHARE = (0.6, 0.9)
VENT_FACTOR = 1.5  # the recording goes on for this many pulse lengths after the vent opens
ROWS = 300
SIM_STEP_S = 5e-4  # simulate_step's output step: recording periods are multiples of it
MODULUS = (0.88, 1.12)
SNR = (4.0, 12.0)
NULL_NOISE = (1e-3, 2e-2)
OBSERVED = ("pressure_kpa", "flow_slpm", "bend_angle_deg")
LAB_COLUMNS = ("time_s", "supply_kpa", "pressure_kpa", "flow_slpm", "bend_angle_deg", "tip_x_mm", "tip_z_mm")
TUBING = {"tubing_length_mm": 300.0, "tubing_id_mm": 0.79375}  # the supplement's 1/32" bore, 300 mm assumed
TUBING_META = {k: f"{v:g}" for k, v in TUBING.items()}


@dataclass(frozen=True)
class Case:
    id: str
    design: str
    effect: str | None
    value: float
    modulus_scale: float
    supply_kpa: float
    vent_at_s: float
    duration_s: float
    sample_s: float
    snr: float
    null_noise: float
    seed: int
    observed: str = ",".join(OBSERVED)  # the columns the recording holds besides time and supply


def _law(name: str):
    from pnmold.pneumatics.law import chamber_law_for

    return chamber_law_for(load_design(name))


def _limit_kpa(name: str) -> float:
    """The highest pressure the design's FE characterisation holds (full bend, or its last step)."""
    from pnmold.physics.characterise import characterise

    c = characterise(load_design(name))
    return float(c.full_bend_pressure_kpa or c.max_pressure_kpa)


def pulse(name: str, supply_kpa: float, share: float) -> tuple[float, float, float]:
    """(vent time, duration, sample period) of the pulse on the nominal actuator (module docstring)."""
    from pnmold.pneumatics import StepModel, StepProtocol

    model = StepModel(load_design(name), _law(name))
    target = share * _limit_kpa(name)
    horizon = 5.0
    t = np.arange(0.0, horizon + SIM_STEP_S / 2, SIM_STEP_S)
    proto = StepProtocol(t, np.array([0.0, horizon]), np.array([0]), supply_kpa, **TUBING)
    p = model.run(proto)["pressure_kpa"]
    above = np.flatnonzero(p >= target)
    t_vent = float(t[above[0]]) if above.size else horizon
    period = max(1, round((1 + VENT_FACTOR) * t_vent / ROWS / SIM_STEP_S)) * SIM_STEP_S
    t_vent = max(round(t_vent / period), 4) * period
    return t_vent, round((1 + VENT_FACTOR) * t_vent / period) * period, period


def draw_cases(per_effect: int, n_null: int, seed: int, observed: str = ",".join(OBSERVED)) -> list[Case]:
    rng = np.random.default_rng(seed)
    plan = [e for e in MAGNITUDES for _ in range(per_effect)] + [None] * n_null
    rng.shuffle(plan)
    cases = []
    for i, effect in enumerate(plan):
        name = str(rng.choice(DESIGNS))
        lo, hi = MAGNITUDES.get(effect, (0.0, 0.0))
        value = float(rng.uniform(lo, hi))
        supply = float(rng.uniform(*SUPPLY_KPA))
        t_vent, duration, period = pulse(name, supply, float(rng.uniform(*PULSE_SHARE)))
        null_noise = float(np.exp(rng.uniform(np.log(NULL_NOISE[0]), np.log(NULL_NOISE[1]))))
        cases.append(Case(f"case_{i:03d}", name, effect, value, float(rng.uniform(*MODULUS)), supply, t_vent,
                          duration, period, float(rng.uniform(*SNR)), null_noise, int(rng.integers(1 << 30)),
                          observed))
    return cases


def clean_columns(case: Case) -> dict[str, np.ndarray]:
    """The recording's columns without noise: ``simulate_step`` with the effect on."""
    from pnmold.pneumatics import ActuatorLine, BendingDynamics, Rig, simulate_step

    design = load_design(case.design)
    effects = {"dead_volume_ml": case.value} if case.effect == "dead_volume" else (
        {"flow_restriction": case.value} if case.effect == "flow_restriction" else {})
    rig = Rig(case.supply_kpa, vent_at_s=case.vent_at_s, **TUBING, **effects)
    res = simulate_step(_law(case.design).scaled(case.modulus_scale), ActuatorLine.from_design(design),
                        BendingDynamics.from_design(design), rig, duration_s=case.duration_s)
    every = round(case.sample_s / SIM_STEP_S)
    return {k: np.asarray(res.series[k][::every], float) for k in LAB_COLUMNS}


def signature_noise(case: Case, clean: dict[str, np.ndarray]) -> dict[str, float]:
    """Noise per observable: the signature after recalibrating the modulus / snr, or the null level
    (on the observables the recording holds)."""
    observed = case.observed.split(",")
    span = {k: max(float(np.ptp(clean[k])), 1e-9) for k in observed}
    if case.effect is None:
        rel = case.null_noise
    else:
        from scipy.optimize import minimize_scalar

        from pnmold.pneumatics import StepModel, StepProtocol
        from pnmold.recording import Recording

        model = StepModel(load_design(case.design), _law(case.design))
        proto = StepProtocol.from_recording(Recording("clean", "step", clean, dict(TUBING_META)))

        def remainder(scale: float) -> dict[str, np.ndarray]:
            base = model.run(proto, {}, {"modulus_scale": scale})
            return {k: clean[k] - base[k] for k in observed}

        def cost(scale: float) -> float:
            return sum(float(np.sum(v ** 2)) / span[k] ** 2 for k, v in remainder(scale).items())

        best = minimize_scalar(cost, bounds=(0.6, 1.6), method="bounded", options={"xatol": 1e-4})
        r = remainder(best.x)
        rel = max(float(np.sqrt(np.mean(v ** 2))) / span[k] for k, v in r.items()) / case.snr
    return {k: max(rel, 1e-4) * span[k] for k in observed}



def generate(case: Case, folder: Path) -> dict[str, float]:
    """Write the case's step recording (no label) into ``folder``; the noise per observable."""
    rng = np.random.default_rng(case.seed)
    clean = clean_columns(case)
    noise = signature_noise(case, clean)
    n = clean["time_s"].size
    out = {"time_s": clean["time_s"], "supply_kpa": clean["supply_kpa"] + np.where(
        clean["supply_kpa"] > 0, rng.normal(0.0, 0.002 * case.supply_kpa, n), 0.0)}
    for k in OBSERVED:  # drawn for every column, so the noise of one does not depend on the others recorded
        draw = clean[k] + rng.normal(0.0, noise.get(k, 0.0), n)
        if k in noise:
            out[k] = draw
    if "bend_angle_deg" in noise:  # the tip as a camera sees it (not compared: it follows the angle)
        tip = noise["bend_angle_deg"] / max(float(np.ptp(clean["bend_angle_deg"])), 1e-9) * max(
            float(np.ptp(clean["tip_z_mm"])), 1e-9)
        for k in ("tip_x_mm", "tip_z_mm"):
            out[k] = clean[k] + rng.normal(0.0, tip, n)
    write_recording(folder / "step.csv", "step", out,
                    {"design": case.design, "orientation": "horizontal", **TUBING_META})
    return noise


def diagnose_case(folder: Path, design: str) -> tuple[dict | None, float, float, str]:
    """``pnmold diagnose DESIGN step.csv`` as a user runs it; (JSON or None, wall seconds, CPU
    seconds of the process (user + system: what it costs, whatever else the machine runs), stderr)."""
    out = folder / "diagnosis.json"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    log = folder / "diagnose.log"
    t0 = time.perf_counter()
    with open(log, "w") as err:
        proc = subprocess.Popen([sys.executable, "-m", "pnmold.cli", "diagnose", design, str(folder / "step.csv"),
                                 "--json", str(out), "--quiet"], stdin=subprocess.DEVNULL,
                                stdout=subprocess.DEVNULL, stderr=err, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
    seconds = time.perf_counter() - t0
    cpu = usage.ru_utime + usage.ru_stime
    if proc.returncode != 0 or not out.is_file():
        return None, seconds, cpu, log.read_text()[-2000:]
    return json.loads(out.read_text()), seconds, cpu, ""


def score(cases: list[Case], results: dict[str, dict]) -> dict:
    return blind.score(cases, results, MAGNITUDES)


def run(per_effect: int, n_null: int, seed: int, out: Path, jobs: int, observed: str = ",".join(OBSERVED)) -> dict:
    data, key_dir = out / "cases", out / "key"
    cases = draw_cases(per_effect, n_null, seed, observed)
    for c in cases:
        folder = data / c.id
        key = key_dir / f"{c.id}.json"
        if not (folder / "step.csv").is_file() or not key.is_file() or json.loads(key.read_text())["case"] != asdict(c):
            noise = generate(c, folder)
            write_json(key, {"case": asdict(c), "noise": noise})
        print(f"{c.id}: data written", flush=True)

    def one(c: Case):
        doc, seconds, cpu, err = diagnose_case(data / c.id, c.design)
        named = [m["effect"] for m in doc["missing_physics"]] if doc else []
        right = bool(doc and named and named[0] == c.effect)
        value = doc["missing_physics"][0]["parameters"].get(c.effect) if right else None
        fit = doc["fit"] if doc else {}
        print(f"{c.id}: {c.design} hidden {c.effect} {c.value:.3g} -> named {named} "
              f"({seconds:.1f} s, {cpu:.1f} s CPU){' ERROR ' + err[-300:] if err else ''}", flush=True)
        return c.id, {"named": named, "value": value, "seconds": seconds, "cpu_seconds": cpu, "error": err,
                      "heldout_before": fit.get("heldout_rmse_before", float("nan")),
                      "heldout_after": fit.get("heldout_rmse_after", float("nan")),
                      "unexplained": doc["unexplained"] if doc else None,
                      "calibrated": doc["baseline"]["calibrated"] if doc else None}

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        results = dict(pool.map(one, cases))
    write_json(out / "results.json", {"results": results, "key": [asdict(c) for c in cases]})
    return score(cases, results)


def score_text(s: dict) -> str:
    return "\n".join([
        f"{s['concealed']} concealed + {s['null']} null step cases ({s['failed_runs']} diagnose runs failed)",
        f"correct effect named first: {100 * s['correct_first']:.0f}%   (target >= 90%)",
        f"named effect right:         {100 * s['named_right']:.0f}%",
        f"claims on null cases:       {100 * s['null_claims']:.0f}%   (target <= 5%); "
        f"'unexplained' on null cases: {s['null_unexplained']}",
        f"held-out RMSE ratio (correct cases): median {s['median_heldout_rmse_ratio']:.1f}x, "
        f"min {s['min_heldout_rmse_ratio']:.1f}x",
        f"parameter error (correct cases): median {100 * s['median_parameter_error']:.0f}%, "
        f"max {100 * s['max_parameter_error']:.0f}%",
        f"seconds per diagnosis:      median {s['median_seconds']:.1f}, max {s['max_seconds']:.1f} wall; "
        f"median {s['median_cpu_seconds']:.1f}, max {s['max_cpu_seconds']:.1f} CPU (user + system)   (target <= 30)",
        "per effect (named first / cases): " + ", ".join(f"{k} {v}" for k, v in s["per_effect"].items()),
    ])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--per-effect", type=int, default=10)
    parser.add_argument("--null", type=int, default=10)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "blind-step")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--observed", default=",".join(OBSERVED),
                        help="recorded columns besides time and supply (pressure_kpa always; default all three)")
    args = parser.parse_args()
    observed = [c.strip() for c in args.observed.split(",") if c.strip()]
    if "pressure_kpa" not in observed or not set(observed) <= set(OBSERVED):
        parser.error(f"--observed: pressure_kpa and any of {', '.join(OBSERVED[1:])}")
    t0 = time.perf_counter()
    print(score_text(run(args.per_effect, args.null, args.seed, args.out, args.jobs,
                         ",".join(c for c in OBSERVED if c in observed))))
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
