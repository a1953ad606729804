"""Self-contact (pnmold.fem.contact): the gap's derivatives, the penalty, and two blocks pressed
together against the closed form of the penalty (force balance, overlap ~ load / penalty,
Newton's quadratic convergence)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from skfem import MeshTet

from pnmold.fem import Load, Membrane, Model, Newton, NewtonOptions, Yeoh, kernels
from pnmold.fem.contact import ContactSurface, SelfContact, facing_weight, pair_energy, penalty
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


def test_the_facing_weight_is_c2_from_zero_to_one():
    lo, hi = SelfContact().facing
    c = np.array([0.0, lo - 1e-9, lo, lo + 1e-9, (lo + hi) / 2, hi - 1e-9, hi, hi + 1e-9, 1.0])
    w, dw, ddw = facing_weight(c, lo, hi)
    assert np.all(w[c <= lo] == 0) and np.all(w[c >= hi] == 1) and w[4] == pytest.approx(0.5)
    np.testing.assert_allclose(dw[[1, 2, 3, 5, 6, 7]], 0.0, atol=1e-6)  # flat at both ends
    np.testing.assert_allclose(ddw[[1, 2, 3, 5, 6, 7]], 0.0, atol=1e-5)
    h = 1e-7
    for f, df in ((0, 1), (1, 2)):
        plus, minus = facing_weight(c + h, lo, hi)[f], facing_weight(c - h, lo, hi)[f]
        # the third derivative jumps at both ends: a difference across them is off by O(h)
        np.testing.assert_allclose((plus - minus) / (2 * h), facing_weight(c, lo, hi)[df], atol=1e-4)


def beside_an_edge(feature: int, n: int, rng) -> np.ndarray:
    """``n`` slaves beside the edge (0, 0, 0)-(1, 0, 0) of the triangle (0, 0, 0), (1, 0, 0),
    (0, 1, 0) (feature 2), or beside its vertex at the origin (1), in front of it or behind,
    within the activation distance and facing it at angles inside the weight's band."""
    r = rng.uniform(0.02, 0.09, n) * rng.choice([-1.0, 1.0], n)
    cos = rng.uniform(0.3, 0.7, n)
    sin = np.sqrt(1 - cos ** 2)
    out = np.array([1.0, 1.0]) / math.sqrt(2) if feature == 1 else np.array([0.0, 1.0])
    xs = np.column_stack([0.4 * (feature == 2) - np.abs(r) * sin * out[0], -np.abs(r) * sin * out[1], r * cos])
    tri = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    x = np.concatenate([xs[:, None], np.repeat(tri[None], n, axis=0)], axis=1)
    return x + 0.003 * rng.standard_normal(x.shape)


@pytest.mark.parametrize("feature", [2, 1], ids=["edge", "vertex"])
def test_the_weighted_pair_energy_matches_finite_differences(feature, capsys):
    rng = np.random.default_rng(10 + feature)
    options = SelfContact()
    x = beside_an_edge(feature, 8, rng)
    features = np.full(len(x), feature)
    e, grad, hess, g, w = pair_energy(x, features, options)
    assert np.all((w > 0) & (w < 1)) and np.all(e > 0)  # every pair within the weight's band
    assert np.any(g < 0) and np.any(g > 0)
    h = 1e-7
    worst = [0.0, 0.0]
    for c in range(12):
        dx = np.zeros((len(x), 12))
        dx[:, c] = h
        ep, gp, _, _, _ = pair_energy(x + dx.reshape(x.shape), features, options, want_hessian=False)
        em, gm, _, _, _ = pair_energy(x - dx.reshape(x.shape), features, options, want_hessian=False)
        fd_grad, fd_hess = (ep - em) / (2 * h), (gp - gm) / (2 * h)
        worst = [max(worst[0], float(np.abs(fd_grad - grad[:, c]).max() / np.abs(grad).max())),
                 max(worst[1], float(np.abs(fd_hess - hess[:, :, c]).max() / np.abs(hess).max()))]
        np.testing.assert_allclose(fd_grad, grad[:, c], rtol=1e-5, atol=1e-7 * np.abs(grad).max())
        np.testing.assert_allclose(fd_hess, hess[:, :, c], rtol=1e-4, atol=1e-5 * np.abs(hess).max())
    np.testing.assert_allclose(hess, hess.transpose(0, 2, 1), atol=1e-9 * np.abs(hess).max())
    with capsys.disabled():
        print(f"\n[weighted pair, feature {feature}] finite differences against the analytic: gradient "
              f"{worst[0]:.1e}, Hessian {worst[1]:.1e} of their largest entries; weights {w.min():.2f}-{w.max():.2f}")


