"""The FE's path following and globalisation: volume control through a pressure
maximum, the relaxed (wrinkling) sheet, the energy line search, the mixed tangent,
failures that name their stage and region, and soft rubber hanging under its weight.

Small structured meshes (scikit-fem boxes, no gmsh), as in ``test_fem.py``.
"""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
from skfem import MeshTet

from pnmold.errors import SolveError
from pnmold.fem import (
    Load,
    Membrane,
    Model,
    Newton,
    NewtonOptions,
    Solution,
    SolveOptions,
    Yeoh,
    solve_bending,
)
from pnmold.fem import newton as newton_module
from pnmold.fem.path import Control, State, inflate
from pnmold.fem.surface import relaxed_sheet
from tests.test_fem import TOL, hollow_beam, mirror_y, tetmesh, unit_block

#: Ecoflex 00-30 as in pnmold/materials/library.py (pnmold's Yeoh fit of Marechal et al.)
ECOFLEX = Yeoh(c10_mpa=0.008167, c20_mpa=7.371e-05, c30_mpa=0.0, density_g_per_ml=1.07)


@pytest.fixture(scope="module")
def beam():
    return hollow_beam()


# -- the relaxed sheet ------------------------------------------------------------------
def _sheet(e, dmod=677.0, nu=0.2, nc=0.9):
    S, C = np.empty(3), np.empty((3, 3))
    w, regime = relaxed_sheet(e[0], e[1], e[2], dmod, nu, nc, True, S, C)
    return w, regime, S, C


def test_relaxed_sheet_energy_stress_and_tangent_agree_in_every_regime():
    """S = dW/dE and C = dS/dE (Voigt, engineering shear) by central differences, at
    random strains that are taut, wrinkled and slack."""
    rng = np.random.default_rng(3)
    seen = set()
    h = 1e-8
    for _ in range(300):
        e = rng.normal(scale=4e-3, size=3) - [1e-3, 1e-3, 0.0]
        w, regime, S, C = _sheet(e)
        seen.add(regime)
        for j in range(3):
            step = np.zeros(3)
            step[j] = h
            wp, _, Sp, _ = _sheet(e + step)
            wm, _, Sm, _ = _sheet(e - step)
            scale = 2.0 if j == 2 else 1.0  # W depends on 2 e12 through S12
            assert (wp - wm) / (2 * h) == pytest.approx(scale * S[j], rel=1e-5, abs=1e-9)
            assert (Sp - Sm) / (2 * h) == pytest.approx(scale * C[:, j], rel=1e-4, abs=1e-4)
    assert seen == {0, 1, 2}


def test_relaxed_sheet_holds_compression_at_the_wrinkling_force():
    """Uniaxial compression (lateral force free): the force along the compression levels
    at -nc once past the wrinkling strain; in tension the plain sheet's E t is kept."""
    dmod, nu, nc = 677.0, 0.2, 0.9
    et = dmod * (1 - nu ** 2)
    for ex, expected in ((-0.01, -nc), (-0.2, -nc), (0.01, et * 0.01)):
        # the lateral strain that leaves the lateral force free
        lo, hi = -0.5, 0.5
        for _ in range(200):
            ey = 0.5 * (lo + hi)
            _, _, S, _ = _sheet((ex, ey, 0.0), dmod, nu, nc)
            lo, hi = (ey, hi) if S[1] < 0 else (lo, ey)
        _, regime, S, _ = _sheet((ex, ey, 0.0), dmod, nu, nc)
        assert S[0] == pytest.approx(expected, rel=1e-6)
        assert regime == (1 if ex < 0 else 0)


def test_wrinkling_strain_is_the_film_on_substrate_estimate():
    """eps_c = 1/4 (3 Es / Ef)^(2/3) with plane-strain moduli (Chen & Hutchinson 2004)."""
    paper = Membrane()
    ef = 6500.0 / (1 - 0.2 ** 2)
    assert paper.wrinkling_strain_on(Yeoh()) == pytest.approx(0.25 * (3 * 0.88 / ef) ** (2 / 3))
    assert paper.wrinkling_strain_on(ECOFLEX) < paper.wrinkling_strain_on(Yeoh()) / 5
    assert Membrane(wrinkling_strain=1e-3).wrinkling_strain_on(ECOFLEX) == 1e-3


