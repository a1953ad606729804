"""Blind benchmark of ``pnmold diagnose``: concealed effects (or none) in recordings made the way a
lab's arise, scored against a key kept apart.

A lab names its design (a template, or a design file of its own) and brings recordings of the
actuator it cast: a batch of rubber a little stiffer or softer and a little heavier or lighter than
the library's, tested in the orientation its metadata declares, with Earth's gravity on. The cases
are made that way, through the public verbs with their defaults:

- **Designs**: the five templates and ``--random-designs`` (default 2) valid designs drawn over the
  design rules' region as ``benchmarks/fe_robust.py`` draws them, in the library's rubbers in turn,
  written as design files; nothing of pnmold was tuned on them.
- **Batches**: for each design, ``--batches`` (default 2) rubbers of its own: every Yeoh constant
  scaled by 1 +- 5-12 % (one stiffer, one softer) and the density by 1 +- 0-4 %, written as a design
  file whose material has a name of its own (not the library's), so the reduced model of the batch is
  characterised by the FE like any lab's design (cached). The diagnosis is told the nominal design.
- **Data**: ``pnmold simulate BATCH --orientation O`` (gravity on, as the orientation declares) with the
  concealed effect in ``--effects`` (a concealed ``gravity`` is a weight other than the declared: a tip
  resting on a support, 0-0.6 g), ``--cycles 3`` and a ramp rate, as a bending and a P-V recording,
  with the verb's own noise options. The FE makes them (``--model fe``) where the effect is in the FE
  (gravity, strain stiffening, layer compliance, self-contact as ``--self-contact`` on a design with gaps
  between its chambers, and every null case), else the reduced model of the batch (its FE
  characterisation). The verb's metadata naming the batch, the model and the effects is
  stripped, and so is the bend angle (a tip tracked by a camera): the recordings say only their kind,
  orientation and ramp rate.
- **Diagnosis**: ``pnmold diagnose DESIGN bending.csv pv.csv`` as a user runs it (a subprocess).

Signal-to-noise: the noise is set from the concealed effect's signature on the observables after
recalibrating the modulus (the nominal reduced model; docs/diagnosis.md: what recalibration cannot
absorb): its RMS on the observable it affects most is ``snr`` (drawn in [4, 12]) times the noise's
standard deviation; the other observables get the same noise relative to their range. Null cases
draw the tip's noise in 0.1-0.6 mm. A concealed magnitude whose signature is under 3 % of the range
(three times the model's own form error the diagnosis allows for) is raised toward the catalogue's bound:
an effect the model's form error hides tests nothing; a case whose effect still shows less (the FE's
self-contact, on or off, on a design where it hardly moves the curve below the ramp's top) is left out
and said, as is one whose recording holds rest rows only.

    .venv/bin/python benchmarks/diagnose_blind.py [--per-effect 8] [--null 20] [--seed 1]
        [--out out/blind] [--source auto|rom] [--jobs 2] [--random-designs 2] [--batches 2] [--rescore]
        [--only IDS]

A case whose bending recording holds fewer than three distinct pressures (its solve ended at rest,
e.g. a batch that cannot be pressurised in its orientation under its own weight) is said and left out.
``--rescore`` scores a finished run's ``results.json`` again. ``--only case_006,case_024`` makes,
diagnoses and scores only those cases of the same draw (every batch is still characterised: the draw
reads their curves), to look into a few cases without the whole run; their results go to
``results-only.json``, beside a whole run's ``results.json``.

An interrupted run resumes: designs, batches and recordings already written are kept (and the FE's
characterisations are cached). The summary adds the scores per design (template or random), per
orientation and per source.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
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
from pnmold.errors import PnmoldError  # noqa: E402
from pnmold.fsutil import write_json, write_text  # noqa: E402
from pnmold.recording import read_recording, write_recording  # noqa: E402
from pnmold.sweep.run import THREAD_ENV  # noqa: E402

DESIGNS = ("fpn", "spn", "fig-s2a-h5", "fig-s2b-n7", "fig-s2c-w2")
#: the effects concealed, with the sub-range of magnitudes drawn (inside the catalogue bounds); gravity's
#: is the weight the data show against the declared 1 g (a tip resting on a support carries part of it)
MAGNITUDES = {
    "gravity": (0.0, 0.6),
    "strain_stiffening": (0.01, 0.06),
    "self_contact": (1.0, 1.0),  # the FE's own contact (--self-contact): on or off
    "layer_compliance": (0.02, 0.3),
    "mullins": (0.1, 0.4),
    "viscoelasticity": (0.15, 0.5),
}
IN_FE = ("gravity", "strain_stiffening", "layer_compliance", "self_contact")
#: a batch's modulus: every Yeoh constant x 1 +- this (one batch stiffer, the next softer); its density
#: x 1 +- up to DENSITY_BATCH (assumed: platinum silicones batch to batch, trapped air or pigment)
BATCH = (0.05, 0.12)
DENSITY_BATCH = 0.04
#: the ramps' top as a share of the batch's full-bend pressure (below full bend and the tip meeting the base)
P_MAX_SHARE = 0.75
#: a design that never bends fully (the sPN) is ramped to this share of its FE characterisation's last
#: converged pressure, times P_MAX_SHARE
NO_FULL_BEND_SHARE = 0.8
CYCLES = 3
ROWS_PER_RAMP = 16
ORIENTATIONS = ("chambers_up", "chambers_down", "horizontal")
#: the metadata a lab's recording keeps (the rest of what ``simulate`` writes names the answer)
KEPT_METADATA = ("orientation", "rate_kpa_per_s")
#: the least signature of a concealed effect (RMS, a share of the observable's range): three times the
#: model's own form error the diagnosis allows for (pnmold.diagnose.data.MODEL_FORM_SHARE)
MIN_SIGNATURE = 0.03
#: the least number of distinct pressures a case's bending recording must hold to be scored
MIN_PRESSURES = 3


@dataclass(frozen=True)
class Case:
    id: str
    design: str  # what the lab names: a template or a design file (``pnmold diagnose DESIGN``)
    batch: str  # the design file of the batch the data come from ("": the design itself)
    effect: str | None
    value: float
    extras: dict
    orientation: str
    rate_kpa_per_s: float
    p_max_kpa: float
    snr: float
    source: str  # the model ``pnmold simulate`` makes the data with: fe or rom
    seed: int


# -- designs and batches -----------------------------------------------------------------------------
def random_designs(n: int, seed: int, folder: Path) -> list[str]:
    """``n`` valid random designs (``benchmarks/fe_robust.py``'s draw), the library rubbers in turn,
    written as design files in ``folder``; their paths."""
    from benchmarks.fe_robust import draw_designs, material_sets
    from pnmold.design.load import to_toml
    from pnmold.materials.library import list_materials

    rubbers = [m.name for m in list_materials()]
    paths = []
    for index, sets in draw_designs(n, seed):
        rubber = rubbers[index % len(rubbers)]
        design = load_design("fpn", [*sets, *material_sets(rubber)])
        path = folder / f"{design.name}-{rubber.split()[0].lower()}.toml"
        if not path.is_file():
            write_text(path, to_toml(design))
        paths.append(str(path))
    return paths


def batch_file(design_ref: str, k: int, rng: np.random.Generator, folder: Path) -> str:
    """A batch of the design's rubber (see the module docstring) as a design file; its path."""
    from pnmold.design.load import to_toml

    design = load_design(design_ref)
    path = folder / f"{design.name}-batch{k}.toml"
    if path.is_file():
        return str(path)
    sign = 1.0 if k % 2 == 0 else -1.0
    scale = 1.0 + sign * float(rng.uniform(*BATCH))
    density = 1.0 + float(rng.uniform(-DENSITY_BATCH, DENSITY_BATCH))
    m = design.material
    batch = design.replace("material", name=f"{m.name} batch {k} of {design.name}", c10_mpa=m.c10_mpa * scale,
                           c20_mpa=m.c20_mpa * scale, c30_mpa=m.c30_mpa * scale,
                           density_g_per_ml=m.density_g_per_ml * density)
    write_text(path, to_toml(batch))
    return str(path)


def batch_scales(case: Case) -> tuple[float, float]:
    """The batch's modulus and density over the named design's (1, 1 without a batch)."""
    if not case.batch:
        return 1.0, 1.0
    nominal, batch = load_design(case.design).material, load_design(case.batch).material
    return batch.c10_mpa / nominal.c10_mpa, batch.density_g_per_ml / nominal.density_g_per_ml


def _characterise(path: str) -> str:
    from pnmold.physics.characterise import characterise

    try:
        char = characterise(load_design(path))
    except PnmoldError as err:
        return f"{Path(path).stem}: FAILED {err}"
    return f"{Path(path).stem}: {char.reason or 'full bend'} ({char.max_pressure_kpa:.4g} kPa)"


def characterise_all(paths: list[str], jobs: int) -> list[str]:
    """Characterise every design once (single-threaded workers; each lands in the cache); the lines said."""
    with _one_thread(), ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        lines = list(pool.map(_characterise, paths))
    for line in lines:
        print(f"characterised {line}", flush=True)
    return lines


class _one_thread:
    """THREAD_ENV for the worker processes started inside (restored after)."""

    def __enter__(self):
        self.saved = {k: os.environ.get(k) for k in THREAD_ENV}
        os.environ.update(THREAD_ENV)

    def __exit__(self, *exc):
        for k, v in self.saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


# -- drawing the cases -------------------------------------------------------------------------------
def draw_cases(per_effect: int, n_null: int, seed: int, source: str, batches: dict[str, list[str]]) -> list[Case]:
    """The plan: ``per_effect`` cases of each concealed effect and ``n_null`` without, each on a design and
    one of its batches, an orientation, a ramp rate and top, an SNR and a seed."""
    from pnmold.physics.characterise import characterise

    rng = np.random.default_rng(seed)
    plan = [e for e in MAGNITUDES for _ in range(per_effect)] + [None] * n_null
    rng.shuffle(plan)
    designs = list(batches)
    cases = []
    for i, effect in enumerate(plan):
        name = str(rng.choice(designs))
        if effect == "self_contact" and load_design(name).gap_mm <= 0:
            # an sPN-like design has no gap between chambers: no walls to meet; the first design that has one
            name = next((d for d in designs if load_design(d).gap_mm > 0), "fpn")
        batch = str(rng.choice(batches[name]))
        char = characterise(load_design(batch))
        full = char.full_bend_pressure_kpa or NO_FULL_BEND_SHARE * char.max_pressure_kpa
        lo, hi = MAGNITUDES.get(effect, (0.0, 0.0))
        orient = str(rng.choice(ORIENTATIONS[:2] if effect == "gravity" else ORIENTATIONS))
        extras = {}
        if effect == "self_contact":
            rng.uniform(0.3, 0.6)  # the contact's onset the reduced model was once given: drawn still, so that
            # a seed's other cases stay what they were
        if effect == "viscoelasticity":
            extras = {"viscoelasticity.tau_s": float(np.exp(rng.uniform(np.log(0.5), np.log(10.0))))}
        src = "fe" if source == "auto" and (effect is None or effect in IN_FE) else "rom"
        cases.append(Case(f"case_{i:03d}", name, batch, effect, float(rng.uniform(lo, hi)), extras, orient,
                          float(rng.uniform(0.5, 4.0)), float(P_MAX_SHARE * full), float(rng.uniform(4.0, 12.0)),
                          src, int(rng.integers(1 << 30))))
    return cases


# -- the noise ------------------------------------------------------------------------------------------
def _protocol(case: Case, kind: str):
    from pnmold.physics.protocol import Protocol

    return Protocol.ramp(kind, case.p_max_kpa, case.p_max_kpa / (ROWS_PER_RAMP - 1), CYCLES,
                         case.rate_kpa_per_s, case.orientation)


def _rom_columns(case: Case, kind: str, effects: dict, scale: float) -> dict[str, np.ndarray]:
    """The nominal design's reduced model as the diagnosis starts (the rig as declared) with ``effects`` (with
    ``self_contact``, on the FE's runs with self-contact, solved once for a design that lacks them)."""
    from pnmold.physics.probes import characterised_for
    from pnmold.physics.rom import ReducedModel

    design = load_design(case.design)
    c = characterised_for(design, [kind], [case.orientation], contact=effects.get("self_contact", 0.0) > 0)
    return ReducedModel.for_design(design, c).run(_protocol(case, kind), effects, None, {"modulus_scale": scale})


def _span(cols_by_kind: dict, key: str) -> float:
    for cols in cols_by_kind.values():
        if key in cols:
            return float(np.ptp(cols[key]))
    return 1.0


def case_noise(case: Case) -> dict[str, float]:
    """Standard deviations of the tip (mm) and the volume (mL); see the module docstring."""
    from scipy.optimize import minimize_scalar

    scale, _ = batch_scales(case)
    effects = {case.effect: case.value, **case.extras} if case.effect else {}
    clean = {k: _rom_columns(case, k, effects, scale) for k in ("bending", "pv")}
    if not case.effect:
        tip = float(np.random.default_rng(case.seed).uniform(0.1, 0.6))
        return {"mm": tip, "ml": tip / max(_span(clean, "tip_z_mm"), 1e-9) * _span(clean, "volume_ml"), "rel": 0.0}

    def remainder(s):
        out = {}
        for kind, cols in clean.items():
            base = _rom_columns(case, kind, {}, s)
            for k in ("tip_x_mm", "tip_z_mm", "volume_ml"):
                if k in cols and (kind == "pv") == (k == "volume_ml"):
                    out[k] = cols[k] - base[k]
        return out

    def cost(s):
        return sum(float(np.sum(v ** 2)) / max(_span(clean, k), 1e-9) ** 2 for k, v in remainder(s).items())

    best = minimize_scalar(cost, bounds=(0.6, 1.6), method="bounded", options={"xatol": 1e-4})
    rel = max(float(np.sqrt(np.mean(v ** 2))) / max(_span(clean, k), 1e-9) for k, v in remainder(best.x).items())
    rel_noise = max(rel / case.snr, 1e-4)
    tip = 0.5 * (_span(clean, "tip_x_mm") + _span(clean, "tip_z_mm"))
    return {"mm": rel_noise * tip, "ml": rel_noise * _span(clean, "volume_ml"), "rel": rel}


def signature(case: Case) -> float:
    """The concealed effect's signature left after recalibrating the modulus: its RMS over the recordings,
    as a share of each observable's range, on the observable it moves most (nominal reduced model)."""
    return case_noise(case)["rel"]


def visible(case: Case) -> Case:
    """The case with a magnitude whose signature the model's own form error does not hide: at least
    :data:`MIN_SIGNATURE` (a concealed effect smaller than what the model cannot explain is not a test of
    the diagnosis); raised toward the catalogue's bound, at most twice."""
    from pnmold.effects import EFFECTS

    if not case.effect or (case.effect == "self_contact" and case.source == "fe"):
        return case  # the FE's self-contact is on or off: no magnitude to raise (:func:`kept` may leave it out)
    for _ in range(2):
        rel = signature(case)
        effect = EFFECTS[case.effect]
        lo, hi = effect.bounds
        if rel >= MIN_SIGNATURE:
            break
        away = case.value - effect.default
        grown = effect.default + away * min(1.5 * MIN_SIGNATURE / max(rel, 1e-9), 4.0)
        case = replace(case, value=float(min(max(grown, lo), 0.95 * hi)))
    return case


# -- making the recordings --------------------------------------------------------------------------------
def simulate_argv(case: Case, kind: str, path: Path, noise: dict[str, float]) -> list[str]:
    """``pnmold simulate`` of the case's batch as a lab's rig would record it (see the module docstring)."""
    step = case.p_max_kpa / (ROWS_PER_RAMP - 1)
    effects = {case.effect: case.value, **case.extras} if case.effect else {}
    contact = case.source == "fe" and effects.pop("self_contact", 0.0) > 0  # the FE's own: a solve option
    argv = ["simulate", case.batch or case.design, "--model", case.source, "--kind", kind,
            "--pressures", f"0:{case.p_max_kpa!r}:{step!r}", "--cycles", str(CYCLES),
            "--rate-kpa-per-s", repr(case.rate_kpa_per_s), "--orientation", case.orientation,
            "--recording", str(path), "--seed", str(case.seed + (kind == "pv")), "-q"]
    if effects:
        argv += ["--effects", ",".join(f"{k}={v!r}" for k, v in effects.items())]
    argv += ["--self-contact"] if contact else []
    argv += ["--noise-mm", repr(noise["mm"])] if kind == "bending" else ["--noise-ml", repr(noise["ml"])]
    return argv


def strip_hints(path: Path) -> None:
    """Keep what a lab's file holds: the kind, the declared orientation and rate, and the measured columns
    (no bend angle: a tip tracked by a camera)."""
    rec = read_recording(path)
    columns = {k: v for k, v in rec.columns.items() if k != "bend_angle_deg"}
    write_recording(path, rec.kind, columns, {k: rec.metadata[k] for k in KEPT_METADATA if k in rec.metadata})


def generate(case: Case, folder: Path) -> None:
    """Write the case's recordings (no label) into ``folder`` through ``pnmold simulate``."""
    from pnmold.cli import main

    noise = case_noise(case)
    folder.mkdir(parents=True, exist_ok=True)
    for kind in ("bending", "pv"):
        path = folder / f"{kind}.csv"
        said = io.StringIO()
        with contextlib.redirect_stderr(said):
            code = main(simulate_argv(case, kind, path, noise))
        if code != 0:
            said = said.getvalue().strip()
            lost = " (no row to record)" if "no row to record" in said else ""  # lost at rest: see _make
            raise RuntimeError(f"{case.id}: pnmold simulate exited {code}{lost}: {said[:200]}")
        strip_hints(path)


def _make(c: Case, data: Path, key_dir: Path) -> Case:
    """Write case ``c``'s recordings (skipped if already there) and its key; the case as made."""
    folder, key = data / c.id, key_dir / f"{c.id}.json"
    if (folder / "pv.csv").is_file() and key.is_file():  # made by an earlier, interrupted run
        return Case(**json.loads(key.read_text()))
    c = visible(c)
    for _ in range(6):
        try:
            generate(c, folder)
            break
        except (RuntimeError, PnmoldError) as err:  # the batch has no equilibrium up there: a lower top
            if "no row to record" in str(err):  # lost at rest, under its weight: no top helps (left out)
                print(f"{c.id}: {err}", flush=True)
                break
            print(f"{c.id}: {err}; ramp top {c.p_max_kpa:.3g} -> {0.85 * c.p_max_kpa:.3g} kPa", flush=True)
            c = replace(c, p_max_kpa=0.85 * c.p_max_kpa)
    write_json(key, asdict(c))
    return c


def testable(folder: Path) -> bool:
    """Whether the case's bending recording holds at least :data:`MIN_PRESSURES` distinct pressures: a
    batch whose solve ends at rest gives a recording of rest rows, which tests no diagnosis, and one that
    cannot carry its own weight (e.g. a floppy Ecoflex design held chambers up) no recording at all."""
    if not (folder / "bending.csv").is_file():
        return False
    rec = read_recording(folder / "bending.csv")
    return np.unique(np.round(rec.columns["pressure_kpa"], 6)).size >= MIN_PRESSURES


def kept(cases: list[Case], data: Path) -> list[Case]:
    """The cases whose recordings can test a diagnosis (:func:`testable`) and whose concealed effect shows
    (:func:`signature` at least :data:`MIN_SIGNATURE`: the FE's self-contact, on or off, has no magnitude
    to raise, and on some designs it hardly moves the curve below its ramp's top); the others said and
    left out."""
    out = []
    for c in cases:
        if not testable(data / c.id):
            print(f"{c.id}: left out: {Path(c.batch).stem} {c.orientation} holds rest rows only, or none (its "
                  f"solve ended at rest)", flush=True)
        elif c.effect and (shown := signature(c)) < MIN_SIGNATURE:
            print(f"{c.id}: left out: {c.effect} on {Path(c.batch).stem} {c.orientation} shows {100 * shown:.2g} % "
                  f"of the range, under the {100 * MIN_SIGNATURE:.2g} % the model's form error hides", flush=True)
        else:
            out.append(c)
    return out


# -- diagnosing and scoring ------------------------------------------------------------------------------
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
    perr = [abs(results[c.id]["value"] - c.value) / _magnitude(c) for c in correct
            if results[c.id]["value"] is not None]
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
        "per_group": {**_per_group(cases, first, lambda c: "random design" if c.design.endswith(".toml")
                                   else "template"),
                      **_per_group(cases, first, lambda c: getattr(c, "orientation", "")),
                      **_per_group(cases, first, lambda c: f"source {getattr(c, 'source', '')}")},
    }