def two_facets(apart_mm: float, size_mm: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """A flat P2 facet at x 0..4 (z = 0, facing +z) and a small one (``size_mm``) ``apart_mm``
    further along x (z = 5, far from it), as reference node positions and facets."""
    corners = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0],
                        [apart_mm, 0.0, 5.0], [apart_mm + size_mm, 0.0, 5.0], [apart_mm, size_mm, 5.0]])
    edges = ((0, 1), (1, 2), (0, 2), (3, 4), (4, 5), (3, 5))
    X = np.vstack([corners, *[(corners[a] + corners[b]) / 2 for a, b in edges]])
    return X, np.array([[0, 1, 2, 6, 7, 8], [3, 4, 5, 9, 10, 11]])


def test_a_point_rounding_the_edge_of_a_surface_meets_no_jump_in_energy():
    """A small facet swept past the open edge of a flat one, from above its face to beside it:
    the energy changes along the sweep as its gradient says (trapezoid rule), with no jump where
    a pair comes or goes (a hard cut on the facing angle would jump there)."""
    X, facets = two_facets(0.0, 0.02)
    surface = ContactSurface(X, facets, SelfContact())
    moving = np.arange(12) % 6 >= 3
    angles = np.linspace(0.0, 0.5 * math.pi, 400)  # about the x axis, the big facet's edge y = 0
    energy, slope = [], []
    for a in angles:
        rel = X[moving] - X[3] + [1.0, 0.0, 0.0]
        at = np.array([0.0, -math.sin(a), math.cos(a)]) * 0.06  # 0.06 mm from the edge
        x = X.copy()
        x[moving] = rel + at
        terms = surface.terms(x, want_k=False)
        R = np.zeros(x.size)
        np.add.at(R, (3 * terms.gdofs[:, :, None] + np.arange(3)).ravel(), terms.residual.ravel())
        d_at = np.array([0.0, -math.cos(a), -math.sin(a)]) * 0.06
        energy.append(terms.energy)
        slope.append(float(R.reshape(-1, 3)[moving].sum(axis=0) @ d_at))
    energy, slope = np.array(energy), np.array(slope)
    assert energy[0] > 0 and energy[-1] == 0  # above the face it presses; beside it, none
    predicted = np.diff(angles) * (slope[1:] + slope[:-1]) / 2
    assert np.abs(np.diff(energy) - predicted).max() < 0.02 * energy.max()


