"""Verification of pnmold.fem against closed forms, beam theory and its own consistency.

Meshes are structured boxes (scikit-fem's ``MeshTet.init_tensor``) turned into TetMesh
values here, so these tests need neither gmsh nor CAD.
"""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.integrate import quad
from scipy.optimize import brentq
from skfem import MeshTet

from pnmold.errors import MeshingError, SolveError, UsageError
from pnmold.fem import (
    Load,
    Membrane,
    Model,
    Newton,
    NewtonOptions,
    SolveOptions,
    Step,
    Yeoh,
    blocked_force_slope,
    full_bend_pressure,
    solve_bending,
    solve_blocked_force,
)
from pnmold.fem.path import continuation
from pnmold.tetmesh import TetMesh

TOL = 1e-9


# -- meshes ---------------------------------------------------------------------------------
def tetmesh(skm: MeshTet, selectors: dict, *, tip=(0.0, 0.0, 0.0), half=False,
            drop=None, mapping=None) -> TetMesh:
    """TetMesh from a scikit-fem mesh: ``drop(centroids)`` removes tets, ``selectors`` name
    boundary facets by their centroids, ``mapping(points)`` moves the nodes."""
    p, t = skm.p.T, skm.t.T
    if drop is not None:
        t = t[~drop(p[t].mean(axis=1))]
        used = np.unique(t)
        remap = np.full(len(p), -1)
        remap[used] = np.arange(used.size)
        p, t = p[used], remap[t]
        skm = MeshTet(p.T.copy(), t.T.copy())
    f = skm.facets[:, skm.boundary_facets()].T
    tet = skm.f2t[0, skm.boundary_facets()]
    c = p[f].mean(axis=1)
    if mapping is not None:
        p = mapping(p)
    normal = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])
    inward = p[skm.t[:, tet].T].mean(axis=1) - p[f].mean(axis=1)
    flip = np.einsum("ij,ij->i", normal, inward) > 0
    f[flip] = f[flip][:, [0, 2, 1]]
    tt = skm.t.T.copy()
    q = p[tt]
    det = np.einsum("ij,ij->i", np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]), q[:, 3] - q[:, 0])
    tt[det < 0] = tt[det < 0][:, [0, 2, 1, 3]]
    facets = {name: f[sel(c)] for name, sel in selectors.items()}
    return TetMesh(np.ascontiguousarray(p), tt, facets, {}, tuple(tip), half)


def mirror_y(mesh: TetMesh) -> TetMesh:
    """The full model of a half model (y >= 0): reflect, merge the y = 0 nodes."""
    p = mesh.nodes_mm
    on_plane = np.abs(p[:, 1]) < TOL
    new = np.flatnonzero(~on_plane)
    image = np.arange(len(p))
    image[new] = len(p) + np.arange(new.size)
    q = np.vstack([p, p[new] * [1.0, -1.0, 1.0]])
    tets = np.vstack([mesh.tets, image[mesh.tets][:, [0, 2, 1, 3]]])
    facets = {name: np.vstack([f, image[f][:, [0, 2, 1]]])
              for name, f in mesh.facets.items() if name != "symmetry"}
    return TetMesh(q, tets, facets, {}, mesh.tip_mm, False)


BEAM_L, BEAM_W, BEAM_H = 30.0, 4.0, 4.0


def hollow_beam() -> TetMesh:
    """Half (y >= 0) of a 30 x 4 x 4 mm beam with a closed 26 x 2 x 2 mm cavity."""
    skm = MeshTet.init_tensor(np.linspace(0, BEAM_L, 16), np.linspace(0, BEAM_W / 2, 3),
                              np.linspace(0, BEAM_H, 5))

    def in_cavity(c, pad=0.0):
        return ((c[:, 0] > 2 - pad) & (c[:, 0] < BEAM_L - 2 + pad) & (c[:, 1] < 1 + pad)
                & (c[:, 2] > 1 - pad) & (c[:, 2] < 3 + pad))

    selectors = {
        "cavity": lambda c: in_cavity(c, 0.01) & (c[:, 1] > TOL),
        "clamp": lambda c: c[:, 0] < TOL,
        "strain_limiting_layer": lambda c: c[:, 2] < TOL,
        "free_end": lambda c: c[:, 0] > BEAM_L - TOL,
        "symmetry": lambda c: c[:, 1] < TOL,
    }
    return tetmesh(skm, selectors, tip=(BEAM_L, 0.0, 0.0), half=True, drop=in_cavity)