def _magnitude(c) -> float:
    """How far the concealed value is from what the rig declares (gravity: 1 g; every other effect: 0)."""
    from pnmold.effects import EFFECTS

    return abs(c.value - EFFECTS[c.effect].default) or 1.0


def _per_group(cases: list, first: dict, group) -> dict[str, str]:
    """Group -> "named first x/y, null claims a/b" over that group's cases."""
    out = {}
    for name in sorted({group(c) for c in cases}):
        mine = [c for c in cases if group(c) == name]
        hidden = [c for c in mine if c.effect]
        nulls = [c for c in mine if not c.effect]
        out[name] = (f"named first {sum(first[c.id] == c.effect for c in hidden)}/{len(hidden)}, "
                     f"null claims {sum(first[c.id] is not None for c in nulls)}/{len(nulls)}")
    return out


def prepare(out: Path, seed: int, jobs: int, n_random: int, n_batches: int) -> dict[str, list[str]]:
    """The designs (templates and random ones) and their batches, characterised by the FE; design ->
    its batch files. A random design or a batch whose characterisation fails is left out, and said."""
    designs = [*DESIGNS, *random_designs(n_random, seed, out / "designs")]
    rng = np.random.default_rng(seed + 1)
    batches = {d: [batch_file(d, k, rng, out / "batches") for k in range(n_batches)] for d in designs}
    lines = characterise_all([d for d in designs if d.endswith(".toml")]
                             + [b for bs in batches.values() for b in bs], jobs)
    failed = {line.split(":")[0] for line in lines if "FAILED" in line}
    kept = {}
    for d, bs in batches.items():
        if Path(d).stem in failed:
            continue
        ok = [b for b in bs if Path(b).stem not in failed]
        if ok:
            kept[d] = ok
    return kept