def corner_and_facet(beside_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """A convex 90 degree corner -- a top facet (z = 0, x <= 0, facing +z) and a side facet (x = 0,
    z <= 0, facing +x) sharing the edge x = z = 0 -- and a small facet ``beside_mm`` from the side
    facet, 0.3 mm below the top's plane: a neighbouring chamber's wall closing on this one's."""
    corners = np.array([[-4.0, -2.0, 0.0], [0.0, -2.0, 0.0], [0.0, 2.0, 0.0],
                        [0.0, -2.0, 0.0], [0.0, -2.0, -4.0], [0.0, 2.0, 0.0],
                        [beside_mm, 0.0, -0.3], [beside_mm, 0.0, -0.32], [beside_mm, 0.02, -0.3]])
    edges = ((0, 1), (1, 2), (0, 2), (3, 4), (4, 5), (3, 5), (6, 7), (7, 8), (6, 8))
    X = np.vstack([corners, *[(corners[a] + corners[b]) / 2 for a, b in edges]])
    return X, np.array([[0, 1, 2, 9, 10, 11], [3, 4, 5, 12, 13, 14], [6, 7, 8, 15, 16, 17]])


def test_the_kept_candidate_list_finds_the_pairs_a_fresh_search_finds():
    """The small facet walks toward the side facet and past its edge in 0.02 mm steps: at each
    step the surface that kept its candidate list pairs exactly as one searching afresh, and the
    list is searched again only after the nodes moved past its margin."""
    options = SelfContact(same_part_mm=0.02)
    X, facets = corner_and_facet(0.3)
    kept = ContactSurface(X, facets, options)
    small = np.unique(facets[2])
    paired = 0
    for k in range(60):
        x = X.copy()
        x[small] += [-0.02 * min(k, 14), 0.0, 0.02 * max(k - 14, 0)]  # in to 0.02 mm, then up past the top
        got, fresh = kept.pairs(x), ContactSurface(X, facets, options).pairs(x)
        for a, b in zip(got, fresh, strict=True):
            np.testing.assert_array_equal(a, b)
        paired += got[0].size > 0
    assert paired > 10
    assert 1 < kept.searches < 20  # kept across steps, searched again after ~0.1 mm of travel


def valley_and_facet(x0: float) -> tuple[np.ndarray, np.ndarray]:
    """A concave valley -- two facets rising 30 degrees to either side of the edge x = z = 0, facing
    up into it -- and a sliver facing down into it 0.08 mm above the edge about ``x0`` (its slave
    points within 0.3 um of it): both slopes face them squarely, and which is nearer swaps at x = 0."""
    h = 4.0 * math.tan(math.radians(30.0))
    corners = np.array([[0.0, -2.0, 0.0], [4.0, -2.0, h], [0.0, 2.0, 0.0],
                        [0.0, -2.0, 0.0], [0.0, 2.0, 0.0], [-4.0, -2.0, h],
                        [x0 - 2e-4, 0.0, 0.08], [x0 - 2e-4, 0.02, 0.08], [x0 + 4e-4, 0.0, 0.08]])
    edges = ((0, 1), (1, 2), (0, 2), (3, 4), (4, 5), (3, 5), (6, 7), (7, 8), (6, 8))
    X = np.vstack([corners, *[(corners[a] + corners[b]) / 2 for a, b in edges]])
    return X, np.array([[0, 1, 2, 9, 10, 11], [3, 4, 5, 12, 13, 14], [6, 7, 8, 15, 16, 17]])


def test_a_point_over_a_valley_keeps_its_slope_while_the_other_is_barely_nearer():
    """Over a valley the nearest slope swaps at its middle, with a kink in the force's direction;
    Newton went back and forth across it and the path stalled. A slave keeps the slope of the last
    tangent while the other is nearer by less than ``hold_mm`` (1.3-1.6 um here, against 2 um), and
    takes the other once it is nearer by more (6 um); a residual alone moves nothing; a surface
    without that memory takes the nearer."""
    options = SelfContact(same_part_mm=0.02)

    def slopes(surface, x0, want_k=True):
        X, facets = valley_and_facet(x0)
        terms = surface.terms(X, want_k=want_k)
        right = np.isin(terms.gdofs[:, 6:], facets[0]).all(axis=1)
        assert terms.pairs == 3 and np.all(terms.facing == 1.0)  # every slave point, on a face
        return set(np.where(right, "right", "left"))

    X, facets = valley_and_facet(0.0005)
    surface = ContactSurface(X, facets, options)
    assert slopes(surface, 0.0005) == {"right"}
    assert slopes(ContactSurface(X, facets, options), -0.0015) == {"left"}  # no memory: the nearer
    assert slopes(surface, -0.0015) == {"right"}  # held
    assert slopes(surface, -0.006, want_k=False) == {"left"}  # the left nearer by 6 um: taken
    assert slopes(surface, -0.0015) == {"right"}  # that residual held nothing: still the right
    assert slopes(surface, -0.006) == {"left"}
    assert slopes(surface, -0.0015) == {"left"}  # a tangent there moved the hold to the left


def test_two_pieces_of_one_flat_face_never_pair_however_far_the_face_bends():
    """Two facets of one flat face, 2.2 mm apart in the reference shape (beyond the 1 mm same-part
    distance), the second then laid over the first 0.3 mm up, as a face pressed out into a dome puts
    one of its points behind another's triangle: one part, no pair (the sPN's end face paired so, 0.5 mm
    deep in a prediction, and its free run with contact ended 20 kPa early). (A body farther behind a face
    than ``same_part_mm`` stays another part: the blocks' prediction test below pairs block B with A's
    bottom face.)"""
    corners = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0],
                        [3.5, 0.0, 0.0], [5.5, 0.0, 0.0], [3.5, 2.0, 0.0]])
    edges = ((0, 1), (1, 2), (0, 2), (3, 4), (4, 5), (3, 5))
    X = np.vstack([corners, *[(corners[a] + corners[b]) / 2 for a, b in edges]])
    facets = np.array([[0, 1, 2, 6, 7, 8], [3, 4, 5, 9, 10, 11]])
    x = X.copy()
    second = np.unique(facets[1])
    x[second] += [-3.5, 0.0, 0.3]  # over the first, 0.3 mm up: its points 0.3 mm behind the second's plane
    surface = ContactSurface(X, facets, SelfContact())
    assert surface.terms(x, want_k=False).pairs == 0


