"""Long recordings: `pnmold diagnose`, `pnmold recording check` and `pnmold simulate --recording` on a
logger's worth of rows (a 1 kHz logger on a slow quasi-static ramp), in time and peak memory.

The recordings are made through the public verbs: `pnmold simulate fpn --model rom --kind bending` gives
three inflation-deflation cycles at 1 kPa steps (with ``--effects``, default a concealed Mullins softening),
once noise-free and once with 0.3 mm of noise (the *small* recording, 241 rows, diagnosed as the
reference). Each long recording resamples the noise-free one to N rows as a 1 kHz logger would see the
same three cycles: each ramp gets its share of the rows, the pressure runs linearly through it with 0.02 kPa
of transducer noise, the tip and the bend angle are read off the ramp's own curve at that pressure with
0.3 mm (0.3 deg) of noise, ``time_s`` is the row over 1000 and ``cycle`` and ``phase`` are kept. Then each
verb runs as a subprocess under ``/usr/bin/time -v``: the rows, the wall time, the peak resident memory and
what it said (the diagnosis's verdict: the effects named, unexplained or not, the calibrated modulus, the rows
it read). `simulate` writes a one-inflation recording of N rows (``--pressures 0:40:STEP``).

    .venv/bin/python benchmarks/big_recording.py [--out out/big] [--rows 100000 1000000]
        [--effects mullins=0.3] [--verbs check diagnose simulate]
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pnmold.recording import read_recording  # noqa: E402

PNMOLD = [sys.executable, "-m", "pnmold.cli"]
DESIGN = "fpn"
P_MAX_KPA = 40.0
CYCLES = 3
NOISE_MM, NOISE_DEG, NOISE_KPA = 0.3, 0.3, 0.02
LOGGER_HZ = 1000.0
WRITE_ROWS = 100_000  # rows formatted at once while writing a long recording


def pnmold(*argv: str) -> None:
    subprocess.run([*PNMOLD, *argv], check=True, cwd=ROOT)


def make_small(out: Path, effects: str) -> tuple[Path, Path]:
    """The noise-free curve and the small noisy recording, through `pnmold simulate`."""
    clean, small = out / "clean.csv", out / "small.csv"
    base = ["simulate", DESIGN, "--model", "rom", "--kind", "bending", "--pressures", f"0:{P_MAX_KPA:g}:1",
            "--cycles", str(CYCLES), "-q", *(["--effects", effects] if effects else [])]
    pnmold(*base, "--recording", str(clean))
    pnmold(*base, "--recording", str(small), "--noise-mm", str(NOISE_MM), "--seed", "1")
    return clean, small


def resample(clean: Path, rows: int, path: Path, seed: int = 0) -> Path:
    """``clean`` as a 1 kHz logger would record it in ``rows`` rows (the module docstring), written in chunks."""
    rec = read_recording(clean)
    p = rec["pressure_kpa"]
    cycle, phase = rec["cycle"], rec["phase"]
    ramps = [np.flatnonzero((cycle == c) & (phase == ph)) for c in np.unique(cycle) for ph in ("inflate", "deflate")]
    ramps = [r for r in ramps if r.size]
    share = np.array([r.size for r in ramps], float)
    counts = np.floor(share / share.sum() * rows).astype(int)
    counts[-1] += rows - counts.sum()
    rng = np.random.default_rng(seed)
    meta = {"pnmold-recording": "1", "kind": "bending", "design": DESIGN, "orientation": rec.orientation}
    columns = ["time_s", "pressure_kpa", "tip_x_mm", "tip_z_mm", "bend_angle_deg", "cycle", "phase"]
    row0 = 0
    with open(path, "w", encoding="utf-8") as f:
        f.write("".join(f"# {k}: {v}\n" for k, v in meta.items()) + ",".join(columns) + "\n")
        for idx, n in zip(ramps, counts, strict=True):
            # a deflation starts where the inflation before it ended (that row is the inflation's)
            path_rows = np.concatenate([[idx[0] - 1], idx]) if phase[idx[0]] == "deflate" else idx
            q = p[path_rows]
            for a in range(0, n, WRITE_ROWS):
                m = min(WRITE_ROWS, n - a)
                t = (np.arange(a, a + m) + 0.5) / n
                p_true = np.interp(t * (q.size - 1), np.arange(q.size), q)
                cols = {"time_s": (row0 + a + np.arange(m)) / LOGGER_HZ,
                        "pressure_kpa": np.maximum(p_true + rng.normal(0, NOISE_KPA, m), 0.0)}
                order = np.argsort(q, kind="stable")
                for name, noise in (("tip_x_mm", NOISE_MM), ("tip_z_mm", NOISE_MM), ("bend_angle_deg", NOISE_DEG)):
                    y = rec[name][path_rows]
                    cols[name] = np.interp(p_true, q[order], y[order]) + rng.normal(0, noise, m)
                text = np.column_stack([np.char.mod("%.4f", cols[c]) for c in columns[:5]])
                tail = f",{int(cycle[idx[0]])},{phase[idx[0]]}\n"
                f.write(tail.join(",".join(r) for r in text) + tail)
            row0 += n
    return path


def timed(argv: list[str]) -> dict:
    """Run ``pnmold argv`` under /usr/bin/time -v: wall s, peak RSS MB, exit code, standard output."""
    run = subprocess.run(["/usr/bin/time", "-v", *PNMOLD, *argv], cwd=ROOT, capture_output=True, text=True)
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", run.stderr)
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", run.stderr)
    seconds = sum(float(x) * 60 ** i for i, x in enumerate(reversed(wall.group(1).split(":")))) if wall else None
    return {"wall_s": seconds, "rss_mb": int(rss.group(1)) / 1024 if rss else None, "exit": run.returncode,
            "out": run.stdout, "err": run.stderr}


def verdict(doc: dict) -> str:
    named = ", ".join(f"{m['effect']} {next(iter(m['parameters'].values())):.3g}" for m in doc["missing_physics"])
    reduced = doc["recordings"][0].get("reduction")
    read = f"read {reduced['rows']} of {reduced['rows_recorded']} rows" if reduced else "read as recorded"
    return (f"named {named or 'nothing'}; unexplained {str(doc['unexplained']).lower()}; modulus x "
            f"{doc['calibration']['final']['modulus_scale']:.3f}; {read}")


def report(label: str, rows: int, run: dict, said: str) -> None:
    wall = f"{run['wall_s']:7.1f}" if run["wall_s"] is not None else "      -"
    rss = f"{run['rss_mb']:7.0f}" if run["rss_mb"] is not None else "      -"
    print(f"{label:<10} {rows:>9} {wall} {rss} exit {run['exit']}  {said}", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="out/big", help="folder for the recordings and JSON (default out/big)")
    parser.add_argument("--rows", type=int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--effects", default="mullins=0.3", help="concealed effects (NAME=VALUE,...; '' for none)")
    parser.add_argument("--verbs", nargs="+", default=["check", "diagnose", "simulate"],
                        choices=["check", "diagnose", "simulate"])
    args = parser.parse_args(argv)
    out = (ROOT / args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    clean, small = make_small(out, args.effects)
    print(f"{'verb':<10} {'rows':>9} {'wall s':>7} {'RSS MB':>7}")
    if "diagnose" in args.verbs:
        run = timed(["diagnose", DESIGN, str(small), "--json", str(out / "small.json"), "-q"])
        said = verdict(json.loads((out / "small.json").read_text())) if run["exit"] == 0 else run["err"][-300:]
        report("diagnose", len(read_recording(small)), run, said)
    for rows in args.rows:
        big = resample(clean, rows, out / f"bending-{rows}.csv")
        if "check" in args.verbs:
            run = timed(["recording", "check", str(big)])
            kept = re.search(r"reduced to (\d+) rows", " ".join(run["out"].split()))
            report("check", rows, run, (f"read; a diagnosis reads {kept.group(1) if kept else rows} rows of it"
                                        if run["exit"] == 0 else run["err"][-300:]))
        if "diagnose" in args.verbs:
            path = out / f"bending-{rows}.json"
            run = timed(["diagnose", DESIGN, str(big), "--json", str(path), "-q"])
            report("diagnose", rows, run, verdict(json.loads(path.read_text())) if run["exit"] == 0
                   else run["err"][-300:])
        if "simulate" in args.verbs:
            sim = out / f"simulate-{rows}.csv"
            run = timed(["simulate", DESIGN, "--model", "rom", "--kind", "bending", "--pressures",
                         f"0:{P_MAX_KPA:g}:{P_MAX_KPA / (rows - 1)!r}", "--recording", str(sim), "-q"])
            written = sum(1 for line in open(sim) if line[:1].isdigit()) if run["exit"] == 0 else 0
            report("simulate", rows, run, f"wrote {written} rows" if run["exit"] == 0 else run["err"][-300:])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
