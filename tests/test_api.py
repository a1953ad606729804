"""pnmold as a library in a notebook: no global matplotlib state, figures on the caller's axes,
DataFrames, a build result's summary, the user's cache folder, the templates and the linear
solver it finds."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.figure import Figure

from pnmold.design import load_design, templates_dir
from pnmold.errors import UsageError
from pnmold.fem import Solution, Step
from pnmold.pipeline import BuildResult

ROOT = Path(__file__).resolve().parents[1]
PLOT_MODULES = ("pnmold.plots", "pnmold.materials.plot", "pnmold.diagnose.plots", "pnmold.pneumatics.plot",
                "pnmold.sweep.plot", "pnmold.report.render", "pnmold.report.fem", "pnmold.pipeline", "pnmold.cli")


def _steps(n: int = 4) -> list[dict]:
    return [{"pressure_kpa": 10.0 * i, "tip_x_mm": 100.0 - 5 * i, "tip_z_mm": -3.0 * i, "bend_angle_deg": 40.0 * i,
             "cavity_volume_ml": 10.0 + i, "max_principal_stretch": 1.0 + 0.1 * i} for i in range(n)]


def _solution() -> Solution:
    steps = tuple(Step(s["pressure_kpa"], s["tip_x_mm"], s["tip_z_mm"], s["bend_angle_deg"], s["cavity_volume_ml"],
                       s["max_principal_stretch"], (1.0, 0.0, 2.0), (0.0, 0.0, 0.1)) for s in _steps())
    return Solution(steps, np.zeros((3, 3)), None, "bend angle reached 120 deg", {"unknowns": 9})


def _result(steps: list[dict], failed: bool = False) -> BuildResult:
    checks = [{"id": "mesh.watertight.actuator", "passed": True, "value": 1, "limit": 1, "message": "closed"},
              {"id": "print.slicer.mold_bottom", "passed": None, "value": None, "limit": None, "message": "skipped"},
              {"id": "fit.void.top", "passed": not failed, "value": 2.0, "limit": 0.01, "message": "a <gap>"}]
    report = {"design": {"name": "fpn", "digest": "0123456789abcdef"}, "checks": checks,
              "fem": {"full_bend_pressure_kpa": 48.02 if steps else None, "reason": None if steps else "skipped",
                      "steps": steps},
              "pours": [{"mold": "a", "mass_g": 30.0}, {"mold": "b", "mass_g": 10.5}], "timings_s": {"cad": 1.0}}
    return BuildResult(load_design("fpn"), Path("out/fpn"), report)


def test_importing_and_plotting_leave_the_notebook_backend_and_pyplot_alone(tmp_path):
    """A notebook has its backend (here svg) and pyplot figures of its own; importing every plot
    module and drawing a figure changes neither."""
    code = f"""
import matplotlib
matplotlib.use("svg")
import matplotlib.pyplot as plt
import importlib, numpy as np
for name in {PLOT_MODULES!r}:
    importlib.import_module(name)
from pnmold.plots import plot_bending
steps = {_steps()!r}
line = np.array([[0.0, 0.0], [10.0, -1.0]])
fig = plot_bending("t", steps, [(10.0, line, line)], {str(tmp_path / "b.png")!r}, 20.0)
print(matplotlib.get_backend(), len(plt.get_fignums()), type(fig).__name__)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["svg", "0", "Figure"]
    assert (tmp_path / "b.png").stat().st_size > 10_000


def test_a_plot_draws_on_the_axes_it_is_given_and_returns_their_figure(tmp_path):
    from pnmold.plots import plot_bending
    from pnmold.sweep import load_sweep
    from pnmold.sweep.plot import plot_sweep

    fig = Figure()
    axes = fig.subplots(1, 3)
    line = np.array([[0.0, 0.0], [10.0, -1.0]])
    assert plot_bending("t", _steps(), [(10.0, line, line)], ax=axes) is fig
    assert axes[1].get_xlabel() == "pressure (kPa)"
    spec = load_sweep(ROOT / "templates" / "sweeps" / "fig-s2a.toml")
    field = spec.axes[0].field
    rows = [{field: 3.0 + i, "full_bend_pressure_kpa": 40.0 + i, "fem_max_pressure_kpa": 50.0, "status": "ok"}
            for i in range(3)]
    one = Figure().subplots()
    assert plot_sweep(spec, rows, tmp_path / "s.png", ax=one) is one.figure
    assert (tmp_path / "s.png").is_file() and not list(tmp_path.glob(".s.png*"))
    own = plot_sweep(spec, rows)
    assert isinstance(own, Figure) and own is not one.figure
    with pytest.raises(UsageError, match="3 axes, got 2"):
        plot_bending("t", _steps(), [], ax=Figure().subplots(1, 2))