def test_a_point_beside_a_wall_is_not_pushed_through_the_face_over_its_edge():
    """The small facet lies 0.36 mm from the top facet's edge, behind its plane, and 0.2 mm from the
    side facet (beyond the 0.1 mm activation). Its nearest surface is the side: no pair, no force
    (pairing it with the top facet, as when the window was applied before the nearest was chosen,
    pushed it up through the top as if 0.36 mm deep). At 0.06 mm the side facet pushes it away
    along +x, not up along z."""
    options = SelfContact(same_part_mm=0.02)
    X, facets = corner_and_facet(0.2)
    assert ContactSurface(X, facets, options).terms(X, want_k=False).pairs == 0
    X, facets = corner_and_facet(0.06)
    terms = ContactSurface(X, facets, options).terms(X, want_k=False)
    assert terms.pairs > 0 and np.all(terms.gaps_mm > 0)
    R = np.zeros(X.size)
    np.add.at(R, (3 * terms.gdofs[:, :, None] + np.arange(3)).ravel(), terms.residual.ravel())
    force = -R.reshape(-1, 3)[np.unique(facets[2])].sum(axis=0)  # on the small facet
    assert force[0] > 0 and abs(force[2]) < 0.01 * force[0]


@pytest.mark.parametrize("apart", [2.0, 12.0], ids=["neighbours", "the-two-ends"])
def test_the_ends_meet_where_a_pair_joins_points_half_the_body_apart(apart):
    X, facets = two_facets(apart)
    surface = ContactSurface(X, facets, SelfContact())
    x = X.copy()
    small = np.arange(len(X)) % 6 >= 3
    x[small] += [1.0 - apart, 1.0, -4.97]  # the small facet 0.03 mm above the big one
    terms = surface.terms(x, want_k=False)
    pairs, force = surface.ends_meet(x, X)
    assert terms.pairs > 0 and terms.force_n > 0
    length = np.ptp(X[:, 0])
    if apart > length / 2:  # the small facet is as far from the big one as the body is long
        assert pairs == terms.pairs and force == pytest.approx(terms.force_n, rel=1e-12)
    else:
        assert pairs == 0 and force == 0.0
    assert surface.ends_meet(X, X) == (0, 0.0)  # apart in the reference shape: no pair at all


