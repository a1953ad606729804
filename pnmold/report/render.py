"""Pictures for the report a person reads: each part, the strain on the bent actuator, curves,
and the GLB models of the interactive view.

Parts are drawn with PyVista (VTK) off screen through EGL, which Mesa's software renderer
(``libegl-mesa0``, installed by ``scripts/install-system-deps.sh``) provides without a
display or a GPU. :class:`Renderer` draws them in a child process (``python -m
pnmold.report.render``), because VTK ends its process when it finds no OpenGL at all: a build then
loses its pictures, with the reason, not its life. Curves are matplotlib (Agg). Everything
returns PNG or GLB bytes.
"""

from __future__ import annotations

import io
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pnmold.conventions import CAST_PARTS, MOLDS, USES
from pnmold.fsutil import write_bytes

#: the parts in the order a person reads them
PARTS = CAST_PARTS + MOLDS
#: seen from below (turned over): the top layer's open cavities, the exterior mold's inside
UPSIDE_DOWN = frozenset({"top_layer"} | {m for m, use in USES.items() if use.print_up[2] < 0})
COLOURS = {"actuator": "#7fb8d8", "top_layer": "#8cc4e0", "bottom_layer": "#6fa8c8", "passive_layer": "#9ccfe6",
           "paper": "#efe9d2", "mold_interior": "#d9534f", "mold_exterior": "#6b9be8", "mold_bottom": "#5cb85c"}
PICTURE_PX = (760, 420)
#: the interactive view keeps at most this many triangles per part (decimated above)
MAX_VIEWER_FACES = 60_000
STRETCH_LABEL = "largest principal stretch"


def _plotter(size: tuple[int, int] = PICTURE_PX):
    """An off-screen plotter on EGL: no X display is needed, and a broken DISPLAY is ignored."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    plotter = pv.Plotter(off_screen=True, window_size=list(size))
    plotter.set_background("white")
    plotter.enable_anti_aliasing("ssaa")
    return plotter


def _look(plotter, direction: tuple[float, float, float], up: tuple[float, float, float], zoom: float) -> None:
    """Point the camera at the scene's centre from ``direction`` and fit the scene."""
    (x0, x1, y0, y1, z0, z1) = plotter.bounds
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    plotter.camera_position = [tuple(centre + 1000 * d), tuple(centre), up]
    plotter.reset_camera()
    plotter.camera.zoom(zoom)


def _png(plotter) -> bytes:
    img = plotter.screenshot(return_img=True)
    plotter.close()
    if img.std() == 0:
        raise RuntimeError("the offscreen renderer drew a blank picture (no working OpenGL?)")
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def part_picture(stl_path: str | Path, name: str) -> bytes:
    """PNG of one part, flat-shaded with its edges, in its use orientation (see UPSIDE_DOWN)."""
    import pyvista as pv

    mesh = pv.read(str(stl_path))
    plotter = _plotter()
    actor = plotter.add_mesh(mesh, color=COLOURS.get(name, "#bbbbbb"), smooth_shading=False, specular=0.2)
    actor.mapper.SetResolveCoincidentTopologyToPolygonOffset()  # the edges drawn over the faces stay visible
    plotter.add_mesh(mesh.extract_feature_edges(30.0), color="#222222", line_width=1.5)
    sign = -1.0 if name in UPSIDE_DOWN else 1.0
    _look(plotter, (0.8, -1.3, 1.1 * sign), (0.0, 0.0, sign), zoom=1.45)
    return _png(plotter)


def mirrored(nodes: np.ndarray, tris: np.ndarray, *values: np.ndarray):
    """A half model (y >= 0) completed by its mirror image in y = 0 (winding flipped)."""
    flipped = nodes * np.array([1.0, -1.0, 1.0])
    out_tris = np.vstack([tris, tris[:, ::-1] + len(nodes)])
    return (np.vstack([nodes, flipped]), out_tris, *(np.concatenate([v, v]) for v in values))


