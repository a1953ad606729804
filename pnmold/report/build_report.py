"""The build report ``report.json`` (schema ``pnmold.build/1``, docs/json-schemas.md) and its parts: what
was built (parts measured on the exported files), the gate's findings, the pours; the FE's section comes
from :mod:`pnmold.report.fem`."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path
from typing import Any

from pnmold.checks import CheckReport
from pnmold.checks.stlio import load_stl
from pnmold.design import Design, digest
from pnmold.version import __version__

SCHEMA = "pnmold.build/1"
_VERSIONED = ("cadquery", "trimesh", "manifold3d", "gmsh", "scikit-fem", "numpy", "scipy")


def versions() -> dict[str, str]:
    out = {}
    for name in _VERSIONED:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def measure_parts(out_dir: Path, names: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """Volume, bounding box and watertightness of each exported STL, read back from disk."""
    parts = {}
    for name in names:
        mesh = load_stl(Path(out_dir) / f"{name}.stl")
        parts[name] = {
            "files": [f"{name}.step", f"{name}.stl"],
            "volume_mm3": round(float(mesh.volume), 4),
            "bbox_mm": [[round(float(v), 4) for v in row] for row in mesh.bounds],
            "watertight": bool(mesh.is_watertight),
            "faces": int(len(mesh.faces)),
        }
    return parts


def pours(design: Design, parts: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """Elastomer per pour: the cast volume and mass, and part A / part B to mix.

    ``volume_ml`` and ``mass_g`` are the cast elastomer (the paper's volume excluded), each pour
    of its own rubber (the bottom layer's: ``[layer_material]`` when named); ``part_a_g`` and
    ``part_b_g`` split ``mix_g`` = mass x (1 + casting.waste_margin) by that rubber's A:B mix
    ratio by weight.
    """
    margin = design.casting.waste_margin
    paper_mm3 = parts["paper"]["volume_mm3"] if "paper" in parts else 0.0
    cast = [("mold_exterior+mold_interior", "top_layer", parts["top_layer"]["volume_mm3"], design.material),
            ("mold_bottom", "bottom_layer", parts["bottom_layer"]["volume_mm3"] - paper_mm3, design.bottom_material)]
    if "passive_layer" in parts:  # a second top layer from the same molds
        cast.append(("mold_exterior+mold_interior", "passive_layer", parts["passive_layer"]["volume_mm3"],
                     design.material))
    out = []
    for mold, part, volume_mm3, m in cast:
        volume_ml = volume_mm3 / 1000.0
        mass_g = volume_ml * m.density_g_per_ml
        mix_g = mass_g * (1.0 + margin)
        a = mix_g * m.mix_ratio_a_to_b / (m.mix_ratio_a_to_b + 1.0)
        out.append({"mold": mold, "part": part,
                    "material": m.name, "volume_ml": round(volume_ml, 4), "mass_g": round(mass_g, 4),
                    "waste_margin": margin, "mix_g": round(mix_g, 4),
                    "part_a_g": round(a, 4), "part_b_g": round(mix_g - a, 4)})
    return out


def design_entry(design: Design) -> dict[str, str]:
    return {"name": design.name, "kind": design.kind, "digest": digest(design),
            "material": design.material.name}


def new_report(design: Design, parts: dict[str, dict[str, Any]], timings_s: dict[str, float]) -> dict[str, Any]:
    """A build's report before its checks and FE: the design, the library versions, the parts and
    pours; ``timings_s`` is the build's own dict of stage times (filled in as the stages run)."""
    return {
        "schema": SCHEMA,
        "pnmold_version": __version__,
        "design": design_entry(design),
        "versions": versions(),
        "parts": parts,
        "checks": [],
        "fem": {"full_bend_pressure_kpa": None, "reason": "quick FE not run", "max_pressure_kpa": None, "steps": []},
        "pours": pours(design, parts),
        "timings_s": timings_s,
    }


def slicer_summary(checks: list[dict[str, Any]]) -> dict[str, Any]:
    """PrusaSlicer's estimates per mold, from the slicer findings."""
    return {c["id"].removeprefix("print.slicer."): (c["value"] if c["passed"] else {"status": c["status"],
            "message": c["message"]}) for c in checks if c["id"].startswith("print.slicer.")}


def record_checks(report: dict[str, Any], checks: CheckReport) -> dict[str, Any]:
    """``report`` with the gate's findings and the slicer's estimates (a new dict)."""
    found = checks.as_list()
    return {**report, "checks": found, "slicer": slicer_summary(found)}