@pytest.fixture(scope="module")
def beam() -> TetMesh:
    return hollow_beam()


def unit_block(n: int = 2, size=(1.0, 1.0, 1.0)) -> TetMesh:
    lx, ly, lz = size
    skm = MeshTet.init_tensor(np.linspace(0, lx, n + 1), np.linspace(0, ly, n + 1),
                              np.linspace(0, lz, n + 1))
    return tetmesh(skm, {"x0": lambda c: c[:, 0] < TOL, "x1": lambda c: c[:, 0] > lx - TOL,
                         "y0": lambda c: c[:, 1] < TOL,
                         "strain_limiting_layer": lambda c: c[:, 2] < TOL})


# -- a. homogeneous uniaxial stretch --------------------------------------------------------
def yeoh_w1(mat: Yeoh, i1bar: float) -> float:
    x = i1bar - 3.0
    return mat.c10_mpa + 2 * mat.c20_mpa * x + 3 * mat.c30_mpa * x * x


def uniaxial_incompressible(mat: Yeoh, lam: float) -> float:
    """Nominal stress of incompressible Yeoh in uniaxial tension."""
    return 2.0 * (lam - lam ** -2) * yeoh_w1(mat, lam ** 2 + 2.0 / lam)


def uniaxial_penalty(mat: Yeoh, lam: float) -> float:
    """Nominal stress of the penalised model (lateral stretch from P22 = 0)."""
    k = mat.bulk_modulus_mpa

    def stresses(l2):
        j = lam * l2 * l2
        i1 = lam ** 2 + 2 * l2 * l2
        w1 = yeoh_w1(mat, j ** (-2 / 3) * i1)
        p11 = w1 * j ** (-2 / 3) * (2 * lam - 2 / 3 * i1 / lam) + k * (j - 1) * l2 * l2
        p22 = w1 * j ** (-2 / 3) * (2 * l2 - 2 / 3 * i1 / l2) + k * (j - 1) * lam * l2
        return p11, p22

    l2 = brentq(lambda s: stresses(s)[1], 0.2, 1.5, xtol=1e-15)
    return stresses(l2)[0]


@pytest.mark.parametrize("volumetric", ["mean_dilatation", "penalty"])
@pytest.mark.parametrize("bulk_ratio", [200.0, 5000.0], ids=["K200", "K5000"])
def test_uniaxial_stretch_matches_closed_form(volumetric, bulk_ratio):
    mat = Yeoh(bulk_ratio=bulk_ratio, volumetric=volumetric)
    model = Model(unit_block(), mat, None, {"x0": (0,), "x1": (0,), "y0": (1,),
                                            "strain_limiting_layer": (2,)})
    newton = Newton(model, NewtonOptions(max_correction=10.0))  # displacement-driven
    pulled = 3 * model.fixed_sets["x1"]
    u = 0.05 * (model.X * [1.0, -0.5, -0.5]).ravel()  # guess: homogeneous 5% stretch
    for lam in np.linspace(1.05, 2.0, 20):
        u[pulled] = lam - 1.0
        res = newton.solve(u, Load())
        assert res.converged
        u = res.u * (lam + 0.05 - 1.0) / (lam - 1.0)  # predictor for the next stretch
        nominal = res.evaluation.residual[pulled].sum()  # force on the 1 mm^2 face
        assert nominal == pytest.approx(uniaxial_penalty(mat, lam), rel=1e-5)
        if bulk_ratio >= 5000:
            assert nominal == pytest.approx(uniaxial_incompressible(mat, lam), rel=0.01)


def test_membrane_has_exact_stretching_stiffness():
    """A paper sheet on a nearly stress-free block: force = E t w lam (lam^2 - 1) / 2.
    (Pulled along x, free across: the sheet is taut, the plain and relaxed sheets agree;
    the plain one, as the stress-free block gives the wrinkled sheet no lateral stiffness;
    the sheet's own E, not the solve's series stiffness on this near-void block.)"""
    soft = Yeoh(c10_mpa=1e-5, c20_mpa=0.0)
    paper = Membrane(wrinkles=False, contrast=None)
    mesh = unit_block(n=2, size=(4.0, 2.0, 1.0))
    model = Model(mesh, soft, paper, {"x0": (0,), "x1": (0,), "y0": (1,),
                                      "strain_limiting_layer": (2,)})
    pulled = 3 * model.fixed_sets["x1"]
    u = np.zeros(model.ndof)
    lam = 1.01
    u[pulled] = 4.0 * (lam - 1.0)
    res = Newton(model, NewtonOptions(max_correction=10.0)).solve(u, Load())
    assert res.converged
    force = res.evaluation.residual[pulled].sum()
    expected = paper.stiffness_n_per_mm * 2.0 * lam * (lam ** 2 - 1) / 2
    assert force == pytest.approx(expected, rel=1e-3)


