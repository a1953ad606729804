"""gmsh meshes the exported STEP: volumes, named boundaries, outward facets, no state left."""

from __future__ import annotations

import signal
from pathlib import Path

import gmsh
import numpy as np
import pytest

from pnmold.design import load_design
from pnmold.mesh import boundary_facets, gmsh_session, mesh_actuator
from pnmold.tetmesh import CAVITY, CLAMP, FREE_END, STRAIN_LIMITING_LAYER, SYMMETRY, MeshSize
from tests.closed_form import cavity_mm3, part_volumes_mm3


def _enclosed(nodes, facets):
    p = nodes[facets]
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6)


@pytest.fixture(scope="module")
def fpn_mesh(built):
    result = built("fpn")
    return result.design, *mesh_actuator(result.out_dir / "actuator.step", result.design)


def test_mesh_volume_is_the_actuator_with_the_tube_in_the_bore(fpn_mesh):
    design, mesh, quality = fpn_mesh
    r = design.inlet.diameter_mm / 2
    tube = np.pi * r * r * design.channel_x_mm[0]  # the tube refills the bore up to the channel
    expected = part_volumes_mm3(design)["actuator"] + tube
    assert mesh.half and 2 * mesh.volume_mm3() == pytest.approx(expected, rel=2e-3)
    assert quality.n_tets == mesh.n_tets and quality.min_gamma > 0.01


def test_cavity_is_closed_and_has_its_closed_form_volume(fpn_mesh):
    design, mesh, _ = fpn_mesh
    # facets point out of the solid, i.e. into the air: the enclosed volume comes out negative;
    # the y = 0 cut adds nothing (x . n = 0 there), so twice the half is the whole cavity
    assert -2 * _enclosed(mesh.nodes_mm, mesh.facets[CAVITY]) == pytest.approx(cavity_mm3(design), rel=2e-3)


def test_every_boundary_facet_points_outward():
    # a unit cube split into tets: the outward-wound boundary encloses +1
    nodes = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]], float)
    tets = np.array([[0, 1, 3, 7], [0, 3, 2, 7], [0, 2, 6, 7], [0, 6, 4, 7], [0, 4, 5, 7], [0, 5, 1, 7]])
    p = nodes[tets]
    vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    facets = boundary_facets(tets)
    assert len(facets) == 12
    assert _enclosed(nodes, facets) == pytest.approx(1.0)


def test_named_boundaries_lie_where_the_supplement_puts_them(fpn_mesh):
    design, mesh, _ = fpn_mesh
    nodes = mesh.nodes_mm
    clamp = nodes[mesh.facets[CLAMP]].reshape(-1, 3)
    assert clamp[:, 0].max() <= design.cavity_x_mm(0)[1] + design.chambers.inside_wall_mm + 1e-6
    assert set(np.round(clamp[:, 2], 6)) == {0.0, round(design.height_mm, 6)}  # top and bottom faces
    paper = nodes[mesh.facets[STRAIN_LIMITING_LAYER]].reshape(-1, 3)
    assert np.allclose(paper[:, 2], 0.0)
    px, py = design.paper_size_mm
    area = 2 * sum(0.5 * np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0]))
                   for t in nodes[mesh.facets[STRAIN_LIMITING_LAYER]])
    assert area == pytest.approx(px * py, rel=1e-6)
    assert np.allclose(nodes[mesh.facets[FREE_END]][..., 0], design.length_mm)
    assert np.allclose(nodes[mesh.facets[SYMMETRY]][..., 1], 0.0)


def test_no_gmsh_state_is_left(fpn_mesh):
    assert not gmsh.isInitialized()


def _sigpipe_ignored() -> bool:
    """The kernel's view (Python's signal.getsignal only knows what Python itself set)."""
    line = next(x for x in Path("/proc/self/status").read_text().splitlines() if x.startswith("SigIgn:"))
    return bool(int(line.split()[1], 16) & (1 << (signal.SIGPIPE - 1)))


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads the signal mask from Linux /proc")
def test_meshing_leaves_sigpipe_ignored_as_python_set_it(fpn_mesh):
    """gmsh.initialize resets SIGPIPE to 'kill'; after that, a sweep coordinator writing to a
    crashed worker's pipe died with exit 141 instead of seeing BrokenPipeError."""
    assert _sigpipe_ignored()
    with gmsh_session():
        assert _sigpipe_ignored()
    assert _sigpipe_ignored()


