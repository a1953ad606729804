"""The design-rule gate: its time on the default fPN (with and without PrusaSlicer), and
random designs drawn over the design space (each refused, passed or failed).

    .venv/bin/python benchmarks/gate.py [--draws 200] [--seed 1]
"""

from __future__ import annotations

import argparse
import collections
import statistics
import sys
import tempfile
import time
import traceback
from pathlib import Path

from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pnmold.checks import check_parts  # noqa: E402
from pnmold.design import load_design  # noqa: E402
from pnmold.errors import DesignError  # noqa: E402
from pnmold.pipeline import build  # noqa: E402
from tests.strategies import design_overrides  # noqa: E402


def time_gate(tmp: Path) -> None:
    out = tmp / "fpn"
    build(load_design("fpn"), out, fem=False, use_slicer=False)
    for label, slicer in (("without slicer", False), ("with PrusaSlicer", True)):
        t0 = time.perf_counter()
        report = check_parts(out, use_slicer=slicer)
        dt = time.perf_counter() - t0
        print(f"gate on fpn {label}: {dt:.2f} s, {len(report.findings)} findings, "
              f"{len(report.failed)} failed, {len(report.skipped)} skipped"
              + ("  (target < 15 s)" if not slicer else ""))


def draws(n: int, seed: int, tmp: Path) -> None:
    rng = st.randoms(use_true_random=False)
    counts, times, failures, errors = collections.Counter(), [], collections.Counter(), []
    strategy = design_overrides()
    import random

    random.seed(seed)
    for i in range(n):
        overrides = strategy.example() if False else _draw(strategy, random.Random(seed * 100003 + i))
        t0 = time.perf_counter()
        try:
            design = load_design("fpn", overrides)
        except DesignError:
            counts["refused"] += 1
            continue
        try:
            result = build(design, tmp / f"draw{i}", fem=False, use_slicer=False)
        except Exception as err:  # anything but DesignError is a finding of this benchmark
            counts["error"] += 1
            errors.append((overrides, f"{type(err).__name__}: {err}", traceback.format_exc(limit=3)))
            continue
        times.append(time.perf_counter() - t0)
        failed = [c["id"] for c in result.report["checks"] if c["passed"] is False]
        counts["failed" if failed else "passed"] += 1
        for f in failed:
            failures[f.rsplit(".", 1)[0]] += 1
            if failures[f.rsplit(".", 1)[0]] == 1:
                print(f"  draw {i} failed {f}: {overrides}")
    del rng
    print(f"draws: {n}; refused {counts['refused']}, passed {counts['passed']}, "
          f"failed {counts['failed']}, other exceptions {counts['error']}")
    if times:
        print(f"mean time per built design: {statistics.mean(times):.2f} s (CAD, export, gate)")
    for check, k in failures.most_common():
        print(f"  failed check {check}: {k}")
    for overrides, message, _ in errors[:5]:
        print(f"  exception {message}: {overrides}")


def _draw(strategy, rnd):
    from hypothesis.internal.conjecture.data import ConjectureData

    data = ConjectureData(random=rnd, max_choices=10_000)
    return data.draw(strategy)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--draws", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        time_gate(Path(tmp))
        draws(args.draws, args.seed, Path(tmp))


if __name__ == "__main__":
    main()
