"""Self-contact in the FE of a real design: the fPN on a coarse mesh, its VTU series read back and
measured the way the overlap acceptance measures a build's (:mod:`pnmold.fem.overlap`)."""

from __future__ import annotations

import numpy as np
import pytest

from pnmold.tetmesh import MeshSize

COARSE = MeshSize(5.0, 10.0)
PRESSURES_KPA = [8.0, 14.0]  # the walls of the gaps meet from about 10 kPa on this mesh


def _series(tmp_path, contact: bool, mesh_of=None):
    from pnmold.design import load_design
    from pnmold.design_fe import build_options, run_fe
    from pnmold.export.vtu import read_vtu_series, write_vtu_series

    run = run_fe(load_design("fpn"), size=COARSE, orientation="none", pressures_kpa=PRESSURES_KPA,
                 options=build_options(contact), mesh_of=mesh_of)
    folder = tmp_path / ("contact" if contact else "free")
    write_vtu_series(run.mesh, run.solution, folder)
    return run, read_vtu_series(folder)


@pytest.mark.slow
def test_with_self_contact_no_vertex_of_the_fpn_lies_inside_another_part(tmp_path):
    from pnmold.fem.overlap import measure_overlap

    free_run, free = _series(tmp_path, contact=False)
    run, steps = _series(tmp_path, contact=True, mesh_of=free_run)
    depth = [measure_overlap(s.nodes_mm, s.cells, s.displacement_mm).max_depth_mm for s in steps]
    free_depth = [measure_overlap(s.nodes_mm, s.cells, s.displacement_mm).max_depth_mm for s in free]
    assert free_depth[-1] > 0.05, free_depth  # without contact the walls pass through each other here
    assert max(depth) <= 0.05, depth
    # the walls push on each other: the fPN bends further at the same pressure
    assert run.solution.steps[-1].bend_angle_deg > free_run.solution.steps[-1].bend_angle_deg + 1.0
    # the contact pressure is written beside the displacement: 0 at rest; at the last step, where
    # the walls have just met (3.4 kPa when written), positive and below a few times the cavity
    # pressure that presses them together
    import meshio

    last = meshio.read(sorted((tmp_path / "contact").glob("step_*.vtu"))[-1])
    first = meshio.read(tmp_path / "contact" / "step_000.vtu")
    peak_kpa = 1000.0 * float(np.max(last.point_data["contact_pressure_mpa"]))
    assert float(np.max(first.point_data["contact_pressure_mpa"])) == 0.0
    assert 0.05 * PRESSURES_KPA[-1] < peak_kpa < 5.0 * PRESSURES_KPA[-1], peak_kpa
    assert "contact_pressure_mpa" not in meshio.read(tmp_path / "free" / "step_000.vtu").point_data


@pytest.mark.parametrize(("flag", "on"), [(["--self-contact"], True), ([], False)], ids=["with-flag", "default"])
def test_build_self_contact_reaches_the_quick_fe(flag, on, tmp_path, monkeypatch):
    """``pnmold build --self-contact`` solves the quick FE with :class:`SelfContact` (its defaults);
    without the flag the build's options stay as they were (no contact)."""
    import pnmold.design_fe
    from pnmold.cli import main
    from pnmold.errors import MeshingError
    from pnmold.fem import SelfContact

    seen = {}

    def run_fe(design, **kw):
        seen["options"] = kw["options"]
        raise MeshingError("stopped by the test after the options were seen")

    monkeypatch.setattr(pnmold.design_fe, "run_fe", run_fe)
    code = main(["build", "--out", str(tmp_path / "b"), "--no-slicer", "--quiet", *flag])
    assert code == 3  # the quick FE "failed" (the stub): the build says so
    assert seen["options"].self_contact == (SelfContact() if on else None)
    assert seen["options"].max_angle_step_deg == pnmold.design_fe.BUILD_OPTIONS.max_angle_step_deg


def test_simulate_fe_self_contact_reaches_the_fe_and_is_refused_elsewhere(tmp_path, monkeypatch, capsys):
    """``pnmold simulate --model fe --self-contact`` solves with :class:`SelfContact`; with the reduced
    model or the step response the flag is refused, naming it (exit 2), not ignored."""
    import pnmold.design_fe
    from pnmold.cli import main
    from pnmold.errors import MeshingError
    from pnmold.fem import SelfContact

    seen = {}

    def run_fe(design, **kw):
        seen["options"] = kw["options"]
        raise MeshingError("stopped by the test after the options were seen")

    monkeypatch.setattr(pnmold.design_fe, "run_fe", run_fe)
    main(["simulate", "fpn", "--model", "fe", "--pressures", "0:10:5", "--self-contact", "--quiet"])
    assert seen["options"].self_contact == SelfContact()
    capsys.readouterr()
    for argv in (["--model", "rom"], ["--dynamic", "--supply-kpa", "100"]):
        assert main(["simulate", "fpn", *argv, "--self-contact", "--json", str(tmp_path / "s.json")]) == 2
        assert "--self-contact" in capsys.readouterr().err
        assert not (tmp_path / "s.json").exists()