def test_the_material_fit_plot_takes_axes_too(tmp_path):
    from pnmold.materials import fit_hyperelastic, read_tensile
    from pnmold.materials.plot import plot_fit

    data = read_tensile(ROOT / "tests" / "data" / "ecoflex0030_uniaxial_tension.csv")
    ax = Figure().subplots()
    assert plot_fit(data, fit_hyperelastic(data, "yeoh"), ax=ax) is ax.figure
    assert ax.get_ylabel() == "engineering stress (MPa)"


def test_results_convert_to_dataframes():
    pd = pytest.importorskip("pandas")
    from pnmold.frames import dataframe

    frame = _solution().to_dataframe()
    assert isinstance(frame, pd.DataFrame) and len(frame) == 4
    assert frame["bend_angle_deg"].tolist() == [0.0, 40.0, 80.0, 120.0]
    assert frame["clamp_reaction_n"].iloc[0] == [0.0, 0.0, 0.1]
    steps = _steps()
    assert _result(steps).steps_frame()["pressure_kpa"].tolist() == [0.0, 10.0, 20.0, 30.0]
    assert _result([]).steps_frame().empty
    columns = dataframe({"pressure_kpa": np.arange(3.0), "tip_z_mm": np.zeros(3)})
    assert list(columns.columns) == ["pressure_kpa", "tip_z_mm"] and len(columns) == 3
    assert dataframe(steps).equals(pd.DataFrame(steps))


def test_without_pandas_a_dataframe_is_refused_naming_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas -> ImportError
    with pytest.raises(UsageError, match=r"pip install 'pnmold\[pandas\]'"):
        _solution().to_dataframe()
    with pytest.raises(UsageError, match="pandas"):
        _result(_steps()).steps_frame()


def test_a_build_result_shows_its_summary():
    ok = _result(_steps())
    text = repr(ok)
    assert text.startswith("<BuildResult fpn (0123456789abcdef) in out")
    assert "checks 2 passed, 0 failed, 1 skipped" in text and "full bend 48.0 kPa" in text and "40.5 g" in text
    html = _result([], failed=True)._repr_html_()
    assert "<table>" in html and "1 passed, 1 failed, 1 skipped" in html
    assert "fit.void.top: a &lt;gap&gt;" in html and "skipped" in html  # escaped


@pytest.mark.parametrize("kind", ["bending", "pv", "force"])
def test_a_simulation_shows_its_summary_and_draws_its_curve(kind, tmp_path):
    """The reduced model on a template with a shipped characterisation (no FE): the summary names the
    design, model, rows and last row; the HTML is a table; the figure is a Figure and writes no file."""
    from matplotlib.figure import Figure

    from pnmold.simulate import SimulationRequest, parse_pressures, simulate

    sim = simulate(load_design("fig-s2a-h5"), SimulationRequest(parse_pressures("0:20:5"), model="rom", kind=kind,
                                                                effects=(("mullins", 0.2),)))
    text = repr(sim)
    assert text.startswith("<Simulation fig-s2a-h5 (") and f"rom, {kind}, chambers_up" in text
    assert "5, 0 to 20 kPa" in text and len(text) < 300
    last = sim.summary()["last row"]
    assert last.endswith("at 20 kPa") and {"bending": "deg", "pv": "mL", "force": " N "}[kind] in last
    assert sim.summary()["effects"] == "mullins=0.2"
    html = sim._repr_html_()
    assert html.startswith("<table>") and "pnmold simulate" in html and "mullins=0.2" in html
    fig = sim.figure()
    assert isinstance(fig, Figure) and len(fig.axes) == (2 if kind == "bending" else 1)
    assert all(ax.lines for ax in fig.axes) and list(tmp_path.iterdir()) == []


