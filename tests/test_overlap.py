"""The overlap measurement (pnmold.fem.overlap) on small synthetic bodies with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from skfem import MeshTet

from pnmold.export.p2 import quadratic_mesh
from pnmold.fem.overlap import (
    OVERLAP_DEPTH_MM,
    SAME_PART_MM,
    boundary_triangles,
    linear_tets,
    measure_overlap,
    same_part_for,
)
from pnmold.tetmesh import TetMesh

GAP = 2.0  # the fPN's gap between chambers


def boxes(*corners, size=(3.0, 3.0, 1.0), cells=(3, 3, 2)) -> TetMesh:
    """Structured boxes of ``size`` with their lower corners at ``corners`` (one body, unconnected)."""
    nodes, tets = [], []
    for corner in corners:
        axes = [np.linspace(c, c + s, n + 1) for c, s, n in zip(corner, size, cells, strict=True)]
        sk = MeshTet.init_tensor(*axes)
        tets.append(sk.t.T + sum(len(p) for p in nodes))
        nodes.append(sk.p.T)
    return TetMesh(np.vstack(nodes), np.vstack(tets))


@pytest.fixture(scope="module")
def stacked():
    """Block A (z 0..1) and block B (z 3..4) above it across a 2 mm gap, as 10-node cells."""
    return quadratic_mesh(boxes((0.0, 0.0, 0.0), (0.0, 0.0, 1.0 + GAP)))


def test_the_sub_tetrahedra_fill_each_cell_and_the_surface_is_closed(stacked):
    tets = linear_tets(stacked.cells)
    p = stacked.nodes_mm[tets]
    vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6
    assert np.abs(vol).sum() == pytest.approx(2 * 3 * 3 * 1.0, rel=1e-12)  # no gap, no double cover
    tri = boundary_triangles(tets)
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert set(counts) == {2}  # every surface edge shared by two surface triangles: closed


@pytest.mark.parametrize("push", [0.3, 0.45], ids=["0.3mm", "0.45mm"])
def test_a_block_pushed_into_another_is_found_with_its_depth(stacked, push):
    X = stacked.nodes_mm
    u = np.zeros_like(X)
    upper = X[:, 2] > 1.0 + GAP / 2
    u[upper, 2] = -(GAP + push)
    ov = measure_overlap(X, stacked.cells, u)
    found = set(ov.nodes.tolist())
    bottom_of_b = np.flatnonzero(upper & (np.abs(X[:, 2] - (1.0 + GAP)) < 1e-9))
    top_of_a = np.flatnonzero(~upper & (np.abs(X[:, 2] - 1.0) < 1e-9))
    assert set(bottom_of_b) | set(top_of_a) <= found  # every node of both faces in the other block
    z = X[ov.nodes, 2] + u[ov.nodes, 2]
    assert np.all((z >= 1.0 - push - 1e-9) & (z <= 1.0 + 1e-9))  # nothing outside the shared slab
    # away from the blocks' sides the nearest surface of the other block is its face, push deep
    middle = np.isin(ov.nodes, np.flatnonzero(np.all(np.abs(X[:, :2] - 1.5) < 1.5 - push - 1e-9, axis=1)))
    assert middle.sum() > 0
    np.testing.assert_allclose(ov.depth_mm[middle], push, atol=1e-9)
    np.testing.assert_allclose(ov.surface_depth_mm[middle], push, atol=1e-9)
    assert ov.max_depth_mm == pytest.approx(push, abs=1e-9)
    assert np.all(ov.surface_depth_mm <= ov.depth_mm + 1e-12)


def test_a_half_models_symmetry_plane_is_not_a_surface_its_nodes_are_measured_to(stacked):
    """The blocks lie at y >= 0, a half model's side of its symmetry plane: a node of B's bottom on
    that plane, pushed 0.02 mm into A, is 0.02 mm from A's outer surface (its top), not 0 from A's
    face on the plane, which the mirror half covers."""
    X = stacked.nodes_mm
    u = np.zeros_like(X)
    upper = X[:, 2] > 1.0 + GAP / 2
    u[upper, 2] = -(GAP + 0.02)
    ov = measure_overlap(X, stacked.cells, u)
    on_plane = (np.abs(X[ov.nodes, 1]) < 1e-9) & (np.abs(X[ov.nodes, 0] - 1.5) < 1.0) & upper[ov.nodes]
    assert on_plane.sum() >= 2
    np.testing.assert_allclose(ov.surface_depth_mm[on_plane], 0.02, atol=1e-9)
    # the same blocks as a whole model (moved to y < 0 in part): the plane's faces are surface again
    shifted = X - np.array([0.0, 1.5, 0.0])
    whole = measure_overlap(shifted, stacked.cells, u)
    assert set(whole.nodes.tolist()) == set(ov.nodes.tolist())
    side = np.isin(whole.nodes, ov.nodes[on_plane])
    np.testing.assert_allclose(whole.surface_depth_mm[side], 0.0, atol=1e-9)  # on B's side face, A's too


def test_blocks_across_a_narrow_gap_are_measured_with_under_half_of_it():
    """Blocks 0.8 mm apart pushed 0.1 mm into each other: with the default 1 mm the tetrahedra the
    nodes entered (0.8 mm from them in the reference shape) are the same part and nothing is found;
    with :func:`same_part_for` the gap's 0.36 mm, the overlap is found at its depth."""
    narrow = quadratic_mesh(boxes((0.0, 0.0, 0.0), (0.0, 0.0, 1.8)))
    X = narrow.nodes_mm
    u = np.zeros_like(X)
    u[X[:, 2] > 1.4, 2] = -(0.8 + 0.1)
    assert same_part_for(0.8) == pytest.approx(0.36) and same_part_for(2.0) == same_part_for(2.62) == SAME_PART_MM
    assert same_part_for(0.0) == SAME_PART_MM  # an sPN: no gap
    assert measure_overlap(X, narrow.cells, u).count() == 0
    ov = measure_overlap(X, narrow.cells, u, same_part_mm=same_part_for(0.8))
    assert ov.count() > 0 and ov.max_depth_mm == pytest.approx(0.1, abs=1e-9)