def test_sheet_in_compression_carries_only_its_wrinkling_force():
    """A block with the sheet on its bottom, squeezed 2% along x: the plain sheet pushes
    back with E t eps w, the relaxed one with about its wrinkling force times the width
    (the sheet's own E: ``contrast=None``)."""
    soft = Yeoh(c10_mpa=1e-3, c20_mpa=0.0)
    mesh = unit_block(n=2, size=(4.0, 2.0, 1.0))
    forces = {}
    for wrinkles in (False, True):
        paper = Membrane(wrinkles=wrinkles, contrast=None)
        model = Model(mesh, soft, paper, {"x0": (0,), "x1": (0,), "y0": (1,),
                                          "strain_limiting_layer": (2,)})
        pushed = 3 * model.fixed_sets["x1"]
        u = np.zeros(model.ndof)
        for squeeze in np.linspace(0.002, 0.02, 10):
            u[pushed] = -4.0 * squeeze
            res = Newton(model, NewtonOptions(max_correction=10.0, max_iterations=30)).solve(u, Load())
            assert res.converged
            u = res.u
        forces[wrinkles] = -res.evaluation.residual[pushed].sum()
        nc = model.mem_nc
    assert forces[False] == pytest.approx(650.0 * 0.02 * 2.0, rel=0.1)
    assert 0.5 * nc * 2.0 < forces[True] < 1.5 * nc * 2.0


def test_solved_sheet_is_in_series_with_the_rubber_and_keeps_the_wrinkling_force():
    """E_solved = 1 / (1/E + 1/(contrast 6 C10)); the wrinkling force is the physical sheet's."""
    paper = Membrane()
    for rubber in (Yeoh(), ECOFLEX):
        solved = paper.solved_on(rubber)
        assert solved.modulus_mpa == pytest.approx(1.0 / (1 / 6500.0 + 1 / (6000.0 * rubber.c10_mpa)))
        assert solved.modulus_mpa < paper.modulus_mpa and solved.contrast is None
        assert solved.wrinkling_force_n_per_mm(rubber) == pytest.approx(
            paper.wrinkling_force_n_per_mm(rubber), rel=1e-12)
    assert Membrane(contrast=None).solved_on(ECOFLEX).modulus_mpa == 6500.0
    with pytest.raises(Exception, match="contrast"):
        Membrane(contrast=0.0)


def test_sheet_contrast_barely_moves_the_bend(beam):
    """The hollow beam with the paper at 40 kPa: the tip moves less than 2% of its travel
    between the default contrast (1000) and 4x it (measured 1.3%), and less than half that
    between 4x and 16x: the solved sheet converges to the practically inextensible paper
    (material.py notes)."""
    tips = {}
    for contrast in (1000.0, 4000.0, 16000.0):
        sol = solve_bending(beam, Yeoh(), Membrane(contrast=contrast), pressures_kpa=[40.0])
        tips[contrast] = np.array([sol.steps[-1].tip_x_mm - beam.tip_mm[0], sol.steps[-1].tip_z_mm])
    travel = np.linalg.norm(tips[16000.0])
    assert travel > 0.5  # it bends (0.64 mm, 2.6 deg)
    first = np.linalg.norm(tips[1000.0] - tips[4000.0]) / travel
    second = np.linalg.norm(tips[4000.0] - tips[16000.0]) / travel
    assert first < 0.02 and second < 0.5 * first


# -- volume control through a pressure maximum ---------------------------------------------
BULGE = (6.0, 6.0, 2.5)  # quarter of a 12 x 12 block; cavity under a 0.5 mm roof


def bulge_mesh():
    """Quarter of a block whose 10 x 10 x 1 mm cavity lies under a 0.5 mm roof."""
    lx, ly, lz = BULGE
    skm = MeshTet.init_tensor(np.linspace(0, lx, 7), np.linspace(0, ly, 7),
                              np.array([0.0, 1.0, 2.0, 2.5]))

    def in_cavity(c, pad=0.0):
        return (c[:, 0] < 5 + pad) & (c[:, 1] < 5 + pad) & (c[:, 2] > 1 - pad) & (c[:, 2] < 2 + pad)

    return tetmesh(skm, {"cavity": lambda c: in_cavity(c, 0.01) & (c[:, 0] > TOL) & (c[:, 1] > TOL),
                         "bottom": lambda c: c[:, 2] < TOL,
                         "sym_x": lambda c: c[:, 0] < TOL,
                         "sym_y": lambda c: c[:, 1] < TOL},
                   drop=in_cavity)


