"""Blind benchmark of ``pnmold diagnose``: concealed effects (or none), scored against a key.

Each case draws a design (a template), one hidden effect or none, its magnitude, a nuisance
modulus error (+-12%, the baseline must recalibrate it, not blame physics), the test
orientation, ramp rate and noise. The data come from the FE where the effect is in the FE
(gravity, strain_stiffening, layer_compliance; null cases too) on a finer mesh than the one
that characterised the reduced model, and otherwise from the reduced model. They are written
as plain recordings (a bending and a pv recording of the same three inflate/deflate cycles),
with no label; the key is kept in a separate folder. Then ``pnmold diagnose`` runs on each
case as a user would (a subprocess) and the result is scored: detection, correct effect
named first, false claims on null cases, held-out RMSE ratio, parameter error, seconds.

Signal-to-noise: the noise is set from the hidden effect's signature on the observables
*after* recalibrating the modulus (what recalibration cannot absorb, docs/diagnosis.md): on the
observable it affects most, the signature's RMS over the recording is ``snr`` (drawn in
[4, 12]) times the noise's standard deviation; the other observables get the same noise
relative to their range.

    .venv/bin/python benchmarks/diagnose_blind.py [--per-effect 10] [--null 20] [--seed 1]
        [--out out/blind] [--source auto|rom] [--jobs 2] [--designs templates|random]
        [--random-designs 6]

``--designs random``: instead of the five templates, designs a lab might bring: drawn at random
over the design rules' valid region as ``benchmarks/fe_robust.py`` draws them (both kinds, 3-15
chambers, every size the rules bound), each in one of the three library rubbers in turn
(Elastosil M4601, Ecoflex 00-30, Dragon Skin 30), written as design files in ``OUT/designs``
and characterised in the FE first (``--jobs`` at a time; cached as a user's design is). Nothing
of pnmold was tuned on them. The summary adds the scores per rubber.

An interrupted run resumes: recordings already in ``OUT/cases`` are kept. The FE's noise-free
columns of each case are kept with the key (``OUT/key/<case>-fe-columns.json``): remove
``OUT/cases`` to redraw the noise (after a change of the reduced model that sets it) without
re-running the FE.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pnmold.design import load_design  # noqa: E402
from pnmold.errors import SolveError  # noqa: E402
from pnmold.fsutil import write_json  # noqa: E402
from pnmold.recording import write_recording  # noqa: E402
from pnmold.sweep.run import THREAD_ENV  # noqa: E402

DESIGNS = ("fpn", "spn", "fig-s2a-h5", "fig-s2b-n7", "fig-s2c-w2")
#: the effects concealed, with the sub-range of magnitudes drawn (inside the catalogue bounds)
MAGNITUDES = {
    "gravity": (0.5, 1.5),
    "strain_stiffening": (0.01, 0.06),
    "self_contact": (2.0, 15.0),
    "layer_compliance": (0.02, 0.3),
    "mullins": (0.1, 0.4),
    "viscoelasticity": (0.15, 0.5),
}
IN_FE = ("gravity", "strain_stiffening", "layer_compliance")
#: the FE's mesh for concealed data: the characterisation's (3.5/7 mm) keeps 50 FE curves within
#: the hour on 2 cores; the data are still of higher fidelity than the reduced model that
#: diagnoses them (a 3-D continuum with the effect inside, against a rod of chamber hinges)
FE_MESH = (3.5, 7.0)
#: the ramps' top as a share of the nominal full-bend pressure: below full bend even for the
#: softest nuisance modulus (0.88), where the FE (no self-contact) would curl through itself
P_MAX_SHARE = 0.75
#: a design that never bends fully (the sPN) is ramped to this share of the characterisation's last
#: converged pressure, times P_MAX_SHARE: its FE stalls near there (39.9 kPa seen at 0.75 x 53.9)
NO_FULL_BEND_SHARE = 0.8
CYCLES = 3
ROWS_PER_RAMP = 16


@dataclass(frozen=True)
class Case:
    id: str
    design: str
    effect: str | None
    value: float
    extras: dict
    modulus_scale: float
    orientation: str
    rate_kpa_per_s: float
    p_max_kpa: float
    snr: float
    source: str
    seed: int


def random_designs(n: int, seed: int, folder: Path) -> list[str]:
    """``n`` valid random designs (``benchmarks/fe_robust.py``'s draw), the library rubbers in turn,
    written as design files in ``folder``; their paths."""
    from benchmarks.fe_robust import draw_designs, material_sets
    from pnmold.design.load import to_toml
    from pnmold.fsutil import write_text
    from pnmold.materials.library import list_materials

    rubbers = [m.name for m in list_materials()]
    paths = []
    for index, sets in draw_designs(n, seed):
        rubber = rubbers[index % len(rubbers)]
        design = load_design("fpn", [*sets, *material_sets(rubber)])
        path = folder / f"{design.name}-{rubber.split()[0].lower()}.toml"
        write_text(path, to_toml(design))
        paths.append(str(path))
    return paths


def _characterise(path: str) -> str:
    from pnmold.physics.characterise import characterise

    char = characterise(load_design(path))
    return f"{Path(path).stem}: {char.reason or 'full bend'} ({char.max_pressure_kpa:.4g} kPa)"


def characterise_all(paths: list[str], jobs: int) -> None:
    """Characterise every design once (single-threaded workers); each lands in the cache."""
    saved = {k: os.environ.get(k) for k in THREAD_ENV}
    os.environ.update(THREAD_ENV)
    try:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            for line in pool.map(_characterise, paths):
                print(f"characterised {line}", flush=True)
    finally:
        _restore(saved)


def _restore(saved: dict[str, str | None]) -> None:
    for k, v in saved.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


def draw_cases(per_effect: int, n_null: int, seed: int, source: str,
               designs: tuple[str, ...] = DESIGNS) -> list[Case]:
    from pnmold.physics.characterise import characterise

    rng = np.random.default_rng(seed)
    plan = [e for e in MAGNITUDES for _ in range(per_effect)] + [None] * n_null
    rng.shuffle(plan)
    cases = []
    for i, effect in enumerate(plan):
        name = str(rng.choice(designs))
        design = load_design(name)
        char = characterise(design)
        full = char.full_bend_pressure_kpa or NO_FULL_BEND_SHARE * char.max_pressure_kpa
        if effect == "self_contact" and math.isinf(_contact_pressure(design)):
            # sPN-like designs have no gap: no contact; the first design that has one, else the fPN
            name = next((d for d in designs if math.isfinite(_contact_pressure(load_design(d)))), "fpn")
            design = load_design(name)
            char = characterise(design)
            full = char.full_bend_pressure_kpa or NO_FULL_BEND_SHARE * char.max_pressure_kpa
        lo, hi = MAGNITUDES.get(effect, (0.0, 0.0))
        orient = (str(rng.choice(["chambers_up", "chambers_down"])) if effect == "gravity"
                  else str(rng.choice(["chambers_up", "chambers_down", "horizontal"])))
        extras = {}
        if effect == "self_contact":  # walls touch between 30% and 60% of the ramp's top
            extras = {"self_contact.gap_scale": _gap_for(design, float(rng.uniform(0.3, 0.6)) * P_MAX_SHARE * full)}
        if effect == "viscoelasticity":
            extras = {"viscoelasticity.tau_s": float(np.exp(rng.uniform(np.log(0.5), np.log(10.0))))}
        src = "fe" if source == "auto" and (effect is None or effect in IN_FE) else "rom"
        cases.append(Case(f"case_{i:03d}", name, effect, float(rng.uniform(lo, hi)), extras,
                          float(rng.uniform(0.88, 1.12)), orient, float(rng.uniform(0.5, 4.0)),
                          float(P_MAX_SHARE * full), float(rng.uniform(4.0, 12.0)), src, int(rng.integers(1 << 30))))
    return cases


def _gap_for(design, onset_kpa: float) -> float:
    """The gap scale whose contact pressure is ``onset_kpa`` (bisection; it grows with the gap)."""
    from pnmold.physics.rom import ReducedModel

    rom = ReducedModel.for_design(design)
    lo, hi = 0.25, 4.0
    if rom.contact_pressure_kpa(lo) >= onset_kpa:
        return lo
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if rom.contact_pressure_kpa(mid) < onset_kpa else (lo, mid)
    return round(0.5 * (lo + hi), 4)


def _contact_pressure(design) -> float:
    from pnmold.physics.rom import ReducedModel

    return ReducedModel.for_design(design).contact_pressure_kpa()


def _rom_columns(case: Case, kind: str, effects: dict, scale: float) -> dict[str, np.ndarray]:
    from pnmold.physics.rom import ReducedModel

    design = load_design(case.design)
    proto = _protocol(case, kind)
    off = {"gravity": 0.0}
    return ReducedModel.for_design(design).run(proto, {**off, **effects}, None, {"modulus_scale": scale})


def _protocol(case: Case, kind: str):
    from pnmold.physics.protocol import Protocol

    return Protocol.ramp(kind, case.p_max_kpa, case.p_max_kpa / (ROWS_PER_RAMP - 1), CYCLES,
                         case.rate_kpa_per_s, case.orientation)


def _fe_columns(case: Case, effects: dict) -> dict[str, dict[str, np.ndarray]]:
    """Both recordings' columns from one FE curve (elastic: every branch retraces it)."""
    from pnmold.simulate import SimulationRequest, simulate_fe

    design = load_design(case.design)
    m = design.material
    s = case.modulus_scale
    design = design.replace("material", c10_mpa=m.c10_mpa * s, c20_mpa=m.c20_mpa * s, c30_mpa=m.c30_mpa * s)
    proto = _protocol(case, "bending")
    levels = sorted(set(np.round(proto.pressure_kpa, 6)))
    req = SimulationRequest(tuple(levels), model="fe", kind="bending", orientation=case.orientation,
                            effects=tuple({"gravity": 0.0, **effects}.items()), mesh_size=FE_MESH)
    doc = simulate_fe(design, req)
    table = {round(st["pressure_kpa"], 6): st for st in doc["steps"]}
    rows = [table[round(p, 6)] for p in proto.pressure_kpa]
    bend = {k: np.array([r[k] for r in rows]) for k in ("tip_x_mm", "tip_z_mm", "bend_angle_deg")}
    rest = table[0.0]["cavity_volume_ml"]  # a pv recording holds the injected volume, as the ROM's
    return {"bending": bend, "pv": {"volume_ml": np.array([r["cavity_volume_ml"] - rest for r in rows])}}


def _signature_noise(case: Case, effects: dict) -> dict[str, float]:
    """Noise per observable: the effect's signature left after recalibrating the modulus,
    at its largest, divided by the case's SNR (tip and volume with the same relative noise)."""
    from scipy.optimize import minimize_scalar

    with_effect = {k: _rom_columns(case, k, effects, case.modulus_scale) for k in ("bending", "pv")}

    def remainder(scale):
        out = {}
        for kind, cols in with_effect.items():
            base = _rom_columns(case, kind, {}, scale)
            for k, v in cols.items():
                if k in ("tip_x_mm", "tip_z_mm", "volume_ml"):
                    out[k] = v - base[k]
        return out

    def cost(scale):
        r = remainder(scale)
        return sum(float(np.sum(v ** 2)) / max(_span(with_effect, k), 1e-9) ** 2 for k, v in r.items())

    best = minimize_scalar(cost, bounds=(0.6, 1.6), method="bounded", options={"xatol": 1e-4})
    r = remainder(best.x)
    rel = max(float(np.sqrt(np.mean(v ** 2))) / max(_span(with_effect, k), 1e-9) for k, v in r.items())
    rel_noise = max(rel / case.snr, 1e-4)
    return {k: rel_noise * _span(with_effect, k) for k in ("tip_x_mm", "tip_z_mm", "volume_ml")}


def _span(cols_by_kind: dict, key: str) -> float:
    for cols in cols_by_kind.values():
        if key in cols:
            return float(np.ptp(cols[key]))
    return 1.0


def generate(case: Case, folder: Path, columns: Path | None = None) -> None:
    """Write the case's recordings (no label) into ``folder``.

    ``columns``: a JSON file (kept with the key) holding the FE's noise-free columns of the
    case: read if there, else written, so a re-run redraws only the noise, not the FE."""
    rng = np.random.default_rng(case.seed)
    effects = {case.effect: case.value, **case.extras} if case.effect else {}
    if case.effect:
        noise = _signature_noise(case, effects)
    else:
        tip = float(rng.uniform(0.1, 0.6))
        span = _span({"b": _rom_columns(case, "bending", {}, case.modulus_scale)}, "tip_z_mm")
        noise = {"tip_x_mm": tip, "tip_z_mm": tip,
                 "volume_ml": tip / span * _span({"p": _rom_columns(case, "pv", {}, case.modulus_scale)},
                                                 "volume_ml")}
    stored = json.loads(columns.read_text()) if columns is not None and columns.is_file() else {}
    if case.source == "fe" and stored.get("case") == asdict(case):
        cols = {kind: {k: np.asarray(v) for k, v in d.items()} for kind, d in stored["columns"].items()}
    elif case.source == "fe":
        cols = _fe_columns(case, effects)
        if columns is not None:
            write_json(columns, {"case": asdict(case),
                                 "columns": {kind: {k: v.tolist() for k, v in d.items()} for kind, d in cols.items()}})
    else:
        cols = {k: _rom_columns(case, k, effects, case.modulus_scale) for k in ("bending", "pv")}
    for kind, names in (("bending", ("tip_x_mm", "tip_z_mm")), ("pv", ("volume_ml",))):
        proto = _protocol(case, kind)
        out = {"pressure_kpa": proto.pressure_kpa, "cycle": proto.cycle, "phase": proto.phase,
               "time_s": proto.times_s()}
        for k in names:
            out[k] = cols[kind][k] + rng.normal(0.0, noise[k], proto.pressure_kpa.size)
        write_recording(folder / f"{kind}.csv", kind, out,
                        {"design": case.design, "orientation": case.orientation,
                         "rate_kpa_per_s": f"{case.rate_kpa_per_s:.4g}"})


def _make(c: Case, data: Path, key_dir: Path) -> Case:
    """Write case ``c``'s recordings (skipped if already there) and its key; the case as made."""
    folder, key = data / c.id, key_dir / f"{c.id}.json"
    if (folder / "pv.csv").is_file() and key.is_file():  # made by an earlier, interrupted run
        return Case(**json.loads(key.read_text()))
    for _ in range(4):
        try:
            if not (folder / "pv.csv").is_file():
                generate(c, folder, key_dir / f"{c.id}-fe-columns.json")
            break
        except SolveError as err:
            if c.source == "fe":  # the FE stalled below the ramp's top: a lower top
                print(f"{c.id}: {err}; ramp top {c.p_max_kpa:.3g} -> {0.85 * c.p_max_kpa:.3g} kPa", flush=True)
                c = replace(c, p_max_kpa=0.85 * c.p_max_kpa)
            else:  # the reduced model found no equilibrium at this magnitude: a smaller one
                print(f"{c.id}: {err}; {c.effect} {c.value:.3g} -> {0.6 * c.value:.3g}", flush=True)
                c = replace(c, value=0.6 * c.value)
    write_json(key, asdict(c))
    return c


def diagnose_case(folder: Path, design: str) -> tuple[dict | None, float, str]:
    """``pnmold diagnose`` as a user runs it; (JSON or None, seconds, stderr)."""
    out = folder / "diagnosis.json"
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pnmold.cli", "diagnose", design, str(folder / "bending.csv"),
                           str(folder / "pv.csv"), "--json", str(out)], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0 or not out.is_file():
        return None, seconds, proc.stderr[-2000:]
    return json.loads(out.read_text()), seconds, ""


