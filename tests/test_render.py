"""The report's pictures (PyVista off screen, in a child process) and its GLB models."""

from __future__ import annotations

import io
import json
import struct
import sys

import numpy as np
import pytest
import trimesh

from pnmold.report import render

VIRIDIS_ENDS = (np.array([68, 1, 84]), np.array([253, 231, 37]))


def rgb(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)


@pytest.fixture
def block(tmp_path):
    """A 40 x 10 x 5 mm block with a pocket in its top face, as STL."""
    from manifold3d import Manifold

    solid = Manifold.cube([40, 10, 5]) - Manifold.cube([30, 6, 3]).translate([5, 2, 2.5])
    mesh = solid.to_mesh()
    path = tmp_path / "block.stl"
    trimesh.Trimesh(mesh.vert_properties[:, :3], mesh.tri_verts).export(path)
    return path


def test_the_upside_down_parts_are_the_ones_cast_or_poured_open_side_down():
    assert render.UPSIDE_DOWN == {"top_layer", "mold_exterior"}
    assert set(render.PARTS) == set(render.COLOURS)


def test_a_part_is_drawn_in_its_colour_in_a_child_process(block):
    pictures = render.pictures({"a": ("part", block, "mold_bottom"), "b": ("part", block, "mold_exterior")})
    assert all(isinstance(v, bytes) for v in pictures.values()), pictures
    a, b = rgb(pictures["a"]), rgb(pictures["b"])
    assert a.shape == (render.PICTURE_PX[1], render.PICTURE_PX[0], 3)
    covered = (a.min(axis=2) < 245).mean()
    assert 0.05 < covered < 0.9
    greenish = (a[..., 1] - np.maximum(a[..., 0], a[..., 2]) > 30).mean()  # mold_bottom is green
    assert greenish > 0.5 * covered
    bluish = (b[..., 2] - np.maximum(b[..., 0], b[..., 1]) > 30).mean()  # mold_exterior is blue, seen from below
    assert bluish > 0.5 * (b.min(axis=2) < 245).mean()


def test_a_missing_file_gives_the_reason(tmp_path):
    out = render.pictures({"x": ("part", tmp_path / "missing.stl", "paper")})
    assert isinstance(out["x"], str) and "missing.stl" in out["x"]


def test_a_crashing_renderer_leaves_the_reason_not_a_dead_build(tmp_path, monkeypatch, block):
    fake = tmp_path / "python"
    fake.write_text("#!/bin/sh\necho 'fake renderer: no OpenGL here' >&2\nkill -SEGV $$\n")
    fake.chmod(0o755)
    monkeypatch.setattr(sys, "executable", str(fake))
    out = render.pictures({"a": ("part", block, "paper"), "s": ("strain", tmp_path / "f.npz")})
    assert out == {k: "the renderer stopped (exit code -11): fake renderer: no OpenGL here" for k in ("a", "s")}


def strip_field(path, half: bool = True):
    """A 40 x 10 mm strip (y >= 0 half when ``half``) lifted into an arc; stretch 1 -> 2 along x."""
    xs, ys = np.linspace(0, 40, 21), np.linspace(0 if half else -10, 10, 6)
    x, y = (a.ravel() for a in np.meshgrid(xs, ys, indexing="ij"))
    nodes = np.column_stack([x, y, np.zeros_like(x)])
    ny = len(ys)
    quads = [(i * ny + j, (i + 1) * ny + j, (i + 1) * ny + j + 1, i * ny + j + 1)
             for i in range(len(xs) - 1) for j in range(ny - 1)]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    disp = np.column_stack([np.zeros_like(x), np.zeros_like(x), 0.01 * x ** 2])
    np.savez(path, nodes_mm=nodes, displacement_mm=disp, surface_tris=tris, stretch=1 + x / 40)
    return nodes, tris


def test_the_strain_picture_colours_the_surface_with_a_colour_bar(tmp_path):
    strip_field(tmp_path / "f.npz")
    png = render.pictures({"s": ("strain", tmp_path / "f.npz")})["s"]
    assert isinstance(png, bytes), png
    img = rgb(png).reshape(-1, 3)
    for end in VIRIDIS_ENDS:  # both ends of the colour map appear (the unlit colour bar at least)
        assert (np.abs(img - end).max(axis=1) < 25).sum() > 50, end
    assert len(np.unique(img, axis=0)) > 200