def inflate_bulge(past_maximum: bool):
    """The roof of neo-Hookean rubber inflated by volume control (its pressure peaks near
    34 kPa at 6.5 x the cavity's volume, then falls as it balloons)."""
    mat = Yeoh(c10_mpa=0.11, c20_mpa=0.0)  # neo-Hookean: a balloon-like pressure maximum
    model = Model(bulge_mesh(), mat, None, {"bottom": (0, 1, 2), "sym_x": (0,), "sym_y": (1,)})
    newton = Newton(model)
    steps, maxima = [], []
    u = np.zeros(model.ndof)
    start = State(0.0, u, 0.0, newton.evaluate(u, Load()))

    def report(state):
        steps.append((state.t, state.p))
        return state.t > 250.0, 0.0  # mm^3, 10 x the cavity: well past the maximum

    end, why = inflate(newton, start, lambda p: Load(p), lambda _: 0.0, report,
                       Control(first_move=0.02), p_limit=1.0, past_maximum=past_maximum,
                       on_maximum=maxima.append)
    return newton, steps, maxima, end, why


def test_volume_control_reports_a_pressure_maximum_and_pressure_control_cannot_pass_it():
    newton, steps, maxima, end, why = inflate_bulge(past_maximum=False)
    assert why == "pressure_maximum" and len(maxima) == 1
    top = maxima[0]
    pressures = [p for _, p in steps]
    assert top.p == pytest.approx(max(pressures), rel=1e-3)  # the maximum is the last step
    # rising to the maximum, within the 1e-5 by which a fall is told from Newton's noise
    assert all(b > a * (1 - 1e-5) for a, b in zip(pressures, pressures[1:], strict=False))
    # no equilibrium 3% above the maximum: pressure-controlled Newton from the top fails
    res = newton.solve(end.u, Load(1.03 * top.p), stresses=end.stresses,
                       work=top.p * (top.t - steps[0][0]))
    assert not res.converged


def test_volume_control_continues_past_the_maximum_at_a_falling_pressure():
    newton, steps, maxima, _, why = inflate_bulge(past_maximum=True)
    # past the maximum K has a negative pivot; held at the cavity volume the system has none
    # (the count the step control expects: crossing the maximum is not "too long a step")
    assert newton.linear.negative_pivots == 1 and newton.inertia == 0
    assert len(maxima) == 1
    volumes = [v for v, _ in steps]
    assert all(b > a for a, b in zip(volumes, volumes[1:], strict=False))
    after = [p for v, p in steps if v > maxima[0].t]
    assert after and max(after) < maxima[0].p and after[-1] < after[0]


def test_short_failed_tries_early_in_an_inflation_are_not_a_critical_point():
    """Early in an inflation (travel much smaller than the cavity) short tries can fail with a
    less stable predicted tangent on a smooth path (CalculiX's pointwise penalty on the coarse
    fPN: the predictor's volumetric error): the resolution that declares a critical point is a
    share of the volume travelled, not of the cavity, so the path goes on."""
    from pnmold.fem.path import CRITICAL_RESOLUTION

    mat = Yeoh(c10_mpa=0.11, c20_mpa=0.0)
    model = Model(bulge_mesh(), mat, None, {"bottom": (0, 1, 2), "sym_x": (0,), "sym_y": (1,)})
    newton = Newton(model)
    u = np.zeros(model.ndof)
    start = State(0.0, u, 0.0, newton.evaluate(u, Load()))
    v0 = start.ev.cavity_volume_mm3
    window = (v0 + 2.0, v0 + 2.02)  # mm^3 of travel, a tenth of the cavity
    longest = 0.5 * CRITICAL_RESOLUTION * v0  # longer tries into it fail: within 1e-4 of the cavity
    real, last, artefacts = newton.solve, [v0], []

    def solve(u0, load, *args, volume=None, **kw):
        if volume is not None and last[0] < window[1] and volume > window[0] and volume - last[0] > longest:
            artefacts.append(volume)
            newton.most_negatives = newton.inertia + 1
            return SimpleNamespace(converged=False, why="emulated: predicted tangent less stable",
                                   residuals=[1.0], factorizations=0)
        res = real(u0, load, *args, volume=volume, **kw)
        if res.converged and volume is not None:
            last[0] = volume
        return res

    newton.solve = solve
    steps = []

    def report(state):
        steps.append(state.t)
        return state.t > v0 + 3.0, 0.0

    end, why = inflate(newton, start, lambda p: Load(p), lambda _: 0.0, report, Control(first_move=0.02),
                       p_limit=1.0)
    assert artefacts, "the emulated failures were met"
    assert why == "stopped" and end.t > window[1]