def score(cases: list, results: dict[str, dict], effects=MAGNITUDES) -> dict:
    """Detection, correct effect first, null claims, held-out RMSE ratio, parameter error and
    seconds (and CPU seconds where recorded) over ``cases`` scored against their key."""
    concealed = [c for c in cases if c.effect]
    nulls = [c for c in cases if not c.effect]
    first = {c.id: (results[c.id]["named"] or [None])[0] for c in cases}
    correct = [c for c in concealed if first[c.id] == c.effect]
    named = [c for c in concealed if first[c.id] is not None]
    ratios = [results[c.id]["heldout_before"] / max(results[c.id]["heldout_after"], 1e-12) for c in correct]
    perr = [abs(results[c.id]["value"] - c.value) / c.value for c in correct if results[c.id]["value"] is not None]
    seconds = [results[c.id]["seconds"] for c in cases]
    cpu = [results[c.id].get("cpu_seconds", float("nan")) for c in cases]
    return {
        "cases": len(cases), "concealed": len(concealed), "null": len(nulls),
        "correct_first": len(correct) / max(len(concealed), 1),
        "named_right": len(correct) / max(len(named), 1),
        "null_claims": sum(first[c.id] is not None for c in nulls) / max(len(nulls), 1),
        "null_unexplained": sum(bool(results[c.id]["unexplained"]) for c in nulls),
        "median_heldout_rmse_ratio": float(np.median(ratios)) if ratios else float("nan"),
        "min_heldout_rmse_ratio": float(np.min(ratios)) if ratios else float("nan"),
        "median_parameter_error": float(np.median(perr)) if perr else float("nan"),
        "max_parameter_error": float(np.max(perr)) if perr else float("nan"),
        "max_seconds": max(seconds), "median_seconds": float(np.median(seconds)),
        "max_cpu_seconds": max(cpu), "median_cpu_seconds": float(np.median(cpu)),
        "per_effect": {e: f"{sum(first[c.id] == e for c in concealed if c.effect == e)}/"
                          f"{sum(c.effect == e for c in concealed)}" for e in effects},
        "failed_runs": sum(results[c.id]["error"] != "" for c in cases),
        "per_material": _per_material(cases, first),
    }


