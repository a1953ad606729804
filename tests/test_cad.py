"""The exported parts: golden volumes, closed meshes, STEP = STL, casting consistency."""

from __future__ import annotations

import gmsh
import pytest

from pnmold.checks import solids as S
from pnmold.checks.mesh_checks import surface_pieces
from pnmold.checks.stlio import load_stl
from pnmold.design import load_design
from pnmold.mesh import gmsh_session
from tests.closed_form import cavity_mm3, part_volumes_mm3
from tests.conftest import TEMPLATES


@pytest.mark.parametrize("template", TEMPLATES)
def test_part_volumes_match_closed_form(built, template):
    result = built(template)
    expected = part_volumes_mm3(result.design)
    for name in result.design.part_names:
        got = result.report["parts"][name]["volume_mm3"]
        # boxes are exact; the tessellated inlet bore is the only curved face
        assert got == pytest.approx(expected[name], rel=2e-4), name


@pytest.mark.parametrize("template", TEMPLATES)
def test_every_stl_is_a_closed_consistently_wound_solid(built, template):
    result = built(template)
    out = result.out_dir
    for name in result.design.part_names:
        mesh = load_stl(out / f"{name}.stl")
        assert mesh.is_watertight, name
        assert mesh.is_winding_consistent, name
        assert mesh.volume > 0, name
        assert surface_pieces(mesh) == 1, name


@pytest.mark.parametrize("template", TEMPLATES)
def test_step_reimports_in_gmsh_with_the_stl_volume(built, template):
    result = built(template)
    out = result.out_dir
    with gmsh_session():
        for name in result.design.part_names:
            gmsh.clear()
            entities = gmsh.model.occ.importShapes(str(out / f"{name}.step"))
            gmsh.model.occ.synchronize()
            step_volume = sum(gmsh.model.occ.getMass(d, t) for d, t in entities if d == 3)
            stl_volume = load_stl(out / f"{name}.stl").volume
            assert stl_volume == pytest.approx(step_volume, rel=5e-3), name


def _solids(out, names):
    return {n: S.to_manifold(load_stl(out / f"{n}.stl"), n) for n in names}


@pytest.mark.parametrize("template", TEMPLATES)
def test_top_layer_molds_partition_the_casting_region(built, template):
    result = built(template)
    d, out = result.design, result.out_dir
    m = _solids(out, ["top_layer", "mold_interior", "mold_exterior"])
    top_volume = S.volume(m["top_layer"])
    tol = 1e-4 * top_volume  # 0.01 % of the top layer
    assert S.overlap(m["top_layer"], m["mold_interior"]) <= tol
    assert S.overlap(m["top_layer"], m["mold_exterior"]) <= tol
    assert S.overlap(m["mold_interior"], m["mold_exterior"]) <= tol
    z0 = d.top_z0_mm
    region = S.box((0, -d.width_mm / 2, z0), (d.length_mm, d.width_mm / 2, z0 + d.top_height_mm))
    assert S.void(region, list(m.values())) <= tol


@pytest.mark.parametrize("template", TEMPLATES)
def test_bottom_layer_and_its_mold_partition_the_casting_region(built, template):
    result = built(template)
    d, out = result.design, result.out_dir
    m = _solids(out, ["bottom_layer", "mold_bottom", "paper"])
    tol = 1e-4 * S.volume(m["bottom_layer"])
    assert S.overlap(m["bottom_layer"], m["mold_bottom"]) <= tol
    region = S.box((0, -d.width_mm / 2, 0), (d.length_mm, d.width_mm / 2, d.bottom_layer.thickness_mm))
    assert S.void(region, [m["bottom_layer"], m["mold_bottom"]]) <= tol
    # the paper lies inside the bottom layer, clear of the mold's stops
    assert S.overlap(m["paper"], m["bottom_layer"]) == pytest.approx(S.volume(m["paper"]), rel=1e-6)
    assert S.overlap(m["paper"], m["mold_bottom"]) <= tol


@pytest.mark.parametrize("template", TEMPLATES)
def test_cavity_has_its_closed_form_volume_and_opens_only_through_the_inlet(built, template):
    result = built(template)
    d = result.design
    actuator = S.to_manifold(load_stl(result.out_dir / "actuator.stl"))
    # as built, the cavity's surface joins the outer surface: it is open (through the bore)
    assert len(S.components(actuator)) == 1
    # plug the bore up to the channel's start: the cavity becomes one sealed void
    plug = S.cylinder_x(1.05 * d.inlet.diameter_mm / 2, -1.0, d.channel_x_mm[0], 0.0,
                        d.inlet_axis_z_mm)
    pieces = sorted(S.volume(c) for c in S.components(actuator + plug))
    assert len(pieces) == 2, "plugging the inlet must seal the cavity; something else is open"
    assert -pieces[0] == pytest.approx(cavity_mm3(d), rel=0.01)