def test_solve_bending_names_a_pressure_maximum_as_a_physical_stop(beam):
    """Without its sheet the neo-Hookean test beam balloons instead of curling: the curve
    ends at its pressure maximum (``Solution.stop``), reported, not raised."""
    sol = solve_bending(beam, Yeoh(c10_mpa=0.11, c20_mpa=0.0), None, max_pressure_kpa=500.0)
    assert sol.stop == "pressure_maximum"
    top = sol.pressure_maximum
    assert top.pressure_kpa == pytest.approx(max(s.pressure_kpa for s in sol.steps), rel=1e-6)
    assert top.pressure_kpa == pytest.approx(sol.steps[-1].pressure_kpa, rel=1e-6)
    assert top.cavity_volume_ml > 2 * sol.steps[0].cavity_volume_ml
    assert "pressure maximum" in sol.reason and sol.full_bend_pressure_kpa is None


@pytest.mark.parametrize("critical", [True, False])
def test_a_critical_point_ends_the_curve_as_an_instability_a_plain_failure_raises(beam, monkeypatch, critical):
    """The pressure stage fails after 10 kPa: at a critical point of the path (the tangent lost
    stability within the last try) the curve ends there as the named stop ``instability``
    with its last state; otherwise the failure is a SolveError carrying the partial curve."""
    from pnmold.fem import solver as solver_module
    from pnmold.fem.path import PathFailure

    real = solver_module.inflate

    def failing(newton, start, load_at, angle, on_step, control, **kw):
        end, _ = real(newton, start, load_at, angle, on_step, control, **{**kw, "p_limit": 0.01})
        raise PathFailure("pressure", end, end.t + 1.0, None, "no progress", critical=critical)

    monkeypatch.setattr(solver_module, "inflate", failing)
    if not critical:
        with pytest.raises(SolveError) as err:
            solve_bending(beam, max_pressure_kpa=50.0)
        assert err.value.partial.steps[-1].pressure_kpa == pytest.approx(10.0)
        return
    sol = solve_bending(beam, max_pressure_kpa=50.0)
    assert sol.stop == "instability" and sol.full_bend_pressure_kpa is None
    assert sol.steps[-1].pressure_kpa == pytest.approx(10.0)
    assert "loses stability at 10 kPa" in sol.reason and "0.001 mL further" in sol.reason
    assert "90% of the softest mode at x = " in sol.reason


def test_a_body_that_buckles_under_its_weight_ends_as_an_instability_before_any_pressure(beam, monkeypatch):
    """The gravity stage fails at a critical point (half its weight carried): the curve ends
    there as ``instability`` with that state (0 kPa, the partial sag, ``rest_weight_g``) and says
    so, instead of raising; the stage's factorisations are still counted."""
    from pnmold.fem import solver as solver_module
    from pnmold.fem.path import PathFailure

    real = solver_module.ramp

    def buckling(newton, start, load_at, t_end, *args, **kw):
        half = real(newton, start, load_at, 0.5, *args, **kw)
        raise PathFailure("gravity", half, 0.5 + 1e-6, None, "no progress", critical=True)

    monkeypatch.setattr(solver_module, "ramp", buckling)
    sol = solve_bending(beam, max_pressure_kpa=50.0, gravity=(0.0, 0.0, -1.0))
    assert sol.stop == "instability" and sol.full_bend_pressure_kpa is None
    assert len(sol.steps) == 1 and sol.steps[0].pressure_kpa == 0.0
    assert sol.steps[0].tip_z_mm < 0.0  # it sags under the half weight it carried
    assert sol.rest_weight_g == pytest.approx(0.5)  # and says the rest carries half the weight
    assert "under 0.5 g of its own weight and before any pressure" in sol.reason
    assert "90% of the softest mode at x = " in sol.reason
    assert sol.stats["stage_factorizations"]["gravity"] > 0


