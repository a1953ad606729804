"""``pnmold simulate``: the quasi-static response of a design, as JSON and as a recording.

The FE model (``--model fe``) builds the design's CAD, meshes the exported STEP and solves
the pressure curve (free bending, or blocked force against a plane at the tip). Cycles
repeat the elastic curve (inflate, then deflate); the FE has no rate or history effects.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pnmold.design import Design, digest
from pnmold.errors import UsageError

SCHEMA = "pnmold.simulation/1"
KINDS = ("bending", "pv", "force")


@dataclass(frozen=True)
class SimulationRequest:
    pressures_kpa: tuple[float, ...]
    model: str = "fe"
    kind: str = "bending"
    cycles: int = 1
    orientation: str = "chambers_up"
    effects: tuple[tuple[str, float], ...] = ()


def parse_pressures(text: str) -> tuple[float, ...]:
    """``A:B:STEP`` -> (A, A+STEP, ..., B) in kPa."""
    try:
        a, b, step = (float(x) for x in text.split(":"))
    except ValueError:
        raise UsageError(f"--pressures: expected A:B:STEP in kPa, got {text!r}") from None
    if not (step > 0 and b > a >= 0 and math.isfinite(b)):
        raise UsageError(f"--pressures: need 0 <= A < B and STEP > 0, got {text!r}")
    n = int(math.floor((b - a) / step + 1e-9))
    values = [a + i * step for i in range(n + 1)]
    if values[-1] < b - 1e-9:
        values.append(b)
    return tuple(round(v, 9) for v in values)


def parse_effects(text: str | None) -> tuple[tuple[str, float], ...]:
    if not text:
        return ()
    out = []
    for item in text.split(","):
        if "=" not in item:
            raise UsageError(f"--effects: expected NAME=VALUE, got {item!r}")
        name, value = item.split("=", 1)
        try:
            out.append((name.strip(), float(value)))
        except ValueError:
            raise UsageError(f"--effects: {name.strip()} needs a number, got {value!r}") from None
    return tuple(out)


def _gravity_orientation(request: SimulationRequest) -> str:
    effects = dict(request.effects)
    unknown = set(effects) - {"gravity"}
    if unknown:
        raise UsageError(f"--effects: {', '.join(sorted(unknown))} not available in the FE model of this version "
                         "(available: gravity)")
    if effects.get("gravity", 1.0) == 0.0:
        return "none"
    if effects.get("gravity", 1.0) != 1.0:
        raise UsageError("--effects: the FE model takes gravity=0 or gravity=1 (Earth's gravity)")
    return request.orientation


def simulate_fe(design: Design, request: SimulationRequest) -> dict[str, Any]:
    """Solve with the FE model; return the ``pnmold.simulation/1`` document."""
    from pnmold.cad import export_parts, make_parts
    from pnmold.fem import solve_blocked_force
    from pnmold.mesh import mesh_actuator
    from pnmold.quickfe import gravity_vector, material_of, membrane_of, run_fe

    orientation = _gravity_orientation(request)
    with tempfile.TemporaryDirectory() as tmp:
        shapes = make_parts(design)
        export_parts({"actuator": shapes["actuator"]}, Path(tmp))
        step = Path(tmp) / "actuator.step"
        targets = [p for p in request.pressures_kpa if p > 0]
        if request.kind == "force":
            mesh, _ = mesh_actuator(step, design)
            sol = solve_blocked_force(mesh, material_of(design), membrane_of(design), pressures_kpa=targets,
                                      gravity=gravity_vector(design, orientation))
        else:
            sol = run_fe(design, step, orientation=orientation, pressures_kpa=targets).solution
    wanted = set(np.round(request.pressures_kpa, 6))
    inflate = [s.as_dict() for s in sol.steps if round(s.pressure_kpa, 6) in wanted]
    steps = _cycled(inflate, request.cycles)
    return {"schema": SCHEMA, "design": {"name": design.name, "digest": digest(design)}, "model": "fe",
            "kind": request.kind, "orientation": orientation, "effects": dict(request.effects),
            "steps": steps,
            "full_bend_pressure_kpa": sol.full_bend_pressure_kpa, "reason": sol.reason}


def _cycled(inflate: list[dict[str, Any]], cycles: int) -> list[dict[str, Any]]:
    out = []
    for c in range(1, cycles + 1):
        out += [{**s, "cycle": c, "phase": "inflate"} for s in inflate]
        out += [{**s, "cycle": c, "phase": "deflate"} for s in reversed(inflate[:-1])] if cycles > 1 else []
    return out


def recording_columns(doc: dict[str, Any]) -> dict[str, np.ndarray]:
    """The lab-format columns (CONTRACTS.md §4) of a simulation's steps."""
    steps = doc["steps"]
    col = {k: np.array([s[k] for s in steps], float) for k in steps[0] if not isinstance(steps[0][k], str | list)}
    out: dict[str, np.ndarray] = {}
    if doc["kind"] == "bending":
        for k in ("pressure_kpa", "tip_x_mm", "tip_z_mm", "bend_angle_deg"):
            out[k] = col[k]
    elif doc["kind"] == "pv":
        out["volume_ml"] = col["cavity_volume_ml"] - col["cavity_volume_ml"][0]  # injected volume
        out["pressure_kpa"] = col["pressure_kpa"]
    else:
        out["pressure_kpa"] = col["pressure_kpa"]
        out["force_n"] = col["force_n"]
    if "cycle" in steps[0]:
        out["cycle"] = np.array([s["cycle"] for s in steps], int)
        out["phase"] = np.array([s["phase"] for s in steps], dtype=object)
    return out
