"""Fault injection through the command line: bad inputs, unwritable outputs, folders of a lab's own
files, Ctrl-C at several moments, and one deliberately injected bug.

Every case runs ``python -m pnmold.cli ...`` in a scratch folder of its own holding a lab's files (a
recording, a notes file, a sub-folder of camera data). After the run every file that was there
before must still be there byte for byte ("files lost"), standard error must hold no Python
traceback, and exit 70 (a bug) may come only from the injected bug. Prints one line per case and
the totals; exits 1 when any of the three fails.

    .venv/bin/python benchmarks/faults.py [--only SUBSTRING] [--workers 2]
"""

from __future__ import annotations

import argparse
import os
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"
PY = sys.executable
GOOD = ("# pnmold-recording: 1\n# kind: bending\npressure_kpa,tip_x_mm,tip_z_mm\n"
        + "".join(f"{p},{100 - p / 4:.2f},{-p * 1.5:.2f}\n" for p in range(0, 40, 4)))
BUG = ("import sys; import pnmold.cli.templates as t; t.run = lambda args: 1 / 0; "
       "from pnmold.cli import main; sys.exit(main(['templates']))")


@dataclass(frozen=True)
class Case:
    name: str
    argv: tuple[str, ...]          # after `python -m pnmold.cli`; "{d}" is the scratch folder
    files: tuple[tuple[str, str | bytes], ...] = ()  # extra input files to make first
    codes: tuple[int, ...] = (2,)  # the exit codes the case expects
    interrupt_s: float | None = None
    env: tuple[tuple[str, str], ...] = ()
    script: str | None = None      # run `python -c script` instead of the command line