def test_simulate_records_no_rest_that_carries_part_of_the_weight(monkeypatch, tmp_path):
    """``simulate --model fe`` of a body that buckles under its weight at rest: its partial rest is no
    state of the rig, so the document has no rows, the JSON says why, and a recording is refused
    with that reason (non-zero exit) instead of holding a rest row at part of the weight."""
    import pnmold.design_fe
    from pnmold.design import load_design
    from pnmold.simulate.quasistatic import SimulationRequest, simulate

    rest = SimpleNamespace(pressure_kpa=0.0, as_dict=lambda: {"pressure_kpa": 0.0, "tip_x_mm": 80.0, "tip_z_mm": -20.0,
                                                             "bend_angle_deg": -30.0, "cavity_volume_ml": 10.0})
    why = "lost stability under 0.315 g of its own weight and before any pressure"
    for carried in (0.315, None):
        sol = SimpleNamespace(steps=[rest], rest_weight_g=carried, reason=why, full_bend_pressure_kpa=None)
        run = SimpleNamespace(solution=sol, gravity_g=1.0)
        monkeypatch.setattr(pnmold.design_fe, "run_fe", lambda *a, run=run, **k: run)
        request = SimulationRequest(pressures_kpa=(0.0, 5.0, 10.0))
        if carried is None:  # the whole weight carried: the rest row is recorded
            assert len(simulate(load_design("fpn"), request).doc["steps"]) == 1
            continue
        with pytest.raises(SolveError, match="solved no row to record: lost stability under 0.315 g"):
            simulate(load_design("fpn"), request, json_path=tmp_path / "s.json", recording_path=tmp_path / "r.csv")
    assert not (tmp_path / "r.csv").exists()
    doc = json.loads((tmp_path / "s.json").read_text())
    assert doc["steps"] == [] and doc["reason"] == why


@pytest.mark.parametrize(("first", "most", "converged", "base", "cuts", "expected"), [
    (1, 1, 0, 0, 4, True),    # the shortest try's prediction is less stable than the last state
    (0, 1, 0, 0, 4, True),    # ... or one of its iterates is (a singular tangent close by)
    (1, 1, 1, 0, 4, True),    # the converged states themselves lost stability in the stage
    (1, 1, 1, 1, 4, False),   # one negative eigenvalue all along: nothing was lost
    (1, 1, 0, 0, 3, False),   # too long a try to tell a critical point from an overshoot
    (1, 1, -1, 0, 8, False),  # the linear solver gives no inertia
])
def test_a_failure_is_critical_only_when_stability_was_lost_on_a_short_try(first, most, converged, base, cuts,
                                                                          expected):
    from types import SimpleNamespace

    from pnmold.fem.path import _critical

    newton = SimpleNamespace(first_negatives=first, most_negatives=most, inertia=converged)
    assert _critical(newton, cuts, base) is expected
    # a try within the resolution of the last state is short enough, whatever the halvings
    assert _critical(newton, 0, base, near=True) is (converged >= 0 and (most > converged or converged > base))


