"""Findings of the design-rule gate: ``{id, passed, value, limit, message}``.

``passed`` is True or False, or None for a check that was skipped (the message says why);
a skipped check never counts as passed.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any


def _clean(value: Any) -> Any:
    if isinstance(value, float):
        return None if not math.isfinite(value) else round(value, 6)
    return value


@dataclass(frozen=True)
class Finding:
    id: str
    passed: bool | None
    value: Any
    limit: Any
    message: str

    def __post_init__(self):
        object.__setattr__(self, "passed", None if self.passed is None else bool(self.passed))
        for name in ("value", "limit"):
            v = getattr(self, name)
            if hasattr(v, "item") and getattr(v, "ndim", 1) == 0:
                object.__setattr__(self, name, v.item())

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["value"], d["limit"] = _clean(self.value), _clean(self.limit)
        d["status"] = {True: "passed", False: "failed", None: "skipped"}[self.passed]
        return d


def at_most(id: str, value: float, limit: float, what: str, unit: str = "") -> Finding:
    ok = value <= limit
    return Finding(id, ok, value, limit, f"{what}: {value:.4g}{unit} "
                   f"({'within' if ok else 'above'} the limit {limit:.4g}{unit})")


#: STL stores float32 coordinates: lengths measured on an exported part carry ~1e-5 mm
#: of rounding at 200 mm, so measured lengths are compared with this slack.
LENGTH_TOL_MM = 1e-4


def at_least(id: str, value: float, limit: float, what: str, unit: str = "", tol: float = 0.0) -> Finding:
    ok = value >= limit - tol
    return Finding(id, ok, value, limit, f"{what}: {value:.4g}{unit} "
                   f"({'meets' if ok else 'below'} the limit {limit:.4g}{unit})")


def equal(id: str, value: Any, expected: Any, what: str) -> Finding:
    ok = value == expected
    return Finding(id, ok, value, expected, f"{what}: {value} (expected {expected})")


@dataclass(frozen=True)
class CheckReport:
    findings: tuple[Finding, ...]

    @property
    def failed(self) -> list[Finding]:
        return [f for f in self.findings if f.passed is False]

    @property
    def skipped(self) -> list[Finding]:
        return [f for f in self.findings if f.passed is None]

    def by_id(self, id: str) -> Finding:
        return next(f for f in self.findings if f.id == id)

    def as_list(self) -> list[dict[str, Any]]:
        return [f.as_dict() for f in self.findings]
