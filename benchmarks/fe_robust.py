"""Robustness of the quick FE over the design space: random valid designs x the
library's materials x chambers up and down, each bent as ``pnmold build`` bends it.

Designs are drawn at random over the sizes the design rules constrain (kind, chamber count,
length, width, height, inside and outer walls, gap, floor, bottom layer, channel);
``pnmold.design.validate`` (through ``load_design``) refuses invalid draws, which are drawn
again, and designs whose parts fail the gate are skipped as ``pnmold build`` would. Each
design is built once (CAD and gate, no slicer); every material is set from
``pnmold/materials/library.py`` (C10, C20, C30, density; ``design_fe.material_of`` adds its
elongation at break for the stretch stop).

Per case it prints how the curve ended -- full bend, a named physical stop (pressure
maximum, pressure limit, stretch past the elongation at break) or failed (a SolveError; a
traceback counts as failed too) -- with time and factorisations, and how many of its converged
steps have a boundary node deeper than 0.05 mm inside another part of the body
(:mod:`pnmold.fem.overlap`); then the totals. ``--self-contact`` bends as ``pnmold build
--self-contact`` does. Cases are appended to ``--out`` (JSON lines) as they finish and a rerun
skips those done (use another ``--out`` with and without contact). Each curve runs in a process of its own
(spawned afresh), whose peak resident memory the row keeps (``peak_rss_gb``).

    .venv/bin/python benchmarks/fe_robust.py [--designs 30] [--seed 1] [--jobs 1]
        [--out fe_robust.jsonl] [--mesh 3.2,6.4] [--self-contact]
"""

from __future__ import annotations

import argparse
import collections
import concurrent.futures as cf
import json
import multiprocessing
import os
import resource
import sys
import tempfile
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ORIENTATIONS = ("chambers_up", "chambers_down")
#: ranges drawn (uniform) -- the spans of tests/strategies.py, inside which the rules cut
RANGES = {
    "chambers.length_mm": (3.0, 12.0),
    "chambers.width_mm": (8.0, 24.0),
    "chambers.height_mm": (4.0, 16.0),
    "chambers.inside_wall_mm": (0.8, 2.5),
    "chambers.outer_wall_mm": (0.8, 3.0),
    "chambers.gap_mm": (0.8, 3.0),
    "top_layer.floor_mm": (1.5, 4.0),
    "bottom_layer.thickness_mm": (1.5, 4.0),
    "channel.height_mm": (0.6, 2.0),
}
PHYSICAL = ("pressure_maximum", "pressure_limit", "stretch_limit", "instability", "tip_meets_base")


def draw_designs(n: int, seed: int) -> list[tuple[int, list[str]]]:
    """``n`` valid designs (index, overrides); refused draws are drawn again."""
    import numpy as np

    from pnmold.design import load_design
    from pnmold.errors import DesignError

    rng = np.random.default_rng(seed)
    out, tries = [], 0
    while len(out) < n and tries < 200 * n:
        tries += 1
        sets = [f"design.kind={rng.choice(['fpn', 'spn'])}",
                f"chambers.count={int(rng.integers(3, 16))}",
                f"design.name=robust-{seed}-{len(out)}"]
        sets += [f"{key}={round(float(rng.uniform(lo, hi)), 2)}" for key, (lo, hi) in RANGES.items()]
        try:
            load_design("fpn", sets)
        except DesignError:
            continue
        out.append((len(out), sets))
    return out


def material_sets(name: str) -> list[str]:
    """Design overrides that put a library material in a design (the FE then also knows
    its elongation at break: ``design_fe.material_of``)."""
    from pnmold.materials.library import as_design_overrides, get_material

    return as_design_overrides(get_material(name))