def test_a_ramp_into_a_limit_point_stops_once_it_is_located_instead_of_creeping():
    """Load control toward a limit point at t = 0.7 (a body buckling under its weight): tries
    past it fail with a less stable tangent, tries short of it converge, so every converged
    increment restarts the halvings and the ramp would close in geometrically down to rounding.
    It ends, critical, once a failed try lies within ``CRITICAL_RESOLUTION`` of the range."""
    from types import SimpleNamespace

    from pnmold.fem.newton import NewtonOptions
    from pnmold.fem.path import CRITICAL_RESOLUTION, Control, PathFailure, State, ramp

    critical_t, n = 0.7, 3
    tries = []

    class Fake:
        options = NewtonOptions()
        model = SimpleNamespace(ndof=n, free=np.arange(n), contact=None)
        span = 10.0
        inertia = most_negatives = 0
        stats = SimpleNamespace(cuts=0, increments=0)

        def evaluate(self, u, t):
            return SimpleNamespace(residual=-t * np.ones(n))

        def factor(self, u, t):
            pass

        def back_solve(self, rhs):
            return rhs

        def solve(self, u, t, stresses=None, work=0.0, strict=True):
            tries.append(t)
            ok = t < critical_t
            self.most_negatives = 0 if ok else 1
            return SimpleNamespace(converged=ok, u=t * np.ones(n), pressure_mpa=0.0,
                                   evaluation=None, stresses=None, tangents=3, why="too long",
                                   residuals=[1.0], factorizations=1)

    start = State(0.0, np.zeros(n), 0.0, None)
    with pytest.raises(PathFailure) as failure:
        ramp(Fake(), start, lambda t: t, 1.0, lambda u: 0.0, lambda s: (False, 0.0), Control(), what="gravity")
    fail = failure.value
    assert fail.critical
    assert critical_t - CRITICAL_RESOLUTION <= fail.last.t < critical_t
    assert fail.target - fail.last.t <= CRITICAL_RESOLUTION
    assert len(tries) < 80  # located, not crept up on until the increment vanished


# -- globalisation -------------------------------------------------------------------------
def test_energy_line_search_lowers_the_energy_from_a_far_start(beam, monkeypatch):
    """40 kPa in one jump from rest (load control): every step the search accepts on the
    energy lowers the potential, and Newton converges."""
    model = Model(beam, Yeoh(), Membrane(), {"clamp": (0, 1, 2), "symmetry": (1,)})
    newton = Newton(model)
    accepted = []
    original = newton_module.Newton._step

    def recorded(self, u, p, ev, volume, load, guarded=False, reused=False):
        point = original(self, u, p, ev, volume, load, guarded, reused)
        if point is not None and not guarded:
            rn = np.linalg.norm(ev.residual[model.free])
            accepted.append((ev.energy, point.ev.energy, rn,
                             np.linalg.norm(point.ev.residual[model.free])))
        return point

    monkeypatch.setattr(newton_module.Newton, "_step", recorded)
    res = newton.solve(np.zeros(model.ndof), Load(pressure_mpa=0.04))
    assert res.converged
    assert accepted
    for before, after, r_before, r_after in accepted:  # the documented acceptance rule
        assert after < before + 1e-9 * abs(before) or r_after <= 0.5 * r_before


def test_mixed_tangent_changes_the_iterations_not_the_solution(beam):
    curves = {}
    for mixed in (True, False):
        options = SolveOptions(newton=NewtonOptions(mixed=mixed))
        sol = solve_bending(beam, pressures_kpa=[10.0, 30.0], options=options)
        curves[mixed] = [(s.tip_x_mm, s.tip_z_mm, s.cavity_volume_ml) for s in sol.steps]
    np.testing.assert_allclose(curves[True], curves[False], rtol=1e-5, atol=1e-5)


def test_reused_factorisation_changes_the_factorisations_not_the_solution(beam):
    """Later Newton iterations solved by GMRES with the increment's first factorisation
    (module notes 5. of ``newton``): the same curve as factoring every tangent, fewer
    factorisations, and GMRES did the rest."""
    curves, stats = {}, {}
    for krylov in (0, 30):
        options = SolveOptions(newton=NewtonOptions(krylov_iterations=krylov))
        sol = solve_bending(beam, pressures_kpa=[10.0, 30.0], options=options)
        curves[krylov] = [(s.tip_x_mm, s.tip_z_mm, s.cavity_volume_ml) for s in sol.steps]
        stats[krylov] = sol.stats
    np.testing.assert_allclose(curves[30], curves[0], rtol=1e-5, atol=1e-5)
    assert stats[0]["krylov_solves"] == 0
    assert stats[30]["krylov_solves"] > 0
    assert stats[30]["factorizations"] < stats[0]["factorizations"]