# -- b. thick-walled cylinder, plane strain -------------------------------------------------
CYL_A, CYL_B = 5.0, 10.0


def cylinder_pressure(mat: Yeoh, lam_a: float) -> float:
    """Incompressible plane-strain inflation: p = int_a^b 2 W1 (l^2 - l^-2) dr / r."""
    a = lam_a * CYL_A
    b = math.sqrt(CYL_B ** 2 + a * a - CYL_A ** 2)

    def integrand(r):
        lam = r / math.sqrt(r * r - a * a + CYL_A ** 2)
        return 2 * yeoh_w1(mat, lam * lam + lam ** -2 + 1) * (lam * lam - lam ** -2) / r

    return quad(integrand, a, b, epsabs=1e-13, epsrel=1e-12)[0]


def quarter_ring(nr: int, nt: int) -> TetMesh:
    skm = MeshTet.init_tensor(np.linspace(CYL_A, CYL_B, nr + 1),
                              np.linspace(0, math.pi / 2, nt + 1), np.linspace(0, 1.0, 2))

    def polar(p):
        return np.column_stack([p[:, 0] * np.cos(p[:, 1]), p[:, 0] * np.sin(p[:, 1]), p[:, 2]])

    return tetmesh(skm, {"cavity": lambda c: c[:, 0] < CYL_A + TOL,
                         "sym_y": lambda c: c[:, 1] < TOL,
                         "sym_x": lambda c: c[:, 1] > math.pi / 2 - TOL,
                         "ends": lambda c: (c[:, 2] < TOL) | (c[:, 2] > 1 - TOL)},
                   mapping=polar)


def inflate_ring(nr: int, nt: int, mat: Yeoh, pressures_mpa: list[float]) -> list[float]:
    """Inner stretch of the FE ring at each pressure."""
    model = Model(quarter_ring(nr, nt), mat, None, {"sym_y": (1,), "sym_x": (0,),
                                                    "ends": (2,)})
    inner = np.unique(model.facet_dofs["cavity"][:, :3])
    stretches = []

    def record(p, u, ev):
        x = model.X[inner] + u.reshape(-1, 3)[inner]
        stretches.append(float(np.mean(np.hypot(x[:, 0], x[:, 1]))) / CYL_A)
        return False, math.inf

    continuation(Newton(model), np.zeros(model.ndof), lambda p: Load(p), 0.0,
                 pressures_mpa[-1], pressures_mpa[0], pressures_mpa[-1], record,
                 targets=pressures_mpa)
    return stretches


def test_thick_cylinder_inflation_converges_to_closed_form(record_property):
    mat = Yeoh(bulk_ratio=5000.0)
    p_max = cylinder_pressure(mat, 1.6)
    pressures = [p_max * s for s in (0.25, 0.5, 0.75, 1.0)]
    errors = []
    for nr, nt in [(1, 4), (2, 8), (4, 16)]:
        lam = inflate_ring(nr, nt, mat, pressures)
        err = max(abs(cylinder_pressure(mat, la) - p) / p for la, p in zip(lam, pressures,
                                                                         strict=True))
        errors.append(err)
        assert lam[-1] >= 1.5
    rates = [math.log2(e0 / e1) for e0, e1 in zip(errors, errors[1:], strict=False)]
    record_property("cylinder_errors", errors)
    record_property("cylinder_rates", rates)
    print(f"cylinder pressure errors {errors}, observed rates {rates}")
    assert errors[-1] < 0.02
    assert errors[0] > errors[1] > errors[2]


# -- c. cantilever under gravity ------------------------------------------------------------
CANTILEVER_L, CANTILEVER_W, CANTILEVER_H = 60.0, 3.0, 3.0
SAG_SCALE = 0.01  # of g: small deflection


