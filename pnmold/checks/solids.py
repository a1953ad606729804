"""Exact-ish volume arithmetic on exported meshes with manifold3d (robust booleans)."""

from __future__ import annotations

import manifold3d as mf
import numpy as np
import trimesh

from pnmold.errors import GeometryError


def to_manifold(mesh: trimesh.Trimesh, name: str = "part") -> mf.Manifold:
    """A manifold3d solid from a welded trimesh; refuses a mesh that is not a closed solid."""
    m = mf.Manifold(mf.Mesh(vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
                            tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))
    if m.status() != mf.Error.NoError:
        raise GeometryError(name, f"not a closed manifold solid ({m.status().name})")
    return m


def box(lo, hi) -> mf.Manifold:
    """The axis-aligned box [lo, hi] (mm)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return mf.Manifold.cube(tuple(hi - lo)).translate(tuple(lo))


def cylinder_x(radius: float, x0: float, x1: float, y: float, z: float,
               segments: int = 96) -> mf.Manifold:
    """A cylinder along +x from x0 to x1 with its axis through (y, z)."""
    c = mf.Manifold.cylinder(x1 - x0, radius, radius, segments)  # along +z from 0
    return c.rotate((0.0, 90.0, 0.0)).translate((x0, y, z))


def volume(m: mf.Manifold) -> float:
    return float(m.volume())


def overlap(a: mf.Manifold, b: mf.Manifold) -> float:
    """Volume of the intersection of two solids (mm3)."""
    return volume(a ^ b)


def void(region: mf.Manifold, parts: list[mf.Manifold]) -> float:
    """Volume of ``region`` covered by none of ``parts`` (mm3)."""
    rest = region
    for p in parts:
        rest = rest - p
    return volume(rest)


def components(m: mf.Manifold) -> list[mf.Manifold]:
    """The separate solids of ``m``."""
    return list(m.decompose())