def test_a_curve_whose_ends_meet_is_named_and_says_where():
    from pnmold.fem.results import STOPS, Step
    from pnmold.fem.solver import _stop

    step = Step(40.6, 10.0, 5.0, 329.0, 30.0, 1.8, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    stop, reason, fb = _stop("stopped", [step], {"ends_meet": (step, 3, 0.012)}, False, 3.0)
    assert stop == "tip_meets_base" and stop in STOPS and fb is None
    assert "40.6 kPa" in reason and "329.0 deg" in reason and "3 contact pairs" in reason
    assert "(1 contact pair carrying" in _stop("stopped", [step], {"ends_meet": (step, 1, 0.01)}, False, 3.0)[1]


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


def test_walls_facing_across_a_gap_narrower_than_the_same_part_distance_still_pair():
    """The blocks' facing faces are 0.05 mm apart, well within the default ``same_part_mm`` (1 mm),
    yet they face each other across air (normals opposed, each squarely in front of the other):
    they pair, at the gap's distance, and every pair joins the two blocks (a block's own face stays
    one part with itself)."""
    model = block_model(SelfContact())
    s, master, feature = model.contact.pairs(model.X)
    assert s.size > 0 and model.contact.closest_gap(model.X) == pytest.approx(GAP0)
    upper = model.X[:, 2] > HEIGHT + GAP0 / 2
    slave_upper = upper[model.contact.facets[s // 3]].all(axis=1)
    assert np.all(slave_upper != upper[master].all(axis=1))  # each pair joins the two blocks


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


def test_the_candidate_search_finds_every_pair_within_each_triangles_own_radius():
    """Against brute force, with a few triangles 50 times the others' size (a ballooned wall): the
    same pairs, each within its own triangle's radius, none more."""
    from pnmold.fem.overlap import near_pairs

    rng = np.random.default_rng(3)
    points, centroids = rng.uniform(0, 40, (800, 3)), rng.uniform(0, 40, (300, 3))
    radius = rng.uniform(0.5, 1.5, 300)
    radius[[7, 150]] = 50.0
    s, t, apart = near_pairs(points, centroids, radius)
    dist = np.linalg.norm(points[:, None] - centroids[None], axis=2)
    want = set(zip(*np.nonzero(dist <= radius[None]), strict=True))
    assert set(zip(s.tolist(), t.tolist(), strict=True)) == want and len(s) == len(want)
    assert np.allclose(apart, dist[s, t])


def test_the_nodal_contact_pressure_is_the_weight_over_the_footprint_where_the_blocks_touch():
    """The field written to the VTU files: on the touching faces' nodes the pressure that carries
    B's weight (the penalty's pressure is uniform there to the spread noted above), 0 elsewhere."""
    pressure = 0.02
    model = block_model(contact(penalty_mpa_per_mm=10.0))
    newton = Newton(model, NewtonOptions(rtol=1e-13, mixed=False, krylov_iterations=0, max_iterations=30))
    res = newton.solve(np.zeros(model.ndof), Load(gravity_n_per_mm3=(0.0, 0.0, -pressure / HEIGHT)))
    field = model.contact.nodal_pressure(model.X + res.u.reshape(-1, 3))
    z = model.X[:, 2]
    touching = np.abs(z - HEIGHT - GAP0 / 2) < GAP0  # the nodes of the two facing faces
    assert res.converged and field.shape == (len(model.X),)
    assert field[touching].mean() == pytest.approx(pressure, rel=0.05)
    assert field[touching].min() > 0.5 * pressure and field[touching].max() < 1.5 * pressure
    assert np.all(field[~touching] == 0.0)
    lifted = model.X + np.where((z > HEIGHT + GAP0 / 2)[:, None], [0.0, 0.0, 0.1], 0.0)
    assert np.all(model.contact.nodal_pressure(lifted) == 0.0)  # apart beyond the activation distance


def quadratic_rates(residuals: list[float], floor: float) -> list[float]:
    """The orders ``log(r[i+1]/r[i]) / log(r[i]/r[i-1])`` where all three are above ``floor``."""
    r = [v for v in residuals if v > floor]
    return [math.log(r[i + 1] / r[i]) / math.log(r[i] / r[i - 1]) for i in range(1, len(r) - 1)]


def test_newton_converges_quadratically_through_the_contact():
    """Quadratic in the error, read from Newton's corrections (each the error of the iterate it leaves,
    to leading order); the residual norm's own rate swings with the path the early iterations took (it
    read 2.9 at the end on one, 1.3 on another whose corrections fell 4e-4, 5e-6, 2e-10 mm)."""
    model = block_model(contact(penalty_mpa_per_mm=1.0))
    load = Load(gravity_n_per_mm3=(0.0, 0.0, -0.1 / HEIGHT))
    newton = Newton(model, NewtonOptions(rtol=1e-15, mixed=False, krylov_iterations=0, max_iterations=30))
    res = newton.solve(np.zeros(model.ndof), load)
    assert res.converged and res.residuals[-1] < 1e-9 * res.residuals[0]
    rates = quadratic_rates(res.step_norms, 1e3 * np.finfo(float).eps * max(res.step_norms))
    assert rates and rates[-1] > 1.7, res.step_norms


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


def test_a_pattern_grown_for_contact_holds_every_candidate_pair_not_only_the_touching_ones():
    """New contact pairs grow the tangent's pattern, and each new pattern costs the linear solver an analysis
    (on the default fPN build 29 analyses for 72 factorisations, 42 % of PARDISO's time). So when a pair
    needs a coupling the pattern lacks, it grows by the couplings of every candidate pair on the contact's
    list at once: pairs that meet later on that list need no new pattern (the fPN: 4 analyses)."""
    model = block_model(contact())
    model.evaluate(np.zeros(model.ndof), Load(), want_k=True)
    touching = model.contact.terms(model.X, want_k=False).gdofs
    listed = model.contact.listed_nodes()
    assert len(np.unique(listed, axis=0)) > len(np.unique(np.sort(touching, axis=1), axis=0))
    held = model.pattern.indices.size
    model.pattern.positions(listed)
    assert model.pattern.indices.size == held  # nothing left to grow by


def test_an_increment_whose_prediction_drives_the_blocks_together_is_shortened_before_it_is_solved():
    """Block B predicted to move down by the increment (1 mm per unit): halved until the
    prediction leaves the closest pair at least a quarter of the activation distance apart (the
    blocks start 0.05 mm apart: a quarter of 0.1 mm, 0.025 mm), so 1 -> 1/64 (0.016 mm down);
    moving up, or without self-contact, the increment is as asked."""
    from pnmold.fem.states import State, clear_of_contact

    model = block_model(contact())
    upper = (model.X[:, 2] > HEIGHT + GAP0 / 2)[:, None]
    state = State(0.0, np.zeros(model.ndof), 0.0, None)

    def down(t: float) -> tuple[np.ndarray, float, None]:
        return np.where(upper, [0.0, 0.0, -t], 0.0).ravel(), 0.0, None

    assert model.contact.closest_gap(model.X) == pytest.approx(GAP0)
    newton = Newton(model)
    t_new, (u, _, _) = clear_of_contact(newton, state, 1.0, down)
    assert t_new == pytest.approx(1 / 64)
    assert model.contact.closest_gap(model.X + u.reshape(-1, 3)) == pytest.approx(GAP0 - 1 / 64)
    assert model.contact.closest_gap(model.X + down(1 / 32)[0].reshape(-1, 3)) < 0.025  # one halving fewer fails
    assert newton.stats.contact_shortenings == 6
    assert clear_of_contact(newton, state, 1.0, lambda t: down(-t))[0] == 1.0
    apart = Model(blocks(), Yeoh(), None, {"clamp": (0, 1, 2), "symmetry": (0, 1)})
    assert clear_of_contact(Newton(apart), state, 1.0, down)[0] == 1.0
    # a prediction that closes the pair at once, whatever the increment's length: not shortened
    jump = clear_of_contact(newton, state, 1.0, lambda t: down(0.5 if t > 0 else 0.0))
    assert jump[0] == 1.0 and newton.stats.contact_shortenings == 6
    far = model.X + np.where(upper, [0.0, 0.0, 1.0], 0.0)
    assert model.contact.closest_gap(far) == contact().activation_mm  # no pair: the activation distance
    # a crawling path's increment of a few units in the last place is solved as asked, never
    # halved to nothing (it was, and the shortenings' count divided by zero)
    late = State(0.33835765922240857, np.zeros(model.ndof), 0.0, None)
    t_edge = 0.3383576592224087  # the first halving lands one place above late.t, the second on it
    assert clear_of_contact(newton, late, t_edge, lambda t: down(0.5 if t > late.t else 0.0))[0] == t_edge


def test_the_predictor_is_of_lower_order_where_contact_pairs_are_active():
    """Of the Newton options' order 4, the self-contact's order 2 from a state with pairs (the blocks
    0.05 mm apart, within the activation distance); order 4 from one without (B lifted 1 mm), and
    without self-contact."""
    from pnmold.fem.states import State, predictor_order

    model = block_model(contact())
    newton = Newton(model, NewtonOptions(predictor_order=4))
    lifted = np.where((model.X[:, 2] > HEIGHT + GAP0 / 2)[:, None], [0.0, 0.0, 1.0], 0.0).ravel()
    touching, apart = (State(0.0, u, 0.0, model.evaluate(u, Load())) for u in (np.zeros(model.ndof), lifted))
    assert touching.ev.contact_pairs > 0 and apart.ev.contact_pairs == 0
    assert predictor_order(newton, touching) == 2 and predictor_order(newton, apart) == 4
    bare = Model(blocks(), Yeoh(), None, {"clamp": (0, 1, 2), "symmetry": (0, 1)})
    state = State(0.0, np.zeros(bare.ndof), 0.0, bare.evaluate(np.zeros(bare.ndof), Load()))
    assert predictor_order(Newton(bare, NewtonOptions(predictor_order=4)), state) == 4