def test_finer_size_gives_more_elements(built):
    result = built("spn")
    coarse, _ = mesh_actuator(result.out_dir / "actuator.step", result.design, MeshSize(2.0, 5.0))
    fine, _ = mesh_actuator(result.out_dir / "actuator.step", result.design, MeshSize(2.0, 5.0).refined(1.5))
    assert fine.n_tets > 1.5 * coarse.n_tets
    assert 2 * fine.volume_mm3() == pytest.approx(2 * coarse.volume_mm3(), rel=1e-6)


def test_meshing_the_same_step_twice_gives_the_same_mesh(built, fpn_mesh):
    """Repeatable meshes make repeatable FE curves and sweep rows (gmsh on one thread)."""
    design, first, _ = fpn_mesh
    again, _ = mesh_actuator(built("fpn").out_dir / "actuator.step", design)
    assert again.n_nodes == first.n_nodes and again.n_tets == first.n_tets
    assert np.array_equal(again.nodes_mm, first.nodes_mm)
    assert np.array_equal(again.tets, first.tets)


def test_a_rubber_layer_of_its_own_is_a_region_the_mesh_conforms_to(tmp_path):
    """The bottom layer's rubber differs: its elements are a region of their own, none crossing its top
    face; without paper no facet is the paper's."""
    from pnmold.cad import export_actuator_step
    from pnmold.tetmesh import BOTTOM_LAYER

    design = load_design("fpn", ["paper.present=false", "layer_material.name=Dragon Skin 30"])
    mesh, _ = mesh_actuator(export_actuator_step(design, tmp_path), design, MeshSize(3.5, 7.0))
    z = mesh.nodes_mm[mesh.tets][:, :, 2]
    bottom = np.zeros(len(mesh.tets), bool)
    bottom[mesh.regions[BOTTOM_LAYER]] = True
    assert bottom.any() and (~bottom).any()
    assert np.all(z[bottom].max(axis=1) <= design.top_z0_mm + 1e-6)
    assert np.all(z[~bottom].min(axis=1) >= design.top_z0_mm - 1e-6)
    assert len(mesh.facets[STRAIN_LIMITING_LAYER]) == 0


def test_a_longer_clamp_holds_the_top_and_bottom_faces_that_far(tmp_path):
    """``clamp.length_mm`` (a lab's clamp that holds more than the proximal chamber): the clamp's facets
    are the top and bottom faces up to that x and cover them there; the mesh conforms to its end."""
    from pnmold.cad import export_actuator_step

    design = load_design("fpn", ["clamp.length_mm=20"])
    assert design.proximal_end_mm < 20.0 == design.clamp_end_mm
    mesh, _ = mesh_actuator(export_actuator_step(design, tmp_path), design, MeshSize(3.5, 7.0))
    tri = mesh.nodes_mm[mesh.facets[CLAMP]][..., :3]
    assert tri[..., 0].max() == pytest.approx(20.0, abs=1e-6)
    assert set(np.round(tri[..., 2].ravel(), 6)) == {0.0, round(design.height_mm, 6)}

    def area(t):
        return float(0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum())

    outer = mesh.nodes_mm[boundary_facets(mesh.tets)]
    z = outer[..., 2]
    held = (outer[..., 0].max(axis=1) <= 20.0 + 1e-6) & (np.all(z < 1e-6, axis=1)
                                                        | np.all(z > design.height_mm - 1e-6, axis=1))
    assert area(tri) == pytest.approx(area(outer[held]), rel=1e-9)  # all of the top and bottom up to 20 mm


def test_an_embedded_sheet_is_the_inner_faces_on_its_plane(tmp_path):
    """``paper.depth_mm``: the mesh conforms to the sheet's plane inside the bottom layer; its facets are
    inner faces there (two tetrahedra each), covering the sheet's half outline, none on the bottom face."""
    from pnmold.cad import export_actuator_step

    design = load_design("fpn", ["bottom_layer.thickness_mm=3", "paper.depth_mm=1"])
    mesh, _ = mesh_actuator(export_actuator_step(design, tmp_path), design, MeshSize(3.5, 7.0))
    tri = mesh.nodes_mm[mesh.facets[STRAIN_LIMITING_LAYER]]
    assert np.allclose(tri[..., 2], 1.0)
    px, py = design.paper_size_mm
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    assert area == pytest.approx(px * py / 2, rel=1e-6)
    outer = {tuple(sorted(f)) for f in boundary_facets(mesh.tets)}
    assert not any(tuple(sorted(f)) in outer for f in mesh.facets[STRAIN_LIMITING_LAYER])