def _cases() -> list[Case]:
    rec = (("r.csv", GOOD),)
    bad_rows = {
        "no header": "# kind: bending\n",
        "missing column": "pressure_kpa,tip_x_mm\n0,100\n10,90\n",
        "text cell": "pressure_kpa,tip_x_mm,tip_z_mm\n0,100,0\n10,abc,-5\n",
        "nan": "pressure_kpa,tip_x_mm,tip_z_mm\n0,100,0\n10,nan,-5\n",
        "short row": "pressure_kpa,tip_x_mm,tip_z_mm\n0,100,0\n10,90\n",
        "one row": "pressure_kpa,tip_x_mm,tip_z_mm\n0,100,0\n",
        "unknown kind": "# kind: twist\npressure_kpa,tip_x_mm,tip_z_mm\n0,100,0\n10,90,-5\n",
        "time backwards": "time_s,supply_kpa,pressure_kpa\n0,0,0\n1,10,5\n0.5,10,8\n",
        "bad orientation": "# orientation: sideways\npressure_kpa,tip_x_mm,tip_z_mm\n0,100,0\n10,90,-5\n",
        "empty": "",
    }
    cases = [Case(f"recording: {k}", ("diagnose", "fpn", "{d}/bad.csv"), (("bad.csv", v),))
             for k, v in bad_rows.items()]
    cases += [Case(f"recording check: {k}", ("recording", "check", "{d}/bad.csv"), (("bad.csv", v),))
              for k, v in bad_rows.items()]
    cases += [
        Case("recording: binary", ("diagnose", "fpn", "{d}/bad.csv"), (("bad.csv", bytes(range(256))),)),
        Case("recording: latin-1", ("recording", "check", "{d}/bad.csv"),
             (("bad.csv", "pressure_kpa,tip_x_mm,tip_z_mm\n0,100,0\n10,90,-5\n# \xe9\n".encode("latin-1")),)),
        Case("recording: a folder", ("diagnose", "fpn", "{d}/raw")),
        Case("recording: absent", ("diagnose", "fpn", "{d}/nosuch.csv")),
        Case("design: unknown template", ("build", "nosuch", "--out", "{d}/b")),
        Case("design: bad toml", ("build", "{d}/x.toml", "--out", "{d}/b"), (("x.toml", "[chambers\ncount=3"),)),
        Case("design: negative wall", ("build", "--set", "chambers.outer_wall_mm=-1", "--out", "{d}/b")),
        Case("design: unknown key", ("build", "--set", "chambers.colour=3", "--out", "{d}/b")),
        Case("design: text for a number", ("build", "--set", "chambers.count=many", "--out", "{d}/b")),
        Case("design: conflicting --set", ("build", "--set", "chambers.count=6", "--set", "chambers.count=7",
                                           "--out", "{d}/b")),
        Case("simulate: bad pressures", ("simulate", "fpn", "--model", "rom", "--pressures", "10:0:x")),
        Case("simulate: unknown effect", ("simulate", "fpn", "--model", "rom", "--effects", "magic=1")),
        Case("tensile: absent", ("material", "fit", "{d}/nosuch.csv")),
        Case("tensile: no numbers", ("material", "fit", "{d}/t.csv"),
             (("t.csv", "eng_strain,eng_stress_mpa\na,b\n"),)),
        Case("tensile: one point", ("material", "fit", "{d}/t.csv"),
             (("t.csv", "eng_strain,eng_stress_mpa\n0.1,0.01\n"),)),
        Case("sweep: bad file", ("sweep", "{d}/s.toml", "--db", "{d}/s.sqlite"), (("s.toml", "[sweep]\nname=\n"),)),
        Case("check: not a build", ("check", "{d}/raw")),
        Case("report: not a build", ("report", "{d}/raw")),
        Case("export: not a build", ("export", "{d}/raw")),
        Case("unknown verb", ("frobnicate",)),
        Case("unknown option", ("build", "--frobnicate")),
        Case("docs: unknown page", ("docs", "nosuch")),
        # outputs: a lab's folder, the working folder, a file, a foreign database, unwritable places
        Case("build --out the lab's folder", ("build", "--out", "{d}", "--no-fem")),
        Case("build --out .", ("build", "--out", ".", "--no-fem")),
        Case("build --out a file", ("build", "--out", "{d}/notes.txt", "--no-fem")),
        Case("build --out a sub-folder of camera data", ("build", "--out", "{d}/raw", "--no-fem")),
        Case("diagnose --report the recording's folder", ("diagnose", "fpn", "{d}/r.csv", "--report", "{d}"), rec),
        Case("export --out the lab's folder", ("export", "{d}/raw", "--out", "{d}")),
        Case("sweep --db a lab's SQLite", ("sweep", str(ROOT / "templates/sweeps/fig-s2a.toml"), "--db",
                                            "{d}/lab.sqlite")),
        Case("sweep --db a text file", ("sweep", str(ROOT / "templates/sweeps/fig-s2a.toml"), "--db",
                                         "{d}/notes.txt")),
        Case("PNMOLD_CACHE at the lab's folder", ("simulate", "fpn", "--model", "rom", "--pressures", "0:20:10"),
             env=(("PNMOLD_CACHE", "{d}"),)),
        Case("--json at a folder", ("effects", "--json", "{d}/raw"), codes=(74,)),
        Case("--json under a file", ("effects", "--json", "{d}/notes.txt/x.json"), codes=(74,)),
        Case("--json in /proc", ("effects", "--json", "/proc/pnmold.json"), codes=(74,)),
        Case("--recording at a folder", ("simulate", "fpn", "--model", "rom", "--kind", "bending",
                                          "--recording", "{d}/raw"), codes=(74,)),
        Case("checklist --out at a folder", ("checklist", "fpn", "--out", "{d}/raw"), codes=(74,)),
        Case("material fit --json under a file", ("material", "fit", str(SHARED / "ecoflex0030_uniaxial_tension.csv"),
                                                 "--json", "{d}/notes.txt/f.json"), codes=(74,)),
        # doubtful input: refused or read with the reason
        Case("recording: one pressure", ("diagnose", "fpn", "{d}/bad.csv"),
             (("bad.csv", "pressure_kpa,tip_x_mm,tip_z_mm\n10,90,-5\n10,90.2,-5.1\n10,89.9,-4.9\n"),)),
        Case("recording: every pressure negative", ("diagnose", "fpn", "{d}/bad.csv"),
             (("bad.csv", "pressure_kpa,tip_x_mm,tip_z_mm\n-5,90,-5\n-10,80,-10\n-20,70,-20\n"),)),
        Case("recording: a European spreadsheet", ("recording", "check", "{d}/eu.csv"),
             (("eu.csv", "\ufeffpressure_kpa;tip_x_mm;tip_z_mm\r\n0;100,5;0\r\n10,5;90,25;-5,5\r\n"),), (0,)),
        Case("recording: tab-separated", ("recording", "check", "{d}/tab.csv"),
             (("tab.csv", "pressure_kpa\ttip_x_mm\ttip_z_mm\n0\t100\t0\n10\t90\t-5\n"),), (0,)),
        Case("tensile: percent strain in a ratio column", ("material", "fit", "{d}/t.csv"),
             (("t.csv", "eng_strain,eng_stress_mpa\n" + "".join(f"{e},{0.003 * e:.4f}\n"
                                                                  for e in range(0, 600, 50))),)),
        Case("design: a 96 MPa rubber", ("build", "--out", "{d}/b", "--set", "material.name=Labsil", "--set",
                                         "material.c10_mpa=96", "--set", "material.c20_mpa=0", "--set",
                                         "material.c30_mpa=0", "--set", "material.density_g_per_ml=1.1", "--set",
                                         "material.mix_ratio_a_to_b=10")),
        Case("simulate: 1 GPa with the reduced model", ("simulate", "fpn", "--model", "rom", "--pressures",
                                                         "0:1000000:250000"), codes=(0,)),
        Case("diagnose --report a file", ("diagnose", "fpn", "{d}/r.csv", "--report", "{d}/notes.txt")),
        Case("build --out pnmold's folder holding a lab file", ("build", "--out", "{d}/b", "--no-fem"),
             (("b/.pnmold-output", '{"schema": "pnmold.output/1", "what": "build", "files": ["a.txt"]}'),
              ("b/a.txt", "pnmold's"), ("b/lab.csv", "the lab's"))),
        # good runs next to the lab's files: nothing of theirs touched
        Case("simulate --recording beside the lab's files", ("simulate", "fpn", "--model", "rom", "--kind", "bending",
                                                             "--recording", "{d}/new.csv"), codes=(0,)),
        Case("diagnose --report a new folder", ("diagnose", "fpn", "{d}/r.csv", "--report", "{d}/diag"), rec, (0,)),
        # Ctrl-C at several moments of a build, and the injected bug
        *(Case(f"Ctrl-C at {t:g} s", ("build", "--out", "{d}/b"), codes=(130,), interrupt_s=t)
          for t in (0.3, 1.5, 4, 9)),
        Case("injected bug", (), codes=(70,), script=BUG),
    ]
    return cases