def half_cantilever(nz: int) -> TetMesh:
    """Half (y >= 0) of a 60 x 3 x 3 mm bar, clamped at x = 0, ``nz`` element layers."""
    skm = MeshTet.init_tensor(np.linspace(0, CANTILEVER_L, 31), np.linspace(0, CANTILEVER_W / 2, 3),
                              np.linspace(0, CANTILEVER_H, nz + 1))
    return tetmesh(skm, {"clamp": lambda c: c[:, 0] < TOL,
                         "symmetry": lambda c: c[:, 1] < TOL,
                         "free_end": lambda c: c[:, 0] > CANTILEVER_L - TOL}, half=True)


def gravity_sag(mesh: TetMesh, body: Yeoh, regions=None) -> float:
    """Mean sag (mm) of the free end under ``SAG_SCALE`` g of ``body``'s weight density."""
    model = Model(mesh, body, None, {"clamp": (0, 1, 2), "symmetry": (1,)}, regions=regions)
    g = SAG_SCALE * body.weight_density_n_per_mm3
    res = Newton(model).solve(np.zeros(model.ndof), Load(gravity_n_per_mm3=(0, 0, -g)))
    assert res.converged
    end = np.unique(model.facet_dofs["free_end"])
    return float(-res.u.reshape(-1, 3)[end, 2].mean())


def test_cantilever_sag_matches_beam_theory():
    mat = Yeoh()
    sag = gravity_sag(half_cantilever(3), mat)
    q = SAG_SCALE * mat.weight_density_n_per_mm3 * CANTILEVER_W * CANTILEVER_H
    inertia = CANTILEVER_W * CANTILEVER_H ** 3 / 12
    expected = q * CANTILEVER_L ** 4 / (8 * mat.youngs_modulus_mpa * inertia)
    assert sag == pytest.approx(expected, rel=0.03)


def test_two_rubber_cantilever_sags_as_a_composite_beam():
    """A bottom third cast in a 4x stiffer, 1.5x denser rubber (``regions``): the sag is the
    transformed-section beam's, with the weight of both rubbers."""
    width, height, layer_mm = CANTILEVER_W, CANTILEVER_H, 1.0
    mesh = half_cantilever(6)
    low = np.flatnonzero(mesh.nodes_mm[mesh.tets][:, :, 2].mean(axis=1) < layer_mm)
    mesh = dataclasses.replace(mesh, regions={"bottom_layer": low})
    body = Yeoh()
    stiff = Yeoh(c10_mpa=4 * body.c10_mpa, c20_mpa=4 * body.c20_mpa, c30_mpa=4 * body.c30_mpa,
                 density_g_per_ml=1.5 * body.density_g_per_ml)
    sag = gravity_sag(mesh, body, {"bottom_layer": stiff})
    a1, a2 = width * layer_mm, width * (height - layer_mm)  # stiff layer, body
    q = SAG_SCALE * body.weight_density_n_per_mm3 * (1.5 * a1 + a2)
    n = 4.0  # modular ratio; transformed section in body units
    zc = (n * a1 * layer_mm / 2 + a2 * (layer_mm + height) / 2) / (n * a1 + a2)
    inertia = (n * (width * layer_mm ** 3 / 12 + a1 * (zc - layer_mm / 2) ** 2)
               + width * (height - layer_mm) ** 3 / 12 + a2 * (zc - (layer_mm + height) / 2) ** 2)
    expected = q * CANTILEVER_L ** 4 / (8 * body.youngs_modulus_mpa * inertia)
    assert sag == pytest.approx(expected, rel=0.03)
    assert gravity_sag(mesh, body) > 1.5 * sag  # the stiff layer matters


def test_clamp_reaction_carries_the_weight_of_two_rubbers(beam):
    low = np.flatnonzero(beam.nodes_mm[beam.tets][:, :, 2].mean(axis=1) < 1.0)
    two = dataclasses.replace(beam, regions={"bottom_layer": low})
    body = Yeoh()
    heavy = Yeoh(c10_mpa=2 * body.c10_mpa, density_g_per_ml=2.0)
    sol = solve_bending(two, body, pressures_kpa=[2.0], gravity=(0, 0, -1),
                        regions={"bottom_layer": heavy})
    p = two.nodes_mm[two.tets]
    vols = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6
    weight = 2 * (body.weight_density_n_per_mm3 * (vols.sum() - vols[low].sum())
                  + heavy.weight_density_n_per_mm3 * vols[low].sum())  # a half model
    assert sol.steps[-1].clamp_reaction_n[2] == pytest.approx(weight, rel=1e-6)
    with pytest.raises(MeshingError, match="bottom_layer"):
        Model(beam, body, None, {"clamp": (0, 1, 2)}, regions={"bottom_layer": heavy})


