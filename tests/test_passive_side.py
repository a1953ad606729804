"""A design with a passive side (``[passive_side]``): the other half of a bidirectional segment, a second
top layer turned over under the bottom layer, unpressurised. The layout, the parts and their gate, the
section properties the reduced model reads, the FE's mesh and its bend."""

from __future__ import annotations

import numpy as np
import pytest

from pnmold.design import load_design
from pnmold.design.load import digest
from tests.closed_form import part_volumes_mm3

TWO_SIDED = ["passive_side.present=true", "bottom_layer.thickness_mm=3", "paper.depth_mm=1.5"]


def test_the_passive_side_lifts_the_bottom_layer_by_a_top_layer_and_keeps_old_digests():
    one = load_design("spn", ["bottom_layer.thickness_mm=3", "paper.depth_mm=1.5"])
    two = load_design("spn", TWO_SIDED)
    assert one.bottom_z0_mm == 0.0 and two.bottom_z0_mm == pytest.approx(two.top_height_mm)
    assert two.top_z0_mm == pytest.approx(two.top_height_mm + 3.0)
    assert two.height_mm == pytest.approx(one.height_mm + one.top_height_mm)
    assert two.sheet_z_mm == pytest.approx(two.top_height_mm + 1.5)
    assert "passive_layer" in two.part_names and "passive_layer" not in one.part_names
    # the passive side is a second top layer of the same rubber
    top = part_volumes_mm3(one)["top_layer"]
    assert two.elastomer_volume_mm3 - one.elastomer_volume_mm3 == pytest.approx(top, rel=1e-9)
    assert digest(load_design("spn", ["passive_side.present=false"])) == digest(load_design("spn"))


def test_a_two_sided_design_builds_passes_the_gate_and_its_passive_side_is_the_top_layer_turned_over(tmp_path):
    """Every part at its closed-form volume and every check passing; a passive layer that is not the
    top layer turned over (here shifted by 1 mm along x, so the top layer's molds do not cast it) fails
    ``fit.passive.mirror``."""
    import trimesh

    from pnmold.checks.run import check_parts
    from pnmold.checks.stlio import load_stl
    from pnmold.pipeline import build

    design = load_design("spn", TWO_SIDED)
    result = build(design, tmp_path / "two", fem=False, use_slicer=False)
    assert result.exit_code == 0, result.failed_checks
    expected = part_volumes_mm3(design)
    for name in design.part_names:
        assert result.report["parts"][name]["volume_mm3"] == pytest.approx(expected[name], rel=2e-4), name
    lo, hi = load_stl(result.out_dir / "passive_layer.stl").bounds
    assert lo[2] == pytest.approx(0.0, abs=1e-4) and hi[2] == pytest.approx(design.bottom_z0_mm, abs=1e-4)
    pours = [p for p in result.report["pours"] if p["mold"] == "mold_exterior+mold_interior"]
    assert [p["part"] for p in pours] == ["top_layer", "passive_layer"]
    assert "Cast the passive side" in (result.out_dir / "checklist.md").read_text()
    report = check_parts(result.out_dir, use_slicer=False)
    assert report.by_id("fit.passive.mirror").passed and report.by_id("cast.chambers_connected").passed

    moved = load_stl(result.out_dir / "passive_layer.stl")
    moved.apply_translation((1.0, 0.0, 0.0))
    trimesh.exchange.export.export_mesh(moved, str(result.out_dir / "passive_layer.stl"))
    assert check_parts(result.out_dir, use_slicer=False).by_id("fit.passive.mirror").passed is False


def test_the_section_counts_the_passive_side_as_the_top_layer_mirrored():
    """The sections' volume is the design's elastomer volume, and their first moment puts the passive
    side's material below the bottom layer: the mirror image of the top layer's about its mid-plane."""
    from pnmold.physics.section import interval_integrals

    one = load_design("spn", ["bottom_layer.thickness_mm=3", "paper.depth_mm=1.5"])
    two = load_design("spn", TWO_SIDED)
    got = {d: interval_integrals(d, np.array([0.0, d.length_mm])) for d in (one, two)}
    assert got[two]["volume_mm3"][0] == pytest.approx(two.elastomer_volume_mm3, rel=2e-3)
    top_one = got[one]["top_mm3"][0]
    assert got[two]["top_mm3"][0] == pytest.approx(2 * top_one, rel=1e-9)
    # the top layer's centroid rises by the passive side's height; the passive side's sits as far below zm
    zm, rise = two.mid_plane_z_mm, two.bottom_z0_mm
    top_z = got[one]["top_z_mm4"][0] / top_one + rise
    assert got[two]["top_z_mm4"][0] / got[two]["top_mm3"][0] == pytest.approx((top_z + (2 * zm - top_z)) / 2)
    assert got[two]["cavity_mm3"][0] == pytest.approx(got[one]["cavity_mm3"][0])  # only one side is driven


@pytest.mark.slow
def test_the_passive_side_resists_the_bend_and_only_the_driven_side_is_loaded(tmp_path):
    """FE on the characterisation's mesh (3.5/7 mm): the pressure loads only the driven side's cavity (above
    the bottom layer, but for the bore's tail), the sheet lies inside the body on its plane, and at the same
    pressure the two-sided segment bends less than the same segment without its passive side, but it bends.
    Solves the rest step and 10 kPa only (the two-sided segment bends 3.8 deg there, 0.69 of the one-sided's
    5.5; at 20 kPa 7.6 of 11.3 deg, 0.67, and at 40 kPa 18.6 of 27.7 deg, 0.67, each for a longer solve:
    the two-sided's 10 kPa takes 20 factorisations, its 20 kPa 29)."""
    from pnmold.cad import export_actuator_step
    from pnmold.design_fe import run_fe
    from pnmold.physics.characterise import DEFAULT_SIZE
    from pnmold.tetmesh import CAVITY, STRAIN_LIMITING_LAYER

    bends = {}
    for label, sets in (("one", ["bottom_layer.thickness_mm=3", "paper.depth_mm=1.5"]), ("two", TWO_SIDED)):
        design = load_design("spn", sets)
        step = export_actuator_step(design, tmp_path / label)
        run = run_fe(design, step_path=step, size=DEFAULT_SIZE, orientation="none", pressures_kpa=[10.0])
        bends[label] = [s.bend_angle_deg for s in run.solution.steps]
        nodes, facets = run.mesh.nodes_mm, run.mesh.facets
        bore_bottom = design.inlet_axis_z_mm - design.inlet.diameter_mm / 2  # the tail of the bore dips below
        assert nodes[facets[CAVITY]][:, :, 2].min() == pytest.approx(bore_bottom, abs=1e-6)
        sheet = nodes[facets[STRAIN_LIMITING_LAYER]][:, :, 2]
        assert sheet.size and np.allclose(sheet, design.sheet_z_mm, atol=1e-6)
    assert 0.0 < bends["two"][-1] < 0.8 * bends["one"][-1]
    assert bends["two"][0] < bends["two"][-1]
