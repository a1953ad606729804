"""``pnmold sweep``: many designs from a sweep file, results in SQLite (resumable)."""

from __future__ import annotations

import contextlib

from rich.markup import escape

from pnmold.cli._common import err_console, out_console
from pnmold.errors import EXIT_INTERRUPTED

HELP = "many designs from a sweep file, results in SQLite"
DESCRIPTION = ("Build every point of a sweep file (a base design and axes over its fields, grid or random) on "
               "local processes or a Dask cluster; one SQLite row per point, committed as it arrives; re-running "
               "skips finished points.")


def add_args(parser) -> None:
    parser.add_argument("sweep", metavar="SWEEP.toml", help="the sweep file (see templates/sweeps/)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="Dask scheduler, e.g. tcp://host:8786 (default: local processes)")
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help="local worker processes (default: the number of cores)")
    parser.add_argument("--db", metavar="FILE", help="results database (default out/sweeps/<sweep-name>.sqlite)")
    parser.add_argument("--export", choices=["csv"], help="also write the table beside the database")


def run(args) -> int:
    from pnmold.sweep import default_db, finish_sweep, load_sweep
    from pnmold.sweep.progress import SweepProgress

    spec = load_sweep(args.sweep)
    db = args.db or default_db(spec.name)
    view = contextlib.nullcontext(None) if args.quiet else SweepProgress(err_console, spec.name)
    try:
        with view as bar:
            done = finish_sweep(spec, db=db, scheduler=args.scheduler, workers=args.workers, export=args.export,
                                on_update=bar)
    except KeyboardInterrupt:
        err_console.print(f"interrupted: finished points are in {db}; run the same command to resume")
        return EXIT_INTERRUPTED
    if not args.quiet:
        result = done.result
        statuses = [r["status"] for r in result.rows]
        tally = ", ".join(f"{statuses.count(s)} {s}" for s in ("ok", "check_failed", "refused", "failed"))
        for row in result.rows[:40]:
            inputs = ", ".join(f"{f}={row[f]}" for f in result.spec.fields)
            bend = row["full_bend_pressure_kpa"]
            what = f"full bend {bend:.1f} kPa" if bend is not None else (row["error"] or row["reason"] or "")
            out_console.print(f"  {inputs}: {row['status']}, {escape(what)}")
        out_console.print(f"{result.spec.name}: {len(result.points)} points ({tally}); {result.counts.done} computed "
                          f"now, {result.counts.skipped} already done; wrote {', '.join(map(str, done.written))}")
    return 0