# -- d. tangent check -----------------------------------------------------------------------
def closed_box() -> TetMesh:
    skm = MeshTet.init_tensor(np.linspace(0, 6, 7), np.linspace(0, 3, 4), np.linspace(0, 3, 4))

    def in_cavity(c, pad=0.0):
        return ((c[:, 0] > 1 - pad) & (c[:, 0] < 5 + pad) & (c[:, 1] > 1 - pad)
                & (c[:, 1] < 2 + pad) & (c[:, 2] > 1 - pad) & (c[:, 2] < 2 + pad))

    return tetmesh(skm, {"cavity": lambda c: in_cavity(c, 0.01), "clamp": lambda c: c[:, 0] < TOL,
                         "strain_limiting_layer": lambda c: c[:, 2] < TOL,
                         "free_end": lambda c: c[:, 0] > 6 - TOL}, drop=in_cavity)


@pytest.mark.parametrize("volumetric", ["mean_dilatation", "penalty"])
def test_tangent_matches_finite_differences(volumetric):
    model = Model(closed_box(), Yeoh(bulk_ratio=50, volumetric=volumetric), Membrane(),
                  {"clamp": (0, 1, 2)})
    rng = np.random.default_rng(0)
    X = model.X
    u = (0.05 * np.sin(X[:, [1, 2, 0]]) + 0.02 * rng.standard_normal(X.shape)).ravel()
    u[model.fixed] = 0.0
    load = Load(pressure_mpa=0.03, gravity_n_per_mm3=(0, 1e-3, -2e-3), plane_z_mm=0.02,
                plane_stiffness_n_per_mm=3.0)
    check_tangent(model, u, load, rng)


def check_tangent(model: Model, u: np.ndarray, load: Load, rng, h: float = 1e-6):
    """The assembled tangent at ``u`` against central differences of the residual along a random
    direction, and the residual against the energy's; returns the evaluation at ``u``."""
    ev = model.evaluate(u, load, want_k=True)
    upper = ev.matrix
    tangent = upper + upper.T - sp.diags(upper.diagonal())
    v = np.zeros(model.ndof)
    v[model.free] = rng.standard_normal(model.free.size)
    plus, minus = model.evaluate(u + h * v, load), model.evaluate(u - h * v, load)
    fd = ((plus.residual - minus.residual) / (2 * h))[model.free]
    kv = tangent @ v[model.free]
    assert np.linalg.norm(fd - kv) / np.linalg.norm(kv) < 1e-6
    slope = (plus.energy - minus.energy) / (2 * h)
    assert slope == pytest.approx(ev.residual @ v, rel=1e-6)
    return ev


# -- e. symmetry --------------------------------------------------------------------------
def test_half_and_full_models_agree(beam):
    pressures = [20.0, 40.0]
    half = solve_bending(beam, pressures_kpa=pressures)
    full = solve_bending(mirror_y(beam), pressures_kpa=pressures)
    for h, f in zip(half.steps, full.steps, strict=True):
        assert h.tip_z_mm == pytest.approx(f.tip_z_mm, rel=0.01)
        assert h.bend_angle_deg == pytest.approx(f.bend_angle_deg, rel=0.01)
        assert h.cavity_volume_ml == pytest.approx(f.cavity_volume_ml, rel=1e-6)
    assert half.steps[-1].bend_angle_deg > 1.5


# -- f. failure ---------------------------------------------------------------------------
def test_solve_error_names_last_converged_pressure(beam):
    options = SolveOptions(first_angle_step_deg=30.0,
                           newton=NewtonOptions(max_cuts=0, growth=4.0))
    with pytest.raises(SolveError) as info:
        solve_bending(beam, max_pressure_kpa=1e5, options=options)
    err = info.value
    assert err.last_converged is not None and err.last_converged > 0
    assert f"last converged pressure {err.last_converged:.4g} kPa" in str(err)
    assert err.residuals


