"""A sweep's points: the grid (cartesian product of the axes, in file order) or ``n``
random draws (seeded: uniform within a continuous range, a choice from a list).

Each point is keyed by a stable hash of its overrides, the base design's digest and the
run options that change results (FE on/off, mesh, pressure limit): the same point is the
same key in every run, so finished points are never computed twice.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import random
from dataclasses import dataclass
from typing import Any

from pnmold.sweep.spec import Axis, RunOptions, SweepSpec

#: random draws from a continuous range are rounded to this many decimals (of the field's unit)
DRAW_DECIMALS = 6


@dataclass(frozen=True)
class Point:
    """One design of the sweep: ``values`` are (field, value) pairs in axis order."""

    key: str
    values: tuple[tuple[str, Any], ...]

    @property
    def overrides(self) -> list[str]:
        """As ``--set`` texts, for :func:`pnmold.design.load_design`."""
        return [f"{field}={toml_value(value)}" for field, value in self.values]

    def as_dict(self) -> dict[str, Any]:
        return dict(self.values)


def toml_value(value: Any) -> str:
    """A TOML literal of an int, float or string."""
    if isinstance(value, str):
        return json.dumps(value)
    return repr(value)


def point_key(base_digest: str, values: tuple[tuple[str, Any], ...], run: RunOptions) -> str:
    """Stable 16-hex-digit hash of the resolved overrides, base digest and run options."""
    blob = json.dumps({"base": base_digest, "overrides": sorted(values), "run": run.key_part()},
                      sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def _draw(axis: Axis, rng: random.Random) -> Any:
    if not axis.continuous:
        return rng.choice(axis.values)
    if axis.kind == "int":
        return rng.randint(int(axis.low), int(axis.high))
    return round(rng.uniform(axis.low, axis.high), DRAW_DECIMALS)


def expand_points(spec: SweepSpec) -> list[Point]:
    """Every point of ``spec``, duplicates (repeated random draws) dropped, order kept."""
    if spec.sampling == "grid":
        combos = itertools.product(*(a.values for a in spec.axes))
    else:
        rng = random.Random(spec.seed)
        combos = (tuple(_draw(a, rng) for a in spec.axes) for _ in range(spec.n))
    points: dict[str, Point] = {}
    for combo in combos:
        values = tuple(zip(spec.fields, combo, strict=True))
        key = point_key(spec.base_digest, values, spec.run)
        points.setdefault(key, Point(key, values))
    return list(points.values())