def test_blocks_brought_close_without_touching_do_not_overlap(stacked):
    X = stacked.nodes_mm
    u = np.zeros_like(X)
    u[X[:, 2] > 1.0 + GAP / 2, 2] = -(GAP - 0.05)
    ov = measure_overlap(X, stacked.cells, u)
    assert ov.nodes.size == 0 and ov.count() == 0 and ov.max_depth_mm == 0.0


def bent(strip: TetMesh, turn_deg: float, inner_radius_mm: float):
    """Displacement of the P2 nodes of a strip (x along it, z across its 1 mm thickness) wound
    about the y axis through ``turn_deg`` with that inner radius (no strain across it)."""
    qm = quadratic_mesh(strip)
    X = qm.nodes_mm
    length = X[:, 0].max()
    theta = math.radians(turn_deg) * X[:, 0] / length
    r = inner_radius_mm + 1.0 - X[:, 2]  # past a full turn the end comes back through the start
    x = np.column_stack([r * np.sin(theta), X[:, 1], (inner_radius_mm + 1.0) - r * np.cos(theta)])
    return qm, x - X


@pytest.mark.parametrize(("turn", "overlaps"), [(300.0, False), (350.0, False), (400.0, True)],
                         ids=["300deg", "350deg", "400deg"])
def test_a_strip_bent_without_touching_is_clear_and_wound_past_a_turn_is_not(turn, overlaps):
    sk = MeshTet.init_tensor(np.linspace(0, 30, 31), np.linspace(0, 2, 3), np.linspace(0, 1, 3))
    qm, u = bent(TetMesh(sk.p.T.copy(), sk.t.T.copy()), turn, inner_radius_mm=4.0)
    ov = measure_overlap(qm.nodes_mm, qm.cells, u)
    if not overlaps:
        assert ov.nodes.size == 0
    else:
        # the last 40 degrees come back through the first: the ends' nodes lie in each other
        assert ov.count() > 0 and ov.max_depth_mm > OVERLAP_DEPTH_MM
        ends = qm.nodes_mm[ov.nodes, 0]
        assert np.all((ends < 30 * 40 / 400 + 1.5) | (ends > 30 * 360 / 400 - 1.5))


def test_the_same_part_radius_decides_what_is_another_part(stacked):
    X = stacked.nodes_mm
    u = np.zeros_like(X)
    u[X[:, 2] > 1.0 + GAP / 2, 2] = -(GAP + 0.3)
    assert measure_overlap(X, stacked.cells, u, same_part_mm=SAME_PART_MM).count() > 0
    # when the gap itself counts as the same part, the blocks may pass through each other unseen
    assert measure_overlap(X, stacked.cells, u, same_part_mm=GAP + 0.5).nodes.size == 0


def test_a_vtu_series_read_back_measures_as_the_arrays(stacked, tmp_path):
    import meshio

    from pnmold.export.vtu import DISPLACEMENT, pvd_text, read_vtu_series

    X = stacked.nodes_mm
    states = [np.zeros_like(X), np.where((X[:, 2] > 1.0 + GAP / 2)[:, None], [0.0, 0.0, -(GAP + 0.3)], 0.0)]
    for i, u in enumerate(states):
        meshio.write(tmp_path / f"step_{i:03d}.vtu", meshio.Mesh(X, [("tetra10", stacked.cells)],
                                                                 point_data={DISPLACEMENT: u}))
    (tmp_path / "bending.pvd").write_text(pvd_text([(0.0, "step_000.vtu"), (5.0, "step_001.vtu")]))
    steps = read_vtu_series(tmp_path)
    assert [s.pressure_kpa for s in steps] == [0.0, 5.0]
    direct = measure_overlap(X, stacked.cells, states[1])
    read = measure_overlap(steps[1].nodes_mm, steps[1].cells, steps[1].displacement_mm)
    np.testing.assert_array_equal(read.nodes, direct.nodes)
    assert read.max_depth_mm == pytest.approx(0.3, abs=1e-9)
    assert measure_overlap(steps[0].nodes_mm, steps[0].cells, steps[0].displacement_mm).nodes.size == 0
