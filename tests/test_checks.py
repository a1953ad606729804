"""The design-rule gate: every template passes; each deliberately broken part is caught
with the right id and exit 1."""

from __future__ import annotations

import json
import shutil

import manifold3d as mf
import numpy as np
import pytest
import trimesh

from pnmold.checks import check_parts
from pnmold.checks import solids as S
from pnmold.checks.context import BuildFiles
from pnmold.checks.stlio import load_stl
from pnmold.cli import main
from tests.conftest import TEMPLATES


@pytest.mark.parametrize("template", TEMPLATES)
def test_every_template_passes_the_gate(built, template):
    result = built(template)
    failed = [c["id"] for c in result.report["checks"] if c["passed"] is False]
    assert failed == []
    ids = {c["id"] for c in result.report["checks"]}
    for prefix in ("mesh.watertight.", "fit.overlap.", "print.min_wall.", "demold.", "cast."):
        assert any(i.startswith(prefix) for i in ids), prefix


def test_the_slicer_estimates_reach_the_report(built):
    report = built("fpn").report
    slicer = report["slicer"]
    assert set(slicer) == {"mold_interior", "mold_exterior", "mold_bottom"}
    for estimate in slicer.values():
        if estimate.get("status") == "skipped":  # only where PrusaSlicer is not installed
            pytest.skip("PrusaSlicer is not installed here")
        assert estimate["print_time_s"] > 60 and estimate["filament_g"] > 1


# -- broken parts --------------------------------------------------------------------------

def _write(mesh: trimesh.Trimesh, path) -> None:
    path.write_bytes(trimesh.exchange.stl.export_stl(mesh))


def _to_mesh(m: mf.Manifold) -> trimesh.Trimesh:
    out = m.to_mesh()
    return trimesh.Trimesh(np.asarray(out.vert_properties)[:, :3], np.asarray(out.tri_verts), process=False)


@pytest.fixture
def fpn_copy(built, tmp_path):
    src = built("fpn").out_dir
    dst = tmp_path / "fpn"
    shutil.copytree(src, dst)
    return dst


def _open_mesh(d, files):
    m = load_stl(d / "mold_bottom.stl")
    _write(trimesh.Trimesh(m.vertices, m.faces[2:], process=False), d / "mold_bottom.stl")


def _flipped_faces(d, files):
    m = load_stl(d / "top_layer.stl")
    faces = m.faces.copy()
    faces[:5] = faces[:5, ::-1]
    _write(trimesh.Trimesh(m.vertices, faces, process=False), d / "top_layer.stl")


def _inverted_part(d, files):
    m = load_stl(d / "paper.stl")
    _write(trimesh.Trimesh(m.vertices, m.faces[:, ::-1], process=False), d / "paper.stl")


def _overlapping_molds(d, files):
    _write(_to_mesh(files.solid("mold_interior").translate((0, 0, 1.0))), d / "mold_interior.stl")


def _mold_inside_another(d, files):
    # the interior mold replaced by a block hidden wholly inside the exterior mold's ceiling
    des = files.design
    z = des.top_z0_mm + des.top_height_mm
    _write(_to_mesh(S.box((10, -5, z + 0.5), (20, 5, z + 2.5))), d / "mold_interior.stl")


def _thin_plate(d, files):
    # the exterior mold's plates ground down to 0.5 mm (thinner than two 0.4 mm lines)
    des = files.design
    ext = files.solid("mold_exterior")
    z0 = des.top_z0_mm + des.top_layer.floor_mm
    for i in range(des.chambers.count - 1):
        x0, x1 = des.gap_x_mm(i)
        ext = ext - S.box((x0 + 0.5, -des.width_mm / 2, z0 - 0.1), (x1 + 0.01, des.width_mm / 2, des.height_mm))
    _write(_to_mesh(ext), d / "mold_exterior.stl")


