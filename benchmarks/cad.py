"""Time CAD + export (STEP and STL of every part) for a template. Target: fpn under 30 s.

    .venv/bin/python benchmarks/cad.py [TEMPLATE] [--repeat N]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from pnmold.cad import export_parts, make_parts
from pnmold.design import load_design


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("template", nargs="?", default="fpn")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    design = load_design(args.template)
    cad, export = [], []
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            shapes = make_parts(design)
            t1 = time.perf_counter()
            export_parts(shapes, Path(tmp))
            t2 = time.perf_counter()
        cad.append(t1 - t0)
        export.append(t2 - t1)
    total = [a + b for a, b in zip(cad, export, strict=True)]
    print(f"template {args.template}: {len(shapes)} parts, {args.repeat} runs")
    print(f"cad     median {statistics.median(cad):.2f} s")
    print(f"export  median {statistics.median(export):.2f} s")
    print(f"total   median {statistics.median(total):.2f} s  (target < 30 s)")


if __name__ == "__main__":
    main()