def run_case(case: dict, builds: str, mesh: tuple[float, float], contact: bool = False) -> dict:
    """Bend one (design, material, orientation) as the build does (``contact``: as ``pnmold build
    --self-contact`` does); the outcome as a dict, with the overlap of its converged steps."""
    from pnmold.design import load_design
    from pnmold.design_fe import QUICK_MAX_PRESSURE_KPA, build_options, run_fe
    from pnmold.errors import SolveError
    from pnmold.mesh import MeshSize

    options = build_options(contact)

    design = load_design("fpn", case["sets"] + material_sets(case["material"]))
    step = Path(builds) / f"design{case['design']}" / "actuator.step"
    t0 = time.perf_counter()
    out = dict(case)
    try:
        run = run_fe(design, step_path=step, size=MeshSize(*mesh), orientation=case["orientation"],
                     max_pressure_kpa=QUICK_MAX_PRESSURE_KPA, options=options)
        sol = run.solution
        out.update(stop=sol.stop, reason=sol.reason, full_bend_kpa=sol.full_bend_pressure_kpa,
                   last_kpa=sol.max_pressure_kpa, bend_deg=sol.steps[-1].bend_angle_deg,
                   contact=contact, **_overlap(run))
        stats = sol.stats
    except SolveError as err:
        partial = err.partial
        out.update(stop="failed", reason=str(err), stage=err.stage,
                   last_kpa=err.last_converged)
        stats = partial.stats if partial is not None else {}
    except Exception as err:  # anything else is a finding of this benchmark
        out.update(stop="error", reason=f"{type(err).__name__}: {err}",
                   traceback=traceback.format_exc(limit=4))
        stats = {}
    out.update(seconds=round(time.perf_counter() - t0, 1),
               factorizations=stats.get("factorizations"),
               stage_factorizations=stats.get("stage_factorizations"),
               peak_rss_gb=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20, 2))
    return out


def _overlap(run) -> dict:
    """The converged steps with a boundary node deeper than 0.05 mm inside another part of the body,
    and the deepest (:mod:`pnmold.fem.overlap`, as the overlap acceptance measures it; another part
    beyond under half of a gap narrower than 2 mm, :func:`~pnmold.fem.overlap.same_part_for`)."""
    from pnmold.export.p2 import quadratic_mesh
    from pnmold.fem.overlap import OVERLAP_DEPTH_MM, measure_overlap, same_part_for

    q = quadratic_mesh(run.mesh)
    same = same_part_for(run.design.gap_mm)
    found = [measure_overlap(q.nodes_mm, q.cells, u, same_part_mm=same) for u in run.solution.states]
    return {"steps": len(found), "overlap_steps": sum(ov.count(OVERLAP_DEPTH_MM) > 0 for ov in found),
            "overlap_max_mm": round(max((ov.max_depth_mm for ov in found), default=0.0), 3)}


def build_design(index: int, sets: list[str], builds: str) -> bool:
    """CAD and gate of one design (no FE, no slicer); False if a check fails."""
    from pnmold.design import load_design
    from pnmold.pipeline import build

    out = Path(builds) / f"design{index}"
    if (out / "actuator.step").is_file():
        return True
    result = build(load_design("fpn", sets), out, fem=False, use_slicer=False)
    return not any(c["passed"] is False for c in result.report["checks"])


def _single_thread() -> None:
    for key in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ[key] = "1"


def _outcome(row: dict) -> str:
    if row["stop"] == "full_bend":
        return "full bend"
    if row["stop"] in PHYSICAL:
        return row["stop"].replace("_", " ")
    return "failed"


def _print_row(row: dict) -> None:
    fb = f"{row['full_bend_kpa']:.1f} kPa" if row.get("full_bend_kpa") else "-"
    print(f"design {row['design']:>3} {row['kind']:>3} n={row['count']:<3} {row['material']:<16} "
          f"{row['orientation']:<14} {_outcome(row):<17} full bend {fb:>10}  "
          f"{row['seconds']:6.1f} s  {row.get('factorizations') or '-':>4} fact.  "
          f"overlap {row.get('overlap_steps', '-')}/{row.get('steps', '-')} steps  "
          f"peak {row.get('peak_rss_gb', '-')} GB", flush=True)
    if row["stop"] in ("failed", "error"):
        print(f"      {row['reason'][:300]}", flush=True)