def run(per_effect: int, n_null: int, seed: int, out: Path, source: str, jobs: int, n_random: int,
        n_batches: int, only: set[str] | None = None) -> dict:
    data, key_dir = out / "cases", out / "key"
    batches = prepare(out, seed, jobs, n_random, n_batches)
    cases = draw_cases(per_effect, n_null, seed, source, batches)
    if only:  # the same draw, only these cases made, diagnosed and scored
        unknown = only - {c.id for c in cases}
        if unknown:
            sys.exit(f"--only: no such case in this draw: {', '.join(sorted(unknown))}")
        cases = [c for c in cases if c.id in only]
    # generate in single-threaded worker processes (the FE cases dominate: one per core)
    with _one_thread(), ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        cases = kept(list(pool.map(_make, cases, [data] * len(cases), [key_dir] * len(cases))), data)

    def one(c: Case):
        doc, seconds, err = diagnose_case(data / c.id, c.design)
        named = [m["effect"] for m in doc["missing_physics"]] if doc else []
        right = bool(doc and named and named[0] == c.effect)
        value = doc["missing_physics"][0]["parameters"].get(c.effect) if right else None
        fit = doc["fit"] if doc else {}
        print(f"{c.id} {Path(c.design).stem} {c.orientation} {c.source}: concealed {c.effect} {c.value:.3g}; "
              f"named {named or 'nothing'}{' (unexplained)' if doc and doc['unexplained'] else ''}"
              f"{' FAILED' if err else ''} in {seconds:.0f} s", flush=True)
        return c.id, {"named": named, "value": value, "seconds": seconds, "error": err,
                      "heldout_before": fit.get("heldout_rmse_before", float("nan")),
                      "heldout_after": fit.get("heldout_rmse_after", float("nan")),
                      "unexplained": doc["unexplained"] if doc else None}

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        results = dict(pool.map(one, cases))
    # a subset is written beside a whole run's results, never over them
    write_json(out / ("results-only.json" if only else "results.json"),
               {"results": results, "key": [asdict(c) for c in cases]})
    return score(cases, results)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--per-effect", type=int, default=8)
    parser.add_argument("--null", type=int, default=20)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "blind")
    parser.add_argument("--source", choices=("auto", "rom"), default="auto")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--random-designs", type=int, default=2)
    parser.add_argument("--batches", type=int, default=2)
    parser.add_argument("--rescore", action="store_true", help="score the results.json of --out again")
    parser.add_argument("--only", metavar="IDS", help="comma-separated case ids (e.g. case_006,case_024): the same "
                        "draw, only these made, diagnosed and scored (into results-only.json; a whole "
                        "run's results.json is kept)")
    args = parser.parse_args()
    t0 = time.perf_counter()
    if args.rescore:
        saved = json.loads((args.out / "results.json").read_text())
        cases = kept([Case(**k) for k in saved["key"]], args.out / "cases")
        print(score_text(score(cases, saved["results"])))
        return
    only = {c.strip() for c in args.only.split(",") if c.strip()} if args.only else None
    s = score_text(run(args.per_effect, args.null, args.seed, args.out, args.source, args.jobs,
                       args.random_designs, args.batches, only))
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
        *(f"  {k}: {v}" for k, v in s.get("per_group", {}).items()),
    ])


if __name__ == "__main__":
    main()