# -- observables and loads ------------------------------------------------------------------
def test_reference_cavity_volume_and_curl_direction(beam):
    sol = solve_bending(beam, pressures_kpa=[10.0])
    rest, loaded = sol.steps
    assert rest.cavity_volume_ml == pytest.approx(26 * 2 * 2 / 1000, rel=1e-12)
    assert (rest.tip_x_mm, rest.tip_z_mm, rest.bend_angle_deg) == pytest.approx((30, 0, 0))
    assert loaded.cavity_volume_ml > rest.cavity_volume_ml
    assert loaded.bend_angle_deg > 0 and loaded.tip_z_mm < 0  # curls toward the paper
    assert sol.full_bend_pressure_kpa is None and "deg" in sol.reason


def test_clamp_reaction_carries_the_weight(beam):
    mat = Yeoh()
    sol = solve_bending(beam, mat, pressures_kpa=[2.0], gravity=(0, 0, -1))
    volume = BEAM_L * BEAM_W * BEAM_H - 26 * 2 * 2
    weight = mat.weight_density_n_per_mm3 * volume
    for step in sol.steps:
        assert step.clamp_reaction_n == pytest.approx((0, 0, weight), abs=1e-6 * weight)
    assert sol.steps[0].tip_z_mm < 0


def test_bulk_ratio_sensitivity(beam, record_property):
    """How the tip moves with K/mu (mean dilatation): converges as K grows."""
    tips = {k: solve_bending(beam, Yeoh(bulk_ratio=k), pressures_kpa=[20.0]).steps[-1].tip_z_mm
            for k in (50.0, 200.0, 1000.0)}
    record_property("tip_z_by_bulk_ratio", tips)
    print(f"tip z by K/mu: {tips}")
    change_200 = abs(tips[200.0] - tips[1000.0]) / abs(tips[1000.0])
    change_50 = abs(tips[50.0] - tips[1000.0]) / abs(tips[1000.0])
    assert tips[50.0] < tips[200.0] < tips[1000.0] < 0  # stiffer in volume, less curl
    assert change_200 < change_50 / 2
    assert change_200 < 0.05


def test_blocked_force_grows_with_pressure(beam):
    sol = solve_blocked_force(beam, pressures_kpa=[5.0, 10.0, 20.0])
    forces = [s.force_n for s in sol.steps]
    assert forces[0] == 0.0
    assert 0 < forces[1] < forces[2] < forces[3]
    assert all(s.tip_z_mm > -0.05 for s in sol.steps)  # held by the plane


def test_linearised_blocked_force_matches_the_nonlinear_curve_at_small_pressure(beam):
    """The build's blocked force (first order in pressure) against the nonlinear contact solve:
    the same reaction at rest, and the same slope while the deflection is small."""
    gravity = (0.0, 0.0, -1.0)
    lin = blocked_force_slope(beam, gravity=gravity)
    sol = solve_blocked_force(beam, pressures_kpa=[1.0, 2.0], gravity=gravity)
    rest, *pressed = sol.steps
    assert rest.force_n > 0  # the plane carries part of the weight
    assert lin.force0_n == pytest.approx(rest.force_n, rel=1e-6)
    assert lin.slope_n_per_kpa > 0
    for step in pressed:
        assert lin.force_n(step.pressure_kpa) == pytest.approx(step.force_n, rel=0.02)