def summary(rows: list[dict]) -> None:
    counts = collections.Counter(_outcome(r) for r in rows)
    n = len(rows)
    ok = n - counts["failed"]
    print(f"\n{n} cases: {counts['full bend']} full bend, "
          f"{sum(counts[s.replace('_', ' ')] for s in PHYSICAL)} named physical stop "
          f"({', '.join(f'{k} {v}' for k, v in counts.items() if k not in ('full bend', 'failed'))}), "
          f"{counts['failed']} failed; {100 * ok / max(n, 1):.1f}% full bend or named stop")
    measured = [r for r in rows if "overlap_steps" in r]
    if measured:
        worst = max(r["overlap_max_mm"] for r in measured)
        print(f"  overlap: {sum(r['overlap_steps'] > 0 for r in measured)} of {len(measured)} curves have a step "
              f"with a node deeper than 0.05 mm inside another part (deepest {worst:.3f} mm)")
    for key in ("material", "orientation", "kind"):
        groups = collections.defaultdict(list)
        for r in rows:
            groups[r[key]].append(r)
        print(f"  by {key}: " + "; ".join(
            f"{k}: {sum(_outcome(r) != 'failed' for r in g)}/{len(g)}" for k, g in sorted(groups.items())))
    done = [r for r in rows if r.get("factorizations")]
    if done:
        secs = sorted(r["seconds"] for r in done)
        facts = sorted(r["factorizations"] for r in done)
        print(f"  time per curve: median {secs[len(secs) // 2]:.0f} s, max {secs[-1]:.0f} s; "
              f"factorisations per curve: median {facts[len(facts) // 2]}, max {facts[-1]}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=30)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", default="fe_robust.jsonl")
    parser.add_argument("--builds", default=None, help="folder for the designs' CAD (default: temporary)")
    parser.add_argument("--mesh", default="3.2,6.4", help="wall,max element size (mm); default the build's")
    parser.add_argument("--self-contact", action="store_true", help="bend as pnmold build --self-contact does")
    args = parser.parse_args()
    mesh = tuple(float(v) for v in args.mesh.split(","))
    if args.jobs > 1:
        _single_thread()
    from pnmold.materials.library import list_materials

    out = Path(args.out)
    done = {}
    if out.is_file():
        for line in out.read_text().splitlines():
            row = json.loads(line)
            done[row["key"]] = row
    builds = args.builds or tempfile.mkdtemp(prefix="fe_robust_")
    cases, skipped = [], 0
    for index, sets in draw_designs(args.designs, args.seed):
        kind = sets[0].split("=")[1]
        count = int(sets[1].split("=")[1])
        keys = [f"{args.seed}:{index}:{m.name}:{o}" for m in list_materials() for o in ORIENTATIONS]
        if all(k in done for k in keys):
            continue
        if not build_design(index, sets, builds):
            skipped += 1
            print(f"design {index}: a gate check failed, skipped (as pnmold build skips its FE)")
            continue
        for m in list_materials():
            for o in ORIENTATIONS:
                key = f"{args.seed}:{index}:{m.name}:{o}"
                if key not in done:
                    cases.append({"key": key, "design": index, "sets": sets, "kind": kind,
                                  "count": count, "material": m.name, "orientation": o})
    rows = list(done.values())
    # every curve in a fresh process (spawned, one curve each): peaks of earlier curves kept by the allocator
    # grew one process to 18.9 GB over a run; each row's peak_rss_gb is then that curve's own
    with out.open("a") as sink, cf.ProcessPoolExecutor(
            args.jobs, mp_context=multiprocessing.get_context("spawn"), max_tasks_per_child=1,
            initializer=_single_thread if args.jobs > 1 else None) as pool:
        futures = [pool.submit(run_case, c, builds, mesh, args.self_contact) for c in cases]
        for fut in cf.as_completed(futures):
            row = fut.result()
            sink.write(json.dumps(row) + "\n")
            sink.flush()
            rows.append(row)
            _print_row(row)
    if skipped:
        print(f"{skipped} designs skipped by the gate")
    summary(rows)


if __name__ == "__main__":
    main()