def _scratch(case: Case) -> Path:
    d = Path(tempfile.mkdtemp(prefix="pnmold-fault-"))
    (d / "raw").mkdir()
    (d / "raw" / "cam.bin").write_bytes(os.urandom(4096))
    (d / "notes.txt").write_text("the lab's notes\n")
    (d / "r.csv").write_text(GOOD)
    with sqlite3.connect(d / "lab.sqlite") as con:
        con.execute("CREATE TABLE samples (id INTEGER, value REAL)")
    for name, data in case.files:
        (d / name).parent.mkdir(parents=True, exist_ok=True)
        (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())
    return d


def _snapshot(d: Path) -> dict[str, bytes]:
    return {p.relative_to(d).as_posix(): p.read_bytes() for p in d.rglob("*") if p.is_file()}


def run_case(case: Case) -> dict:
    d = _scratch(case)
    before = _snapshot(d)
    fill = [a.replace("{d}", str(d)) for a in case.argv]
    cmd = [PY, "-c", case.script] if case.script else [PY, "-m", "pnmold.cli", "--quiet", *fill]
    env = {**os.environ, **{k: v.replace("{d}", str(d)) for k, v in case.env}}
    env.setdefault("PNMOLD_CACHE", str(Path(tempfile.gettempdir()) / "pnmold-faults-cache"))
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    if case.interrupt_s is not None:
        try:
            proc.wait(timeout=case.interrupt_s)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGINT)
    try:
        out, err = proc.communicate(timeout=600)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
    after = _snapshot(d)
    lost = sorted(k for k, v in before.items() if after.get(k) != v)
    return {"case": case.name, "code": proc.returncode, "expected": case.codes, "lost": lost,
            "traceback": "Traceback (most recent call last)" in err, "seconds": time.perf_counter() - t0,
            "message": (err.strip().splitlines() or [""])[-1][:150], "injected": case.script is not None,
            "scratch": d}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="run only the cases whose name holds this")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--keep", action="store_true", help="keep the scratch folders")
    args = parser.parse_args()
    cases = [c for c in _cases() if not args.only or args.only in c.name]
    with ThreadPoolExecutor(args.workers) as pool:
        results = list(pool.map(run_case, cases))
    for r in results:
        flag = "ok " if r["code"] in r["expected"] and not r["lost"] and not r["traceback"] else "BAD"
        print(f"{flag} {r['code']:>3} {r['seconds']:6.1f} s  {r['case']}: {r['message']}"
              + (f"  LOST {r['lost']}" if r["lost"] else ""))
        if not args.keep:
            import shutil

            shutil.rmtree(r["scratch"], ignore_errors=True)
    lost = sum(len(r["lost"]) for r in results)
    tracebacks = sum(r["traceback"] for r in results)
    bugs = sum(r["code"] == 70 and not r["injected"] for r in results)
    caught = sum(r["code"] == 70 and r["injected"] for r in results)
    unexpected = sum(r["code"] not in r["expected"] for r in results)
    print(f"\n{len(results)} cases: files lost {lost}, tracebacks {tracebacks}, exit 70 outside the injected bug "
          f"{bugs} (the injected bug: {'exit 70' if caught else 'NOT exit 70'}), exit code other than expected "
          f"{unexpected}")
    return 1 if lost or tracebacks or bugs or unexpected else 0


if __name__ == "__main__":
    sys.exit(main())