def test_the_strain_picture_marks_the_walls_in_contact_in_red(tmp_path):
    """With ``contact_kpa`` (self-contact) the pressed nodes are drawn red; without, no red at all
    (viridis has none)."""
    nodes, _ = strip_field(tmp_path / "f.npz")
    with np.load(tmp_path / "f.npz") as f:
        field = dict(f)
    np.savez(tmp_path / "c.npz", **field, contact_kpa=np.where(nodes[:, 0] > 30, 12.0, 0.0))
    out = render.pictures({"s": ("strain", tmp_path / "f.npz"), "c": ("strain", tmp_path / "c.npz")})
    red = {k: int(((img[:, 0] > 180) & (img[:, 1] < 80) & (img[:, 2] < 80)).sum())
           for k, img in ((k, rgb(out[k]).reshape(-1, 3).astype(int)) for k in ("s", "c"))}
    assert red["s"] == 0 and red["c"] > 100, red


def test_a_half_model_is_mirrored_with_its_winding_flipped(tmp_path):
    nodes, tris = strip_field(tmp_path / "f.npz")
    stretch = np.arange(len(nodes), dtype=float)
    both, tris2, s2 = render.mirrored(nodes, tris, stretch)
    n = len(nodes)
    assert both.shape == (2 * n, 3) and np.allclose(both[n:, 1], -nodes[:, 1])
    assert np.array_equal(tris2[len(tris):], tris[:, ::-1] + n)
    assert np.array_equal(s2, np.concatenate([stretch, stretch]))
    normals = trimesh.Trimesh(both, tris2, process=False).face_normals
    assert np.allclose(normals[: len(tris)], normals[len(tris):])  # both halves face the same way


def glb_json(data: bytes) -> dict:
    length = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + length])


def test_the_glb_lays_the_parts_side_by_side_without_normals(tmp_path, block):
    for name in ("actuator", "mold_exterior"):
        (tmp_path / f"{name}.stl").write_bytes(block.read_bytes())
    data = render.glb(tmp_path, ["actuator", "mold_exterior"])
    doc = glb_json(data)
    assert all("NORMAL" not in p["attributes"] for m in doc["meshes"] for p in m["primitives"])
    assert [m["name"] for m in doc["materials"]] == ["actuator", "mold_exterior"]
    scene = trimesh.load(io.BytesIO(data), file_type="glb")
    bounds = [g.bounds for g in scene.dump()]
    assert len(bounds) == 2
    # y-up (glTF): the actuator frame's y runs along -z, so the parts sit apart in z, 8 mm between
    (lo_a, hi_a), (lo_b, hi_b) = sorted(((b[0][2], b[1][2]) for b in bounds), reverse=True)
    assert hi_b == pytest.approx(lo_a - 8.0, abs=1e-3)
    assert all(b[1][1] - b[0][1] == pytest.approx(5.0, abs=1e-3) for b in bounds)  # z height became y


def test_the_glb_decimates_a_dense_part(tmp_path):
    trimesh.creation.icosphere(subdivisions=5, radius=10).export(tmp_path / "paper.stl")  # 20480 faces
    data = render.glb(tmp_path, ["paper"], max_faces=2000)
    faces = sum(len(g.faces) for g in trimesh.load(io.BytesIO(data), file_type="glb").dump())
    assert 1000 < faces <= 2100


def test_jobs_sent_at_two_times_come_back_together_and_the_child_ends(block, tmp_path):
    strip_field(tmp_path / "f.npz")
    with render.Renderer() as renderer:
        renderer.draw({"a": ("part", block, "paper")})  # a build: the parts first, the strain after the FE
        renderer.draw({"s": ("strain", tmp_path / "f.npz")})
        out = renderer.results()
        child = renderer._proc
    assert renderer.sent == ["a", "s"]
    assert set(out) == {"a", "s"} and all(isinstance(v, bytes) for v in out.values()), out
    assert child.poll() is not None


def test_a_renderer_left_without_results_is_stopped(block):
    with render.Renderer() as renderer:
        renderer.draw({"a": ("part", block, "paper")})
        child = renderer._proc
    assert child.poll() is not None