def _bordered_direct(newton, ev, volume):
    """The volume-controlled Newton step with the tangent at ``ev`` factored."""
    m = newton.model
    newton._factor(ev.matrix)
    b = -newton.linear.solve(ev.residual[m.free])
    g = ev.volume_gradient[m.free]
    a = newton.linear.solve(g)
    dp = -(ev.cavity_volume_mm3 - volume + float(g @ b)) / float(g @ a)
    return b + dp * a, dp


def test_gmres_with_the_last_factorisation_solves_the_bordered_step(beam):
    """The volume-controlled step at a bent state, solved by GMRES preconditioned by the
    factorisation at rest, is the step of the factored tangent there; with too few GMRES
    iterations the tangent is factored after all (counted) and the step is the same."""
    model = Model(beam, Yeoh(), Membrane(), {"clamp": (0, 1, 2), "symmetry": (1,)})
    direct = Newton(model)
    bent = direct.solve(np.zeros(model.ndof), Load(0.003))
    assert bent.converged
    load = Load(0.0035)
    ev = direct.evaluate(bent.u, load, want_k=True)
    volume = ev.cavity_volume_mm3 + 5.0
    d_ref, dp_ref = _bordered_direct(direct, ev, volume)
    # rtol 1e-9: at 1e-10 the preconditioned residual meets the rounding of a one-thread PARDISO
    # factorisation (GMRES stalls after 12 products, a fallback), whatever the code around it
    for iterations, fallbacks in ((40, 0), (1, 1)):
        newton = Newton(model, NewtonOptions(krylov_iterations=iterations, krylov_rtol=1e-9))
        newton.factor(np.zeros(model.ndof), load)  # the preconditioner: the tangent at rest
        newton.assemble(bent.u, load)
        d, dp, _ = newton._direction(ev, volume)
        assert newton.stats.krylov_fallbacks == fallbacks
        assert newton.stats.factorizations == 1 + fallbacks
        np.testing.assert_allclose(d, d_ref, rtol=0, atol=1e-6 * np.abs(d_ref).max())
        assert dp == pytest.approx(dp_ref, rel=1e-6)


# -- failures ------------------------------------------------------------------------------
def test_pressure_failure_names_stage_load_region_and_carries_the_curve(beam):
    """Increments growing 4x and no cuts allowed: the curve fails after a few steps."""
    options = SolveOptions(first_angle_step_deg=30.0,
                           newton=NewtonOptions(max_cuts=0, growth=4.0))
    with pytest.raises(SolveError) as info:
        solve_bending(beam, max_pressure_kpa=1e5, options=options)
    err = info.value
    assert err.stage == "pressure"
    assert str(err).startswith("pressure stage failed at ")
    assert "where: " in str(err) and "try: " in str(err)
    assert err.region and ("x = " in err.region)
    assert err.hint
    assert isinstance(err.partial, Solution) and err.partial.stop == "failed"
    assert len(err.partial.steps) > 1 and err.partial.steps[0].pressure_kpa == 0.0
    assert err.last_converged == err.partial.steps[-1].pressure_kpa
    assert f"last converged pressure {err.last_converged:.4g} kPa" in str(err)
    assert err.residuals


def test_gravity_failure_names_the_gravity_stage(beam):
    options = SolveOptions(gravity_first_step=1.0,
                           newton=NewtonOptions(max_cuts=0, max_iterations=1))
    with pytest.raises(SolveError) as info:
        solve_bending(beam, ECOFLEX, pressures_kpa=[1.0], gravity=(0.0, 0.0, -200.0),
                      options=options)
    err = info.value
    assert err.stage == "gravity" and str(err).startswith("gravity stage failed at 0 g of 1 g")
    assert err.partial is not None and err.partial.steps == ()


def test_solve_error_declares_partial():
    assert SolveError("x").partial is None
    assert SolveError("x", partial="curve").partial == "curve"


# -- soft rubber under its own weight -------------------------------------------------------
@pytest.mark.parametrize("gravity, axis, sign", [((0.0, 0.0, -1.0), 2, -1), ((0.0, 0.0, 1.0), 2, 1),
                                                 ((0.0, -1.0, 0.0), 1, -1)],
                         ids=["chambers_up", "chambers_down", "horizontal"])
