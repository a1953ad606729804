"""Small CadQuery helpers: axis-aligned boxes and booleans that name the feature on failure."""

from __future__ import annotations

from collections.abc import Iterable

import cadquery as cq

from pnmold.errors import GeometryError


def box(feature: str, x: tuple[float, float], y: tuple[float, float],
        z: tuple[float, float]) -> cq.Shape:
    """The box [x0, x1] x [y0, y1] x [z0, z1] (mm)."""
    dx, dy, dz = x[1] - x[0], y[1] - y[0], z[1] - z[0]
    if min(dx, dy, dz) <= 0:
        raise GeometryError(feature, f"box has a non-positive size {dx:.4g} x {dy:.4g} x {dz:.4g} mm")
    return cq.Solid.makeBox(dx, dy, dz, pnt=cq.Vector(x[0], y[0], z[0]))


def cylinder_x(feature: str, radius: float, x: tuple[float, float], y: float, z: float) -> cq.Shape:
    """A cylinder along +x from x[0] to x[1], axis through (y, z)."""
    if radius <= 0 or x[1] <= x[0]:
        raise GeometryError(feature, f"cylinder radius {radius} mm, length {x[1] - x[0]} mm")
    return cq.Solid.makeCylinder(radius, x[1] - x[0], pnt=cq.Vector(x[0], y, z),
                                 dir=cq.Vector(1, 0, 0))


def fuse(feature: str, shapes: Iterable[cq.Shape]) -> cq.Shape:
    shapes = list(shapes)
    try:
        result = shapes[0].fuse(*shapes[1:]) if len(shapes) > 1 else shapes[0]
        return _solid(feature, result.clean())
    except GeometryError:
        raise
    except Exception as err:  # OCC raises its own types
        raise GeometryError(feature, f"union of {len(shapes)} shapes failed: {err}") from err


def cut(feature: str, base: cq.Shape, tools: Iterable[cq.Shape]) -> cq.Shape:
    tools = list(tools)
    if not tools:
        return _solid(feature, base)
    try:
        return _solid(feature, base.cut(*tools).clean())
    except GeometryError:
        raise
    except Exception as err:
        raise GeometryError(feature, f"cutting {len(tools)} features failed: {err}") from err


def _solid(feature: str, shape: cq.Shape) -> cq.Shape:
    """One valid solid (a compound of one solid is unwrapped)."""
    solids = shape.Solids()
    if len(solids) != 1:
        raise GeometryError(feature, f"expected one solid, the boolean gave {len(solids)}")
    solid = solids[0]
    if not solid.isValid():
        raise GeometryError(feature, "the boolean gave an invalid solid")
    return solid
