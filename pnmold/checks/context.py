"""The files of a build folder, read once: the resolved design, meshes and solids."""

from __future__ import annotations

from functools import cached_property
from pathlib import Path

import manifold3d as mf
import trimesh

from pnmold.checks import solids as S
from pnmold.checks.stlio import load_stl
from pnmold.design import Design, load_design
from pnmold.errors import UsageError


class BuildFiles:
    """Lazy access to ``design.toml`` and the STL files of a build folder."""

    def __init__(self, directory: str | Path):
        self.dir = Path(directory)
        if not (self.dir / "design.toml").is_file():
            raise UsageError(f"{self.dir}: not a build folder (no design.toml)")
        self._meshes: dict[str, trimesh.Trimesh] = {}
        self._solids: dict[str, mf.Manifold | None] = {}

    @cached_property
    def design(self) -> Design:
        return load_design(self.dir / "design.toml")

    def path(self, name: str) -> Path:
        return self.dir / f"{name}.stl"

    def mesh(self, name: str) -> trimesh.Trimesh:
        if name not in self._meshes:
            self._meshes[name] = load_stl(self.path(name))
        return self._meshes[name]

    def solid(self, name: str) -> mf.Manifold | None:
        """The part as a manifold3d solid, or None when its mesh is not a closed solid."""
        if name not in self._solids:
            try:
                self._solids[name] = S.to_manifold(self.mesh(name), name)
            except Exception:
                self._solids[name] = None
        return self._solids[name]

    # regions of the actuator frame that the checks need -----------------------------
    def top_envelope(self) -> mf.Manifold:
        d = self.design
        return S.box((0, -d.width_mm / 2, d.top_z0_mm),
                     (d.length_mm, d.width_mm / 2, d.top_z0_mm + d.top_height_mm))

    def bottom_envelope(self) -> mf.Manifold:
        d = self.design
        return S.box((0, -d.width_mm / 2, d.bottom_z0_mm), (d.length_mm, d.width_mm / 2, d.top_z0_mm))

    def inlet_bore(self) -> mf.Manifold:
        """The punched bore, slightly oversized to swallow its tessellation."""
        d = self.design
        return S.cylinder_x(1.05 * d.inlet.diameter_mm / 2, -1.0, d.inlet_depth_mm, 0.0,
                            d.inlet_axis_z_mm)

    def inlet_plug(self) -> mf.Manifold:
        """Fills the bore from outside the end face to the channel's start (the tube)."""
        d = self.design
        return S.cylinder_x(1.05 * d.inlet.diameter_mm / 2, -1.0, d.channel_x_mm[0], 0.0,
                            d.inlet_axis_z_mm)
