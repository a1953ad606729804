"""Measurements on meshes: wall thickness by rays, faces by direction, sealed voids."""

from __future__ import annotations

import manifold3d as mf
import numpy as np
import trimesh

_EPS = 1e-4


def surface_samples(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """Points on every face (centroid and three inner points) with the face normals."""
    tri = np.asarray(mesh.triangles)
    centroid = tri.mean(axis=1)
    points = [centroid] + [0.5 * (centroid + tri[:, k]) for k in range(3)]
    normals = np.asarray(mesh.face_normals)
    return np.concatenate(points), np.tile(normals, (4, 1))


def wall_thickness(mesh: trimesh.Trimesh, solid: mf.Manifold) -> tuple[float, np.ndarray]:
    """Thinnest wall: from points on the surface, the distance along the inward normal to
    where the ray leaves the solid. Returns (thickness mm, location)."""
    points, normals = surface_samples(mesh)
    reach = float(np.linalg.norm(np.ptp(np.asarray(mesh.bounds), axis=0))) + 1.0
    best, where = np.inf, points[0]
    for p, n in zip(points, normals, strict=True):
        if not np.isfinite(n).all() or np.linalg.norm(n) < 0.5:
            continue
        start = p - _EPS * n
        hits = solid.ray_cast(tuple(start), tuple(start - reach * n))
        if hits:
            t = hits[0].distance * reach + _EPS
            if t < best:
                best, where = t, p
    return float(best), where


def faces_toward(mesh: trimesh.Trimesh, direction, cos_min: float) -> np.ndarray:
    """Mask of faces whose normal makes an angle with ``direction`` below acos(cos_min)."""
    d = np.asarray(direction, float)
    return np.asarray(mesh.face_normals) @ (d / np.linalg.norm(d)) >= cos_min


def level(mesh: trimesh.Trimesh, direction) -> np.ndarray:
    """Height of every face centroid along ``direction``, from the lowest vertex."""
    d = np.asarray(direction, float)
    return np.asarray(mesh.triangles_center) @ d - np.min(np.asarray(mesh.vertices) @ d)


def down_faces_off_the_base(mesh: trimesh.Trimesh, up, cos_min: float = 0.7071,
                            tol_mm: float = 1e-3) -> float:
    """Area of faces facing down (within 45 degrees) that are not on the lowest level:
    overhangs when printing, air-trapping ceilings when pouring."""
    down = faces_toward(mesh, -np.asarray(up, float), cos_min)
    raised = level(mesh, up) > tol_mm
    return float(np.asarray(mesh.area_faces)[down & raised].sum())


def base_area(mesh: trimesh.Trimesh, up, tol_mm: float = 1e-3) -> float:
    """Area of the flat faces on the lowest level, facing straight down."""
    down = faces_toward(mesh, -np.asarray(up, float), 0.9999)
    low = level(mesh, up) <= tol_mm
    return float(np.asarray(mesh.area_faces)[down & low].sum())


def footprint(mesh: trimesh.Trimesh, up) -> tuple[float, float, float]:
    """(a, b, height) of the bounding box with ``up`` vertical (up must be a +/- axis)."""
    axis = int(np.argmax(np.abs(up)))
    ext = np.ptp(np.asarray(mesh.bounds), axis=0)
    a, b = (float(ext[i]) for i in range(3) if i != axis)
    return a, b, float(ext[axis])


def voids(solid: mf.Manifold) -> list[float]:
    """Volumes of the sealed voids inside a solid (its inner shells), largest first."""
    return sorted((-float(c.volume()) for c in solid.decompose() if c.volume() < 0), reverse=True)


def bodies(solid: mf.Manifold) -> int:
    """Number of separate solids (outer shells)."""
    return sum(1 for c in solid.decompose() if c.volume() > 0)