def test_fpn_chambers_share_no_wall_and_spn_chambers_do(built):
    """fPN: the exterior mold's plates separate every pair of chambers above the floor."""
    for template, expect_plates in (("fpn", True), ("spn", False)):
        d = load_design(template)
        ext = S.to_manifold(load_stl(built(template).out_dir / "mold_exterior.stl"))
        z0 = d.top_z0_mm + d.top_layer.floor_mm
        between = S.box((d.cavity_x_mm(0)[1], -d.width_mm / 2, z0),
                        (d.cavity_x_mm(1)[0], d.width_mm / 2, d.height_mm))
        assert (S.overlap(ext, between) > 0) == expect_plates


@pytest.mark.slow
def test_a_rubber_layer_without_paper_builds_and_passes_the_gate(tmp_path):
    """A strain-limiting layer of its own rubber and no paper: no paper part, no paper stops in the
    bottom mold or layer, each pour of its own rubber, every check passing."""
    from pnmold.pipeline import build

    design = load_design("fpn", ["paper.present=false", "layer_material.name=Dragon Skin 30"])
    result = build(design, tmp_path / "layer", fem=False, use_slicer=False)
    assert result.exit_code == 0, result.failed_checks
    assert not (result.out_dir / "paper.stl").exists() and set(result.report["parts"]) == set(design.part_names)
    slab = design.length_mm * design.width_mm * design.bottom_layer.thickness_mm
    assert result.report["parts"]["bottom_layer"]["volume_mm3"] == pytest.approx(slab, rel=1e-6)  # no dimples
    pours = {p["part"]: p for p in result.report["pours"]}
    assert pours["bottom_layer"]["material"] == "Dragon Skin 30" and pours["top_layer"]["material"] == "Elastosil M4601"
    assert pours["bottom_layer"]["mass_g"] == pytest.approx(slab / 1000 * 1.08, rel=1e-4)
    assert pours["bottom_layer"]["part_a_g"] == pytest.approx(pours["bottom_layer"]["part_b_g"])  # 1:1
    assert "paper" not in (result.out_dir / "checklist.md").read_text().split("## 3.")[1].split("## 4.")[0]


def _built_to_closed_form(design, out):
    """Build ``design`` without FE or slicer; every check passes and every part has its closed-form volume."""
    from pnmold.pipeline import build

    result = build(design, out, fem=False, use_slicer=False)
    assert result.exit_code == 0, result.failed_checks
    expected = part_volumes_mm3(design)
    for name in design.part_names:
        assert result.report["parts"][name]["volume_mm3"] == pytest.approx(expected[name], rel=2e-4), name
    return result


def test_a_tip_wall_of_its_own_lengthens_the_body_and_passes_the_gate(tmp_path):
    """``chambers.tip_wall_mm`` (another lab's segment whose distal wall is not an inside wall):
    the body ends that far past the last chamber, every part keeps its closed-form volume,
    the actuator's STL spans the new length and every check passes."""
    base = load_design("spn")
    design = load_design("spn", ["chambers.tip_wall_mm=3.3"])
    assert design.length_mm == pytest.approx(base.length_mm - base.chambers.inside_wall_mm + 3.3)
    result = _built_to_closed_form(design, tmp_path / "tip")
    lo, hi = load_stl(result.out_dir / "actuator.stl").bounds
    assert hi[0] - lo[0] == pytest.approx(design.length_mm, abs=1e-4)  # STL: float32


def test_an_embedded_sheet_lies_on_its_first_pour_and_passes_the_gate(tmp_path):
    """``paper.depth_mm`` (a sheet embedded in the bottom layer on a first pour of rubber):
    the paper lies that high, the mold's stops rise a seat's height above it to locate its corners,
    every part keeps its closed-form volume and every check passes."""
    design = load_design("fpn", ["bottom_layer.thickness_mm=3", "paper.depth_mm=1"])
    result = _built_to_closed_form(design, tmp_path / "embedded")
    lo, hi = load_stl(result.out_dir / "paper.stl").bounds
    assert (lo[2], hi[2]) == pytest.approx((1.0, 1.0 + design.paper.thickness_mm), abs=1e-4)
    text = (result.out_dir / "checklist.md").read_text()
    assert text.index("Pour the first batch 1 mm deep") < text.index("Lay the paper flat on it") < text.index(
        "Pour over the paper")