def _per_material(cases: list, first: dict) -> dict[str, str]:
    """Rubber -> "named first x/y, null claims a/b" over that rubber's cases."""
    rubber = {d: load_design(d).material.name for d in {c.design for c in cases}}
    out = {}
    for name in sorted(set(rubber.values())):
        mine = [c for c in cases if rubber[c.design] == name]
        hidden = [c for c in mine if c.effect]
        nulls = [c for c in mine if not c.effect]
        out[name] = (f"named first {sum(first[c.id] == c.effect for c in hidden)}/{len(hidden)}, "
                     f"null claims {sum(first[c.id] is not None for c in nulls)}/{len(nulls)}")
    return out


def run(per_effect: int, n_null: int, seed: int, out: Path, source: str, jobs: int,
        n_random: int = 0) -> dict:
    """``n_random`` > 0: that many random designs (:func:`random_designs`) instead of the templates."""
    data, key_dir = out / "cases", out / "key"
    designs = DESIGNS
    if n_random:
        designs = tuple(random_designs(n_random, seed, out / "designs"))
        characterise_all(list(designs), jobs)
    cases = draw_cases(per_effect, n_null, seed, source, designs)
    # generate in single-threaded worker processes (the FE cases dominate: one per core)
    saved = {k: os.environ.get(k) for k in THREAD_ENV}
    os.environ.update(THREAD_ENV)
    try:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            cases = list(pool.map(_make, cases, [data] * len(cases), [key_dir] * len(cases)))
    finally:
        _restore(saved)

    def one(c: Case):
        doc, seconds, err = diagnose_case(data / c.id, c.design)
        named = [m["effect"] for m in doc["missing_physics"]] if doc else []
        right = bool(doc and named and named[0] == c.effect)
        value = doc["missing_physics"][0]["parameters"].get(c.effect) if right else None
        fit = doc["fit"] if doc else {}
        return c.id, {"named": named, "value": value, "seconds": seconds, "error": err,
                      "heldout_before": fit.get("heldout_rmse_before", float("nan")),
                      "heldout_after": fit.get("heldout_rmse_after", float("nan")),
                      "unexplained": doc["unexplained"] if doc else None}

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        results = dict(pool.map(one, cases))
    write_json(out / "results.json", {"results": results, "key": [asdict(c) for c in cases]})
    return score(cases, results)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--per-effect", type=int, default=10)
    parser.add_argument("--null", type=int, default=20)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "blind")
    parser.add_argument("--source", choices=("auto", "rom"), default="auto")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--designs", choices=("templates", "random"), default="templates")
    parser.add_argument("--random-designs", type=int, default=6)
    args = parser.parse_args()
    t0 = time.perf_counter()
    n_random = args.random_designs if args.designs == "random" else 0
    s = score_text(run(args.per_effect, args.null, args.seed, args.out, args.source, args.jobs, n_random))
    print(s)
    print(f"total {time.perf_counter() - t0:.0f} s")


def score_text(s: dict) -> str:
    return "\n".join([
        f"{s['concealed']} concealed + {s['null']} null cases ({s['failed_runs']} diagnose runs failed)",
        f"correct effect named first: {100 * s['correct_first']:.0f}%   (target >= 90%)",
        f"named effect right:         {100 * s['named_right']:.0f}%   (target >= 90%)",
        f"claims on null cases:       {100 * s['null_claims']:.0f}%   (target <= 5%)",
        f"held-out RMSE ratio (correct cases): median {s['median_heldout_rmse_ratio']:.1f}x, "
        f"min {s['min_heldout_rmse_ratio']:.1f}x   (target >= 3x)",
        f"median parameter error:     {100 * s['median_parameter_error']:.0f}%   (target <= 20%)",
        f"seconds per diagnosis:      median {s['median_seconds']:.1f}, max {s['max_seconds']:.1f}   (target <= 30)",
        "per effect (named first / cases): " + ", ".join(f"{k} {v}" for k, v in s["per_effect"].items()),
        "per rubber: " + "; ".join(f"{k}: {v}" for k, v in s.get("per_material", {}).items()),
    ])


if __name__ == "__main__":
    main()