def test_the_fe_cache_is_the_users_unless_pnmold_cache_names_one(monkeypatch, tmp_path):
    import platformdirs

    from pnmold.physics.characterise import cache_dir

    monkeypatch.setenv("PNMOLD_CACHE", str(tmp_path / "mine"))
    assert cache_dir() == tmp_path / "mine"
    monkeypatch.delenv("PNMOLD_CACHE")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.chdir(tmp_path)
    expected = Path(platformdirs.user_cache_dir("pnmold", appauthor=False)) / "fe"
    assert cache_dir() == expected
    if sys.platform.startswith("linux"):
        assert expected == tmp_path / "xdg" / "pnmold" / "fe"


def test_templates_come_from_the_checkout_unless_pnmold_templates_names_a_folder(monkeypatch, tmp_path):
    assert templates_dir() == ROOT / "templates"  # a source checkout: its top-level templates/
    (tmp_path / "mine.toml").write_text('[design]\ndescription = "one of mine"\n')
    monkeypatch.setenv("PNMOLD_TEMPLATES", str(tmp_path))
    assert templates_dir() == tmp_path
    from pnmold.design import list_templates

    assert list_templates() == {"mine": "one of mine"}


def test_the_linear_solver_is_pardiso_where_it_loads_else_scipy(monkeypatch):
    from pnmold.fem import linsolve

    monkeypatch.delenv("PNMOLD_LINEAR_SOLVER", raising=False)
    expected = "pardiso" if linsolve._pardiso_importable() is None else "scipy"
    assert linsolve.choose_linear_solver() == expected
    monkeypatch.setattr(linsolve, "_pardiso_importable", lambda: "ModuleNotFoundError: No module named 'pypardiso'")
    assert linsolve.choose_linear_solver() == "scipy"  # Apple Silicon, ARM Linux
    assert isinstance(linsolve.linear_solver(), linsolve.SuperLU)
    monkeypatch.setenv("PNMOLD_LINEAR_SOLVER", "pardiso")
    with pytest.raises(UsageError, match="pypardiso cannot be loaded"):
        linsolve.choose_linear_solver()
    monkeypatch.setenv("PNMOLD_LINEAR_SOLVER", " SciPy ")
    assert linsolve.choose_linear_solver() == "scipy"


def test_the_build_report_names_the_linear_solver(monkeypatch):
    from pnmold.fem.linsolve import choose_linear_solver
    from pnmold.report.fem import fem_report

    run = SimpleNamespace(solution=_solution(), orientation="chambers_up",
                          quality=SimpleNamespace(n_nodes=10, n_tets=20, min_gamma=0.3),
                          size=SimpleNamespace(half=True, wall_mm=3.2, max_mm=6.4))
    monkeypatch.delenv("PNMOLD_LINEAR_SOLVER", raising=False)
    assert fem_report(run)["solver"]["linear_solver"] == choose_linear_solver()
    monkeypatch.setenv("PNMOLD_LINEAR_SOLVER", "scipy")
    assert fem_report(run)["solver"]["linear_solver"] == "scipy"


def test_without_pypardiso_the_fe_imports_and_solves_with_scipy():
    """As on Apple Silicon or ARM Linux, where the dependency's platform marker leaves pypardiso out."""
    code = """
import sys
sys.modules["pypardiso"] = None  # import pypardiso -> ImportError
import numpy as np, scipy.sparse as sp
import pnmold.fem
from pnmold.fem.linsolve import choose_linear_solver, linear_solver
lap = sp.diags([-np.ones(9), 2.5 * np.ones(10), -np.ones(9)], [-1, 0, 1], format="csr")
solver = linear_solver()
solver.factor(sp.triu(lap, format="csr"))
x = solver.solve(np.ones(10))
print(choose_linear_solver(), type(solver).__name__, np.allclose(lap @ x, 1.0))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["scipy", "SuperLU", "True"]
