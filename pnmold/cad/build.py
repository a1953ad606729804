"""Make every part of a design and export each as STEP and binary STL."""

from __future__ import annotations

import logging
import os
from pathlib import Path

import cadquery as cq

from pnmold.cad import molds, parts
from pnmold.conventions import USES
from pnmold.design import Design
from pnmold.errors import ExportError
from pnmold.fsutil import atomic_path

log = logging.getLogger(__name__)

__all__ = ["export_actuator_step", "export_parts", "make_parts"]

#: STL tessellation: absolute chordal deviation (mm) and angular deviation (rad).
STL_TOLERANCE_MM = 0.005
STL_ANGULAR_RAD = 0.05


def make_parts(design: Design) -> dict[str, cq.Shape]:
    """Every part of :attr:`Design.part_names` as a CadQuery solid, in casting position (docs/frame-and-units.md)."""
    top = parts.top_layer(design)
    bottom = parts.bottom_layer(design)
    passive = parts.passive_layer(design, top)
    made = {
        "actuator": parts.actuator(design, top, bottom, passive),
        "top_layer": top,
        "bottom_layer": bottom,
        "passive_layer": passive,
        "paper": parts.paper(design) if design.paper.present else None,
        "mold_interior": molds.interior_mold(design),
        "mold_exterior": molds.exterior_mold(design),
        "mold_bottom": molds.bottom_mold(design),
    }
    return {name: made[name] for name in design.part_names}


def _atomic(path: Path, write) -> None:
    """Write through ``write(tmp_path)`` to a temporary name, then rename over ``path``."""
    try:
        with atomic_path(path) as tmp:
            ok = write(str(tmp))
            if ok is False or os.path.getsize(tmp) == 0:
                raise ExportError(str(path), "the CAD kernel wrote nothing")
    except ExportError:
        raise
    except Exception as err:
        raise ExportError(str(path), f"export failed: {err}") from err


def export_actuator_step(design: Design, folder: str | Path) -> Path:
    """Only the cast actuator, as ``folder/actuator.step``: what the FE meshes when no build
    folder is at hand (the same solid a build exports)."""
    top = parts.top_layer(design)
    shape = parts.actuator(design, top, parts.bottom_layer(design), parts.passive_layer(design, top))
    path = Path(folder) / "actuator.step"
    path.parent.mkdir(parents=True, exist_ok=True)
    _atomic(path, lambda tmp: cq.exporters.export(shape, tmp, exportType="STEP"))
    return path


def _write_stl(shape: cq.Shape, path: Path) -> None:
    _atomic(path, lambda tmp: shape.exportStl(
        tmp, tolerance=STL_TOLERANCE_MM, angularTolerance=STL_ANGULAR_RAD, ascii=False,
        relative=False))


def print_oriented(shape: cq.Shape, name: str) -> cq.Shape:
    """A mold turned so that its bed face is down and resting on z = 0."""
    if USES[name].print_up[2] < 0:
        shape = shape.rotate(cq.Vector(0, 0, 0), cq.Vector(1, 0, 0), 180)
    return shape.translate(cq.Vector(0, 0, -shape.BoundingBox().zmin))


def export_parts(shapes: dict[str, cq.Shape], out_dir: Path) -> dict[str, Path]:
    """Write ``<name>.step`` and ``<name>.stl`` for every shape, and a print-oriented STL
    of every mold in ``print/``; return relative file name -> path."""
    out_dir = Path(out_dir)
    (out_dir / "print").mkdir(parents=True, exist_ok=True)
    written = {}
    for name, shape in shapes.items():
        step, stl = out_dir / f"{name}.step", out_dir / f"{name}.stl"
        _atomic(step, lambda tmp, s=shape: cq.exporters.export(s, tmp, exportType="STEP"))
        _write_stl(shape, stl)
        written[f"{name}.step"], written[f"{name}.stl"] = step, stl
        if name in USES:
            path = out_dir / "print" / f"{name}.stl"
            _write_stl(print_oriented(shape, name), path)
            written[f"print/{name}.stl"] = path
        log.debug("exported %s", name)
    return written