def strain_picture(field_path: str | Path) -> bytes:
    """PNG of the deformed surface coloured by the largest principal stretch, with a colour bar.

    ``field_path``: ``fem_field.npz`` with ``nodes_mm``, ``displacement_mm``, ``surface_tris``,
    ``stretch`` (per node) and optionally ``half`` (else: half when no node has y < 0) and
    ``contact_kpa`` (per node, with self-contact: the nodes where the walls press on each other are
    marked in red, the most pressed one labelled)."""
    import pyvista as pv

    with np.load(field_path) as f:
        nodes, disp = f["nodes_mm"].astype(float), f["displacement_mm"].astype(float)
        tris, stretch = f["surface_tris"].astype(np.int64), f["stretch"].astype(float)
        half = bool(f["half"]) if "half" in f.files else nodes[:, 1].min() > -1e-6
        contact = f["contact_kpa"].astype(float) if "contact_kpa" in f.files else np.zeros(len(nodes))
    if half:
        nodes, tris, disp, stretch, contact = mirrored(nodes, tris, disp * np.array([1.0, -1.0, 1.0]), stretch,
                                                       contact)
    faces = np.hstack([np.full((len(tris), 1), 3), tris]).ravel()
    surface = pv.PolyData(nodes + disp, faces)
    surface.point_data[STRETCH_LABEL] = stretch
    plotter = _plotter((820, 520))
    plotter.add_mesh(surface, scalars=STRETCH_LABEL, cmap="viridis", smooth_shading=False,
                     scalar_bar_args={"title": STRETCH_LABEL, "fmt": "%.2f", "color": "black", "width": 0.6,
                                      "position_x": 0.2, "position_y": 0.03, "title_font_size": 18,
                                      "label_font_size": 15})
    at = int(np.argmax(stretch))
    plotter.add_point_labels([surface.points[at]], [f"max {stretch[at]:.2f}"], point_size=10,
                             point_color="cyan", font_size=14, always_visible=True)
    touching = np.flatnonzero(contact > 0)
    if touching.size:
        plotter.add_points(surface.points[touching], color="red", point_size=7, render_points_as_spheres=True)
        top = touching[np.argmax(contact[touching])]
        plotter.add_point_labels([surface.points[top]], ["walls in contact"], point_size=1,
                                 font_size=13, text_color="red", always_visible=True)
    _look(plotter, (0.35, -1.0, 0.45), (0.0, 0.0, 1.0), zoom=1.1)
    return _png(plotter)


def curve_png(series: list[tuple[list[float], list[float], str]], xlabel: str, ylabel: str, title: str) -> bytes:
    """PNG of one or more (x, y, label) curves."""
    from matplotlib.figure import Figure  # no pyplot, no backend switch (pnmold.plots)

    fig = Figure(figsize=(5.2, 3.6))
    ax = fig.subplots()
    for x, y, label in series:
        ax.plot(x, y, "o-", ms=3, label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    if len(series) > 1:
        ax.legend(fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    return buf.getvalue()


def _viewer_mesh(stl_path: Path, name: str, max_faces: int):
    import trimesh
    from trimesh.visual.material import PBRMaterial

    mesh = trimesh.load(stl_path, force="mesh")
    if len(mesh.faces) > max_faces:
        import pyvista as pv

        small = pv.wrap(mesh).triangulate().decimate(1.0 - max_faces / len(mesh.faces))
        mesh = trimesh.Trimesh(small.points, small.faces.reshape(-1, 4)[:, 1:], process=False)
    if name in UPSIDE_DOWN:
        mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi, (1, 0, 0)))
    srgb = [int(COLOURS.get(name, "#bbbbbb")[i:i + 2], 16) / 255 for i in (1, 3, 5)]
    rgb = [round(255 * ((c + 0.055) / 1.055) ** 2.4) for c in srgb]  # glTF colour factors are linear
    mesh.visual = trimesh.visual.TextureVisuals(
        material=PBRMaterial(name=name, baseColorFactor=[*rgb, 255], metallicFactor=0.0, roughnessFactor=0.75))
    return mesh


def glb(folder: str | Path, names: list[str] | tuple[str, ...], *, gap_mm: float = 8.0,
        max_faces: int = MAX_VIEWER_FACES) -> bytes:
    """GLB of the named parts' STL files, side by side across y in their use orientation.

    No normals are written, so the viewer shades each triangle flat (glTF's rule); the
    actuator frame's z-up turns to glTF's y-up."""
    import trimesh

    to_y_up = trimesh.transformations.rotation_matrix(-np.pi / 2, (1, 0, 0))
    scene = trimesh.Scene()
    y = 0.0
    for name in names:
        mesh = _viewer_mesh(Path(folder) / f"{name}.stl", name, max_faces)
        (x0, y0, z0), (_, y1, _) = mesh.bounds
        mesh.apply_translation((-x0, y - y0, -z0))
        y += (y1 - y0) + gap_mm
        mesh.apply_transform(to_y_up)
        scene.add_geometry(mesh, node_name=name, geom_name=name)
    return scene.export(file_type="glb", include_normals=False)