def test_ecoflex_beam_hangs_in_every_orientation(beam, gravity, axis, sign):
    """Ecoflex 00-30 (13x softer than Elastosil): the weight is ramped without a stall,
    the clamp carries the whole weight and the tip moves with gravity."""
    mesh = mirror_y(beam) if axis == 1 else beam
    sol = solve_bending(mesh, ECOFLEX, pressures_kpa=[0.2], gravity=gravity)
    rest = sol.steps[0]
    volume = 30 * 4 * 4 - 26 * 2 * 2
    weight = ECOFLEX.weight_density_n_per_mm3 * volume * np.asarray(gravity)
    assert rest.clamp_reaction_n == pytest.approx(tuple(-weight), abs=1e-3 * np.abs(weight).max())
    tip = sol.shapes_mm[0][np.argmax(mesh.nodes_mm[:, 0])]
    # the sheet stiffens the beam across (in its plane): it sags sideways 30x less
    assert sign * tip[axis] > (0.5 if axis == 2 else 0.005)  # mm
    assert math.isfinite(sol.steps[-1].bend_angle_deg)


def test_inertia_correction_shifts_a_tangent_with_a_surplus_negative_eigenvalue(beam):
    """The beam's tangent at rest, lowered just below its smallest eigenvalue, has one negative
    eigenvalue more than the converged state: it is refactored as K + s diag(K) until it has
    none (one shift, the first of ``inertia_shifts``), and the stats count it."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla

    model = Model(beam, Yeoh(), Membrane(), {"clamp": (0, 1, 2), "symmetry": (1,)})
    newton = Newton(model)
    ev = newton.factor(np.zeros(model.ndof), Load())
    assert newton.inertia == 0
    upper = ev.matrix
    full = (upper + upper.T - sp.diags(upper.diagonal())).tocsc()
    smallest = float(sla.eigsh(full, k=1, sigma=0, which="LM", return_eigenvectors=False)[0])
    lowered = upper.copy()
    lowered.data[model.diag_pos] -= 1.001 * smallest
    ev.matrix = lowered
    newton.linear.factor(lowered)
    assert newton.linear.negative_pivots == 1
    assert newton._correct_inertia(ev, None, newton.negatives()) == 1
    assert newton.linear.negative_pivots == 0 and newton.stats.shifts == 1
    # the last (shifted) factorisation is already right
    assert newton._correct_inertia(ev, None, newton.negatives()) == 0


def test_the_converged_inertia_is_the_unshifted_tangents(beam, monkeypatch):
    """A state reached through shifted tangents keeps the count of its own (unshifted)
    tangent: a shift that hid a negative eigenvalue must not hide a lost stability."""
    model = Model(beam, Yeoh(), Membrane(), {"clamp": (0, 1, 2), "symmetry": (1,)})
    newton = Newton(model)
    newton.factor(np.zeros(model.ndof), Load())
    assert newton.inertia == 0
    shifted = [False]  # every tangent "has" one negative eigenvalue, its shifted copy none
    factor = newton.factor

    def unshifted(*args, **kw):
        shifted[0] = False
        return factor(*args, **kw)

    def shift(ev, g, n):
        shifted[0] = True
        return 1

    monkeypatch.setattr(newton, "factor", unshifted)
    monkeypatch.setattr(newton, "negatives", lambda g=None: 0 if shifted[0] else 1)
    monkeypatch.setattr(newton, "_correct_inertia", shift)
    res = newton.solve(np.zeros(model.ndof), Load(0.002), strict=False)
    assert res.converged and newton.inertia == 1


def test_the_softest_mode_of_a_clamped_beam_is_largest_at_its_free_end(beam):
    """Inverse iteration on the tangent at rest finds the cantilever's first bending mode: it
    vanishes at the clamp and is largest at the free end, which is where it is reported."""
    import re

    from pnmold.fem.failure import softest_mode

    model = Model(beam, Yeoh(), Membrane(), {"clamp": (0, 1, 2), "symmetry": (1,)})
    text = softest_mode(Newton(model), np.zeros(model.ndof), Load())
    x_largest = float(re.search(r"largest at \(([-\d.]+),", text).group(1))
    assert x_largest == pytest.approx(beam.nodes_mm[:, 0].max(), abs=0.5)
    assert "touching" in text and "free_end" in text

