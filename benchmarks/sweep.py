"""Sweep throughput: points per minute with 1 and 2 local workers, the scaling ratio, and
the peak memory (RSS) of each worker process, on a fixed small sweep.

    .venv/bin/python benchmarks/sweep.py                  # 4 fPN points, quick FE on a 3.5/7 mm mesh
    .venv/bin/python benchmarks/sweep.py --no-fem         # geometry and the gate only
    .venv/bin/python benchmarks/sweep.py --wall-mm 5 --max-mm 10 --workers 1 2

Each run starts from an empty database (nothing skipped) and includes the workers' start
and imports, as a user's sweep does. The load average is printed before and after, and the
workers' CPU time with the share of the cores they got: on a shared machine the ratio is
only meaningful when that share stays near 100%. The quick FE's mesh (gmsh) is not
bit-for-bit repeatable, so a point's solve can differ between the runs.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import tempfile
import time
from pathlib import Path

SWEEP = """
[sweep]
name = "bench"
base = "fpn"
[axes]
chambers.count = {counts}
[run]
fem = {fem}
wall_mm = {wall_mm}
max_mm = {max_mm}
"""


def bench(workers: int, spec_path: Path, tmp: Path) -> dict:
    from pnmold.sweep import load_sweep, run_sweep

    spec = load_sweep(spec_path)
    t0 = time.perf_counter()
    result = run_sweep(spec, tmp / f"bench-{workers}.sqlite", workers=workers)
    wall_s = time.perf_counter() - t0
    peak: dict[str, float] = {}
    for row in result.rows:
        if row["worker"]:
            peak[row["worker"]] = max(peak.get(row["worker"], 0.0), row["worker_max_rss_mb"] or 0.0)
    statuses = [r["status"] for r in result.rows]
    cpu_s = sum(r["cpu_s"] or 0.0 for r in result.rows)
    return {"workers": workers, "points": len(result.rows), "wall_s": wall_s, "cpu_s": cpu_s,
            "cpu_share": cpu_s / (workers * wall_s),
            "points_per_min": 60.0 * len(result.rows) / wall_s, "peak_rss_mb": peak,
            "point_s": [r["time_s"] for r in result.rows], "statuses": statuses,
            "full_bend_kpa": [r["full_bend_pressure_kpa"] for r in result.rows]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--counts", default="4,5,6,7", help="chamber counts of the fPN points (default 4,5,6,7)")
    parser.add_argument("--no-fem", action="store_true")
    parser.add_argument("--wall-mm", type=float, default=3.5)
    parser.add_argument("--max-mm", type=float, default=7.0)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = parser.parse_args()
    counts = [int(c) for c in args.counts.split(",")]
    print(f"cores: {len(os.sched_getaffinity(0))}; load average before: {os.getloadavg()}")
    print(f"sweep: fPN, chambers.count = {counts}, FE {'off' if args.no_fem else 'on'}"
          + ("" if args.no_fem else f", mesh {args.wall_mm}/{args.max_mm} mm"))
    results = []
    with tempfile.TemporaryDirectory(prefix="pnmold-bench-sweep-") as tmp:
        spec_path = Path(tmp) / "bench.toml"
        spec_path.write_text(SWEEP.format(counts=counts, fem=str(not args.no_fem).lower(), wall_mm=args.wall_mm,
                                          max_mm=args.max_mm))
        for workers in args.workers:
            r = bench(workers, spec_path, Path(tmp))
            results.append(r)
            rss = ", ".join(f"{v:.0f}" for v in r["peak_rss_mb"].values())
            print(f"{workers} worker(s): {r['points']} points in {r['wall_s']:.1f} s = {r['points_per_min']:.2f} "
                  f"points/min; per point {', '.join(f'{s:.0f}' for s in r['point_s'])} s; statuses "
                  f"{r['statuses']}; full bend {r['full_bend_kpa']} kPa; worker CPU {r['cpu_s']:.0f} s "
                  f"({100 * r['cpu_share']:.0f}% of {workers} core(s) over the wall); peak RSS per worker {rss} MB; "
                  f"load average now {os.getloadavg()}")
    base = results[0]
    for r in results[1:]:
        ratio = r["points_per_min"] / base["points_per_min"]
        busy = (r["cpu_s"] / r["wall_s"]) / (base["cpu_s"] / base["wall_s"])
        print(f"scaling {base['workers']} -> {r['workers']} workers: {ratio:.2f}x in points/min; "
              f"{busy:.2f}x the CPU kept busy (work per point varies with the FE's mesh)")
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(f"largest worker RSS (getrusage RUSAGE_CHILDREN): {children:.0f} MB")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
