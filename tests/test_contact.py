"""Self-contact (pnmold.fem.contact): the gap's derivatives, the penalty, and two blocks pressed
together against the closed form of the penalty (force balance, overlap ~ load / penalty,
Newton's quadratic convergence)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from skfem import MeshTet

from pnmold.fem import Load, Membrane, Model, Newton, NewtonOptions, Yeoh, kernels
from pnmold.fem.contact import SelfContact, penalty
from pnmold.fem.gap import gap, signed_distance
from tests.test_fem import TOL, check_tangent, closed_box, tetmesh

GAP0 = 0.05  # the blocks' gap in the reference shape, within the activation distance below
SIDE, HEIGHT = 2.0, 1.0


def contact(**kw) -> SelfContact:
    """The blocks are one body: 'another part' is anything beyond 0.02 mm, less than their gap."""
    return SelfContact(same_part_mm=0.02, **kw)


def test_gap_gradient_and_hessian_match_finite_differences():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((5, 4, 3))
    g, grad, hess = gap(x)
    h = 1e-6
    for c in range(12):
        dx = np.zeros((5, 12))
        dx[:, c] = h
        gp, grp, _ = gap(x + dx.reshape(5, 4, 3), want_hessian=False)
        gm, grm, _ = gap(x - dx.reshape(5, 4, 3), want_hessian=False)
        np.testing.assert_allclose((gp - gm) / (2 * h), grad[:, c], rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose((grp - grm) / (2 * h), hess[:, :, c], rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(hess, hess.transpose(0, 2, 1), atol=1e-12)
    normal = np.cross(x[:, 2] - x[:, 1], x[:, 3] - x[:, 1])
    np.testing.assert_allclose(g, np.einsum("ij,ij->i", x[:, 0] - x[:, 1], normal)
                               / np.linalg.norm(normal, axis=1))


@pytest.mark.parametrize("feature", [3, 2, 1], ids=["face", "edge", "vertex"])
def test_signed_distance_derivatives_match_finite_differences(feature):
    rng = np.random.default_rng(feature)
    x = rng.standard_normal((6, 4, 3))
    features = np.full(6, feature)
    g, grad, hess = signed_distance(x, features)
    h = 1e-6
    for c in range(12):
        dx = np.zeros((6, 12))
        dx[:, c] = h
        gp, grp, _ = signed_distance(x + dx.reshape(6, 4, 3), features, want_hessian=False)
        gm, grm, _ = signed_distance(x - dx.reshape(6, 4, 3), features, want_hessian=False)
        np.testing.assert_allclose((gp - gm) / (2 * h), grad[:, c], rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose((grp - grm) / (2 * h), hess[:, :, c], rtol=1e-5, atol=1e-7)
    normal = np.cross(x[:, 2] - x[:, 1], x[:, 3] - x[:, 1])
    side = np.sign(np.einsum("ij,ij->i", x[:, 0] - x[:, 1], normal))
    np.testing.assert_array_equal(np.sign(g), side)  # negative behind the face
    if feature == 1:
        np.testing.assert_allclose(np.abs(g), np.linalg.norm(x[:, 0] - x[:, 1], axis=1))
    if feature == 2:
        e = x[:, 2] - x[:, 1]
        np.testing.assert_allclose(np.abs(g), np.linalg.norm(np.cross(x[:, 0] - x[:, 1], e), axis=1)
                                   / np.linalg.norm(e, axis=1))


def test_the_penalty_is_c2_and_has_no_force_beyond_the_activation_distance():
    k, delta = 10.0, 0.1
    g = np.array([-0.3, -1e-9, 0.0, 1e-9, 0.05, delta - 1e-9, delta, delta + 1e-9, 0.4])
    phi, dphi, ddphi = penalty(g, k, delta)
    assert np.all(phi[g >= delta] == 0) and np.all(dphi[g >= delta] == 0) and np.all(ddphi[g >= delta] == 0)
    np.testing.assert_allclose(ddphi[[1, 2, 3]], k, rtol=1e-6)  # continuous at touch
    assert dphi[0] == pytest.approx(k * (-0.3 - delta / 2))
    h = 1e-7
    for f, df in ((0, 1), (1, 2)):
        plus, minus = penalty(g + h, k, delta)[f], penalty(g - h, k, delta)[f]
        np.testing.assert_allclose((plus - minus) / (2 * h), penalty(g, k, delta)[df], atol=1e-5)


def blocks() -> object:
    """Block A (z 0..1, clamped below) and block B (z 1.05..2.05) above it, 2 x 2 mm, their
    sides on rollers (named ``symmetry``: they are no contact surface)."""
    z = [0.0, 0.5, HEIGHT, HEIGHT + GAP0, 1.5 * HEIGHT + GAP0, 2 * HEIGHT + GAP0]
    skm = MeshTet.init_tensor(np.linspace(0, SIDE, 3), np.linspace(0, SIDE, 3), np.array(z))
    sides = {"clamp": lambda c: c[:, 2] < TOL,
             "symmetry": lambda c: (np.abs(c[:, 0] - SIDE / 2) > SIDE / 2 - TOL)
             | (np.abs(c[:, 1] - SIDE / 2) > SIDE / 2 - TOL)}
    return tetmesh(skm, sides, drop=lambda c: (c[:, 2] > HEIGHT) & (c[:, 2] < HEIGHT + GAP0))


def block_model(options: SelfContact) -> Model:
    return Model(blocks(), Yeoh(), None, {"clamp": (0, 1, 2), "symmetry": (0, 1)}, self_contact=options)


def expected_gap(pressure: float, k: float, delta: float) -> float:
    """Where the penalty's pressure -phi'(g) equals ``pressure`` (written out, not solved)."""
    if pressure >= k * delta / 2:
        return delta / 2 - pressure / k
    return delta - math.sqrt(2 * delta * pressure / k)


@pytest.mark.parametrize(("k", "pressure"), [(1.0, 0.1), (10.0, 0.02)], ids=["overlapping", "within-activation"])
def test_two_blocks_pressed_together_carry_the_weight_at_the_penalty_gap(k, pressure, capsys):
    options = contact(penalty_mpa_per_mm=k)
    model = block_model(options)
    weight = pressure * SIDE * SIDE  # B's weight over its footprint: the contact pressure
    load = Load(gravity_n_per_mm3=(0.0, 0.0, -pressure / HEIGHT))
    newton = Newton(model, NewtonOptions(rtol=1e-13, mixed=False, krylov_iterations=0, max_iterations=30))
    res = newton.solve(np.zeros(model.ndof), load)
    x = model.X + res.u.reshape(-1, 3)
    terms = model.contact.terms(x, want_k=False)
    on_b = np.zeros(model.ndof)
    kernels.scatter_vector(terms.residual, terms.gdofs, on_b)
    upper = model.X[:, 2] > HEIGHT + GAP0 / 2
    area = model.contact.area[model.contact.pairs(x)[0]]
    mean_gap = float(area @ terms.gaps_mm / area.sum())
    with capsys.disabled():
        print(f"\n[contact k={k} MPa/mm, P={pressure} MPa] |R| per Newton iteration: "
              + ", ".join(f"{r:.2e}" for r in res.residuals)
              + f"; gap {mean_gap:.5f} mm (closed form {expected_gap(pressure, k, options.activation_mm):.5f}),"
              f" {terms.gaps_mm.min():.5f} to {terms.gaps_mm.max():.5f} over the slave points")
    assert res.converged
    # B is held by the contact alone: its contact forces carry its weight
    assert on_b.reshape(-1, 3)[upper, 2].sum() == pytest.approx(-weight, rel=1e-9)
    assert res.evaluation.self_contact_n == pytest.approx(weight, rel=0.01)  # normals nearly vertical
    facing = np.abs(model.X[model.contact.facets[:, :3], 2] - HEIGHT - GAP0 / 2).max(axis=1) < GAP0
    assert terms.pairs == 3 * facing.sum()  # every slave point of both faces, one pair each
    # the mean gap is the closed form's; the master's reaction, spread linearly on each flat
    # triangle (not by the P2 shape functions), leaves it varying about it by ~10% of how far
    # the penalty has closed it (delta - g)
    closed = options.activation_mm - expected_gap(pressure, k, options.activation_mm)
    assert mean_gap == pytest.approx(expected_gap(pressure, k, options.activation_mm), abs=0.02 * closed)
    assert np.ptp(terms.gaps_mm) < 0.3 * closed


def quadratic_rates(residuals: list[float], floor: float) -> list[float]:
    """The orders ``log(r[i+1]/r[i]) / log(r[i]/r[i-1])`` where all three are above ``floor``."""
    r = [v for v in residuals if v > floor]
    return [math.log(r[i + 1] / r[i]) / math.log(r[i] / r[i - 1]) for i in range(1, len(r) - 1)]


def test_newton_converges_quadratically_through_the_contact():
    model = block_model(contact(penalty_mpa_per_mm=1.0))
    load = Load(gravity_n_per_mm3=(0.0, 0.0, -0.1 / HEIGHT))
    newton = Newton(model, NewtonOptions(rtol=1e-15, mixed=False, krylov_iterations=0, max_iterations=30))
    res = newton.solve(np.zeros(model.ndof), load)
    floor = 1e3 * np.finfo(float).eps * max(res.residuals)
    rates = quadratic_rates(res.residuals, floor)
    assert rates and rates[-1] > 1.7, res.residuals


def test_contact_tangent_matches_finite_differences():
    model = block_model(contact(penalty_mpa_per_mm=3.0))
    rng = np.random.default_rng(0)
    X = model.X
    u = np.where((X[:, 2] > HEIGHT + GAP0 / 2)[:, None], [0.0, 0.0, -0.12], 0.0)
    u = (u + 0.01 * rng.standard_normal(X.shape)).ravel()
    u[model.fixed] = 0.0
    ev = check_tangent(model, u, Load(gravity_n_per_mm3=(0.0, 0.0, -0.01)), rng, h=1e-7)
    assert ev.contact_pairs > 0 and ev.self_contact_n > 0


def test_without_the_option_there_is_no_contact():
    model = Model(blocks(), Yeoh(), None, {"clamp": (0, 1, 2), "symmetry": (0, 1)})
    X = model.X
    u = np.where((X[:, 2] > HEIGHT + GAP0 / 2)[:, None], [0.0, 0.0, -0.3], 0.0).ravel()
    ev = model.evaluate(u, Load())
    assert model.contact is None and ev.contact_pairs == 0 and ev.self_contact_n == 0.0
    touched = block_model(contact()).evaluate(u, Load())
    assert touched.contact_pairs > 0 and touched.energy > ev.energy


def test_the_pattern_grows_by_new_couplings_and_keeps_every_term_in_place():
    model = Model(closed_box(), Yeoh(), Membrane(), {"clamp": (0, 1, 2)})
    u = 0.02 * np.sin(model.X[:, [1, 2, 0]]).ravel()
    u[model.fixed] = 0.0
    load = Load(pressure_mpa=0.02, gravity_n_per_mm3=(0.0, 0.0, -1e-3))
    before = model.evaluate(u, load, want_k=True).matrix
    free = np.flatnonzero(model.free_index[0::3] >= 0)  # nodes whose x is free
    far = free[np.argsort(np.linalg.norm(model.X[free] - model.X[free[0]], axis=1))[[0, -1]]]
    model.pattern.positions(far[None, :])  # a coupling no element has: the pattern grows by it
    after = model.evaluate(u, load, want_k=True).matrix
    assert after.nnz > before.nnz
    assert abs(after - before).max() == 0.0  # solid, sheet and pressure terms where they were
    r, c = sorted(model.free_index[3 * far])

    def stored(m) -> bool:
        return bool(np.any(m.indices[m.indptr[r]:m.indptr[r + 1]] == c))

    assert stored(after) and not stored(before)