def test_fem_does_not_import_gmsh_or_cadquery():
    code = "import sys, pnmold.fem; print(sorted({'gmsh', 'cadquery'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def _step(p: float, angle: float) -> Step:
    return Step(p, 0.0, 0.0, angle, 0.0, 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


def test_full_bend_pressure_is_interpolated_or_explained():
    steps = [_step(0, 0), _step(40, 300), _step(50, 400)]
    assert full_bend_pressure(steps) == (pytest.approx(46.0), None)
    pressure, reason = full_bend_pressure(steps[:2])
    assert pressure is None and "300.0 deg at 40 kPa" in reason
    keys = {"pressure_kpa", "tip_x_mm", "tip_z_mm", "bend_angle_deg", "cavity_volume_ml",
            "max_principal_stretch"}
    assert keys <= set(steps[1].as_dict()) and "force_n" not in steps[1].as_dict()


def test_stretch_field_and_boundary_of_a_homogeneous_stretch():
    """The report's strain picture: a block stretched 1.3x along x shows 1.3 at every node,
    and its boundary is the cube's surface, wound outward, without inner faces."""
    from pnmold.report.fem import boundary_triangles, stretch_field

    mesh = unit_block(n=2)
    u = np.zeros_like(mesh.nodes_mm)
    u[:, 0] = 0.3 * mesh.nodes_mm[:, 0]
    u[:, 1] = -0.1 * mesh.nodes_mm[:, 1]
    lam = stretch_field(mesh, u)
    assert np.allclose(lam, 1.3, rtol=1e-12)
    tris = boundary_triangles(mesh)
    p = mesh.nodes_mm[tris]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    assert area.sum() == pytest.approx(6.0)  # the unit cube's surface, no inner face
    normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    outward = np.einsum("ij,ij->i", normals, p.mean(axis=1) - 0.5)
    assert np.all(outward > 0)  # wound with the outward normal


def test_pardiso_reuses_its_analysis_for_the_same_pattern():
    """A new matrix object with the same sparsity (what every Newton iteration assembles)
    is only factored numerically; a new pattern is analysed again. Both solve correctly."""
    import scipy.sparse as sp

    from pnmold.fem.linsolve import Pardiso

    n = 50
    lap = sp.diags([-np.ones(n - 1), 2.5 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr")
    upper = sp.triu(lap, format="csr")
    solver = Pardiso()
    b = np.arange(1.0, n + 1)
    for scale in (1.0, 3.0):
        m = sp.csr_matrix((upper.data * scale, upper.indices.copy(), upper.indptr.copy()), shape=(n, n))
        solver.factor(m)
        assert np.allclose(scale * (lap @ solver.solve(b)), b)
    assert (solver.n_analyses, solver.n_factorizations) == (1, 2)
    diag = sp.csr_matrix(sp.diags(2.0 * np.ones(n)))
    solver.factor(diag)
    assert np.allclose(solver.solve(b), b / 2)
    assert solver.n_analyses == 2
    solver.release()


def test_pardiso_frees_an_earlier_analysis_when_the_pattern_changes():
    """Self-contact grows the tangent's pattern as walls meet, so PARDISO analyses again and again; MKL keeps
    each earlier analysis's memory unless told to free it (150 MB an analysis on the fPN: an FE run with
    contact through three loading cycles once grew past 11 GB and was killed). Thirteen analyses of two
    alternating patterns of a 27 000-unknown Laplacian leave the process's memory within 200 MB of where the
    first left it (without the freeing: about 570 MB more)."""
    import os

    import scipy.sparse as sp

    from pnmold.fem.linsolve import Pardiso

    def rss_mb() -> float:
        return int(open(f"/proc/{os.getpid()}/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6

    n = 30
    line = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
    eye = sp.identity(n)
    lap = (sp.kron(sp.kron(line, eye), eye) + sp.kron(sp.kron(eye, line), eye) + sp.kron(sp.kron(eye, eye), line)
           + 0.1 * sp.identity(n ** 3))
    patterns = [sp.triu(lap, format="csr"),
                sp.triu(lap + sp.diags([-0.01 * np.ones(n ** 3 - 1)], [1]), format="csr")]  # a few entries more
    solver = Pardiso()
    solver.factor(patterns[0])
    first = rss_mb()
    for i in range(1, 13):  # ending on the first pattern
        solver.factor(patterns[i % 2])
    assert solver.n_analyses == 13
    rhs = np.ones(n ** 3)
    assert np.allclose(lap @ solver.solve(rhs), rhs, atol=1e-8)
    assert rss_mb() - first < 200.0
    solver.release()


def test_pardiso_solves_several_right_hand_sides_and_keeps_both_cores_after_gmsh(monkeypatch):
    """MKL is called directly: two right-hand sides in one call give the two single solves.
    A mesh made as pnmold.mesh makes it (HXT on General.NumThreads = 1) sets the process's
    OpenMP threads to one, which MKL would follow; the solver sets MKL's own thread count
    (two here: the suite's workers run one thread each, tests/conftest.py)."""
    monkeypatch.setenv("MKL_NUM_THREADS", "2")
    import gmsh
    import scipy.sparse as sp

    from pnmold.fem.linsolve import Pardiso, _threads

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
        gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.model.mesh.generate(3)
        solver = Pardiso()
        assert solver._solver.libmkl.MKL_Get_Max_Threads() == _threads() == 2
    finally:
        gmsh.finalize()
    n = 40
    lap = sp.diags([-np.ones(n - 1), 2.5 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr")
    solver.factor(sp.triu(lap, format="csr"))
    rhs = np.column_stack([np.arange(1.0, n + 1), np.cos(np.arange(n))])
    both = solver.solve(rhs)
    assert both.shape == (n, 2) and both.flags.c_contiguous
    for k in range(2):
        assert np.allclose(both[:, k], solver.solve(rhs[:, k]))
        assert np.allclose(lap @ both[:, k], rhs[:, k])
    solver.release()


def test_the_fe_holds_openblas_to_one_thread_while_it_solves_and_restores_it():
    from threadpoolctl import threadpool_info, threadpool_limits

    from pnmold.fem.linsolve import one_blas_thread

    def openblas() -> list[int]:
        return [p["num_threads"] for p in threadpool_info() if p["internal_api"] == "openblas"]

    with threadpool_limits(2, user_api="blas"):  # the suite's workers run one thread: two here
        before = openblas()
        assert before and all(n == 2 for n in before), "numpy's OpenBLAS is not loaded"
        inside = one_blas_thread(openblas)()
        assert inside == [1] * len(before)
        assert openblas() == before


def test_the_scipy_fallback_solves_the_same_curve_as_pardiso(beam, monkeypatch):
    """Where pypardiso is missing (no MKL wheels) the FE factors with SciPy's SuperLU, chosen by
    :func:`linear_solver`; forced here with PNMOLD_LINEAR_SOLVER. On a nonlinear curve with
    gravity (two load stages, reused factorisations) it takes the same steps and lands on the
    same states as PARDISO, to round-off (1e-14 mm here)."""
    from pnmold.fem.linsolve import Pardiso, SuperLU, choose_linear_solver

    curves = {}
    for name, kind in (("pardiso", Pardiso), ("scipy", SuperLU)):
        monkeypatch.setenv("PNMOLD_LINEAR_SOLVER", name)
        assert choose_linear_solver() == name
        assert isinstance(Newton(Model(beam, Yeoh(), Membrane(), {"clamp": (0, 1, 2)})).linear, kind)
        curves[name] = solve_bending(beam, max_pressure_kpa=100.0, gravity=(0, 0, -1))
    ref, alt = curves["pardiso"], curves["scipy"]
    assert ref.steps[-1].bend_angle_deg > 15 and len(ref.steps) > 8  # well into the nonlinear range
    assert [s.pressure_kpa for s in alt.steps] == pytest.approx([s.pressure_kpa for s in ref.steps], rel=1e-12)
    scale = np.abs(ref.displacement_mm).max()
    assert np.abs(alt.displacement_mm - ref.displacement_mm).max() < 1e-8 * scale
    for a, r in zip(alt.steps, ref.steps, strict=True):
        assert a.bend_angle_deg == pytest.approx(r.bend_angle_deg, rel=1e-9, abs=1e-9)
        assert a.cavity_volume_ml == pytest.approx(r.cavity_volume_ml, rel=1e-9)
    monkeypatch.setenv("PNMOLD_LINEAR_SOLVER", "umfpack")
    with pytest.raises(UsageError, match="PNMOLD_LINEAR_SOLVER=umfpack: one of pardiso, scipy"):
        choose_linear_solver()


def test_largest_stretch_in_closed_form_equals_the_eigenvalue_solvers():
    from pnmold.fem.results import largest_stretch_squared

    rng = np.random.default_rng(7)
    general = np.eye(3) + 0.6 * rng.standard_normal((2000, 3, 3))
    q, _ = np.linalg.qr(rng.standard_normal((4, 3, 3)))  # rotations and reflections: C = I
    stretch = np.diag([1.0, 1.0 + 1e-9, 1.0])  # nearly repeated, the largest apart or not
    pairs = np.stack([np.diag([2.0, 2.0, 0.5]), np.diag([0.5, 2.0, 2.0]), stretch])
    F = np.concatenate([general, q, pairs, q @ pairs[0]])
    expected = np.linalg.eigvalsh(np.swapaxes(F, -1, -2) @ F)[..., -1]
    got = largest_stretch_squared(F)
    np.testing.assert_allclose(got[:2000], expected[:2000], rtol=1e-12)
    np.testing.assert_allclose(got, expected, rtol=1e-7)  # a repeated largest: arccos near 1
    assert largest_stretch_squared(F.reshape(-1, 1, 3, 3)).shape == (F.shape[0], 1)