def _undercut(d, files):
    # a hook on one plate's foot reaching under the neighbouring chamber walls
    des = files.design
    x0, x1 = des.gap_x_mm(3)
    zf = des.top_z0_mm + des.top_layer.floor_mm
    hook = S.box((x0 - 0.5, -3, zf - 0.6), (x1 + 0.5, 3, zf))
    _write(_to_mesh(files.solid("mold_exterior") + hook), d / "mold_exterior.stl")
    _write(_to_mesh(files.solid("top_layer") - hook), d / "top_layer.stl")


def _too_big(d, files):
    m = load_stl(d / "mold_bottom.stl")
    _write(trimesh.Trimesh(m.vertices * [2.2, 1, 1], m.faces, process=False), d / "mold_bottom.stl")


def _chamber_cut_off(d, files):
    des = files.design
    x = des.cavity_x_mm(6)[0]
    wall = S.box((x - 1.2, -1.5, des.top_z0_mm - 0.1), (x + 0.01, 1.5, des.top_z0_mm + des.channel.height_mm + 0.1))
    _write(_to_mesh(files.solid("actuator") + wall), d / "actuator.stl")


def _blocked_inlet(d, files):
    des = files.design
    plug = S.cylinder_x(1.2, -0.5, 1.0, 0.0, des.inlet_axis_z_mm)
    _write(_to_mesh(files.solid("actuator") + plug), d / "actuator.stl")


def _air_trap(d, files):
    # a shelf over the pour inside the exterior mold's rim: in the turned-over mold it
    # faces down into the rubber and traps air under it
    des = files.design
    m = des.mold
    r = m.ledge_mm + m.clearance_mm
    z0 = des.top_z0_mm
    z = z0 - m.plate_mm
    shelf = S.box((-r, -des.width_mm / 2 - r, z - 2.0), (-r + 1.5, des.width_mm / 2 + r, z - 1.0))
    _write(_to_mesh(files.solid("mold_exterior") + shelf), d / "mold_exterior.stl")


BROKEN = [
    (_open_mesh, "mesh.watertight.mold_bottom"),
    (_flipped_faces, "mesh.winding.top_layer"),
    (_inverted_part, "mesh.volume.paper"),
    (_overlapping_molds, "fit.overlap.top"),
    (_mold_inside_another, "fit.overlap.top"),
    (_thin_plate, "print.min_wall.mold_exterior"),
    (_undercut, "demold.mold_exterior"),
    (_too_big, "print.build_volume.mold_bottom"),
    (_chamber_cut_off, "cast.chambers_connected"),
    (_blocked_inlet, "cast.inlet_reaches_channel"),
    (_air_trap, "cast.air_trap.mold_exterior"),
]


@pytest.mark.parametrize(("breaker", "check_id"), BROKEN, ids=[b.__name__.strip("_") for b, _ in BROKEN])
def test_broken_part_is_caught_with_its_id(fpn_copy, breaker, check_id, capsys):
    breaker(fpn_copy, BuildFiles(fpn_copy))
    report = check_parts(fpn_copy, use_slicer=False)
    failed = {f.id for f in report.failed}
    assert check_id in failed
    assert main(["check", str(fpn_copy), "--no-slicer", "--quiet"]) == 1
    assert check_id in capsys.readouterr().err
    saved = json.loads((fpn_copy / "report.json").read_text())
    assert check_id in {c["id"] for c in saved["checks"] if c["passed"] is False}


def test_the_intact_copy_passes(fpn_copy):
    assert check_parts(fpn_copy, use_slicer=False).failed == []
    assert main(["check", str(fpn_copy), "--no-slicer", "--quiet"]) == 0


def test_a_missing_slicer_is_skipped_never_passed(fpn_copy, monkeypatch):
    monkeypatch.setenv("PNMOLD_SLICER", "/nonexistent/prusa-slicer")
    report = check_parts(fpn_copy)
    slicer = [f for f in report.findings if f.id.startswith("print.slicer.")]
    assert len(slicer) == 3 and all(f.passed is None for f in slicer)
    assert all("not found" in f.message for f in slicer)


def test_check_refuses_a_folder_that_is_not_a_build(tmp_path):
    assert main(["check", str(tmp_path)]) == 2