DRAW = {"part": part_picture, "strain": strain_picture}
RENDER_TIMEOUT_S = 600


class Renderer:
    """A child process (``python -m pnmold.report.render``) that draws jobs as they are sent, one JSON
    line of ``key -> ("part", stl_path, name) | ("strain", npz_path)`` at a time.

    A build starts it as soon as its parts are exported, so the part pictures are drawn while
    the design is checked and bent, and sends the strain picture once the FE has written its
    field; :meth:`results` then waits for everything sent (at most ``RENDER_TIMEOUT_S`` from
    the start). Use it as a context manager: leaving the block stops the child."""

    def __init__(self) -> None:
        self._tmp = tempfile.TemporaryDirectory(prefix="pnmold-render-")
        self._folder = Path(self._tmp.name)
        self._t0 = time.monotonic()
        self.sent: list[str] = []
        self._stderr = (self._folder / "stderr.txt").open("w+")
        home = str(Path(__file__).resolve().parents[2])  # this pnmold, installed or not
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [home, os.environ.get("PYTHONPATH")]))}
        self._start_error = None
        try:
            self._proc: subprocess.Popen | None = subprocess.Popen(
                [sys.executable, "-m", "pnmold.report.render", str(self._folder)], stdin=subprocess.PIPE,
                stdout=subprocess.DEVNULL, stderr=self._stderr, text=True, env=env)
        except OSError as err:
            self._proc, self._start_error = None, f"the renderer could not start: {err}"

    def draw(self, jobs: dict[str, tuple]) -> None:
        """Send ``jobs`` to the child (a child that has stopped is reported by :meth:`results`)."""
        self.sent += [key for key in jobs if key not in self.sent]
        if self._proc is None or not jobs:
            return
        try:
            self._proc.stdin.write(json.dumps({key: [str(v) for v in job] for key, job in jobs.items()}) + "\n")
            self._proc.stdin.flush()
        except OSError:  # the child died: its exit code and last words say why, in results()
            pass

    def results(self) -> dict[str, bytes | str]:
        """Wait for the child: key -> PNG bytes, or the reason there is no picture."""
        stopped = self._start_error or ""
        if self._proc is not None:
            try:
                self._proc.stdin.close()
            except OSError:
                pass
            try:
                self._proc.wait(timeout=max(1.0, RENDER_TIMEOUT_S - (time.monotonic() - self._t0)))
                self._stderr.seek(0)
                lines = [ln for ln in re.sub(r"\x1b\[[0-9;]*m", "", self._stderr.read()).splitlines() if ln.strip()]
                code = self._proc.returncode
                stopped = f"the renderer stopped (exit code {code}){': ' + lines[-1] if lines else ''}"
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
                stopped = f"the renderer took longer than {RENDER_TIMEOUT_S} s"
        out: dict[str, bytes | str] = {}
        for key in self.sent:
            png, err = self._folder / f"{key}.png", self._folder / f"{key}.err"
            out[key] = png.read_bytes() if png.is_file() else err.read_text() if err.is_file() else stopped
        return out

    def close(self) -> None:
        """Stop the child if it still runs and remove its folder."""
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait()
        self._stderr.close()
        self._tmp.cleanup()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def pictures(jobs: dict[str, tuple[str, ...]]) -> dict[str, bytes | str]:
    """Draw ``jobs`` (key -> ``("part", stl_path, name)`` or ``("strain", npz_path)``) in a
    child process (:class:`Renderer`): key -> PNG bytes, or the reason there is no picture."""
    with Renderer() as renderer:
        renderer.draw(jobs)
        return renderer.results()


def _serve(folder: str) -> None:
    """The child of :class:`Renderer`: jobs as JSON lines on stdin, ``<key>.png`` or
    ``<key>.err`` into ``folder``, until stdin closes."""
    for line in sys.stdin:
        if not line.strip():
            continue
        for key, (kind, *args) in json.loads(line).items():
            try:
                data = DRAW[kind](*args)
            except (OSError, ValueError, KeyError, RuntimeError) as err:
                Path(folder, f"{key}.err").write_text(f"{type(err).__name__}: {err}")
                continue
            write_bytes(Path(folder, f"{key}.png"), data)


if __name__ == "__main__":
    _serve(sys.argv[1])
