"""The command line, called in-process: exit codes and the files it writes."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest

from pnmold.cli import main
from pnmold.cli._main import VERBS
from pnmold.design import load_design
from pnmold.errors import GeometryError
from tests.test_design import INVALID

BUILD_FILES = {f"{n}.{ext}" for n in load_design("fpn").part_names for ext in ("step", "stl")} | {
    "design.toml", "report.json"}


def test_build_writes_every_contract_file(tmp_path):
    out = tmp_path / "fpn"
    assert main(["build", "--out", str(out), "--no-fem", "--quiet"]) == 0
    assert BUILD_FILES <= {p.name for p in out.iterdir()}
    assert len([n for n in BUILD_FILES if n.endswith((".step", ".stl"))]) == 14
    report = json.loads((out / "report.json").read_text())
    assert report["schema"] == "pnmold.build/1"
    assert report["design"]["name"] == "fpn" and len(report["design"]["digest"]) == 16
    for name in load_design("fpn").part_names:
        assert report["parts"][name]["watertight"] is True
        assert report["parts"][name]["volume_mm3"] > 0
    pours = {p["mold"]: p for p in report["pours"]}
    top = pours["mold_exterior+mold_interior"]
    assert top["volume_ml"] == pytest.approx(report["parts"]["top_layer"]["volume_mm3"] / 1000, rel=1e-4)
    assert top["mass_g"] == pytest.approx(top["volume_ml"] * 1.13, rel=1e-4)
    assert top["part_a_g"] == pytest.approx(9 * top["part_b_g"], rel=1e-4)
    assert top["part_a_g"] + top["part_b_g"] == pytest.approx(top["mass_g"] * 1.15, rel=1e-4)
    assert {"cad", "export", "measure"} <= set(report["timings_s"])
    assert report["fem"]["full_bend_pressure_kpa"] is None and report["fem"]["reason"]


def test_set_overrides_reach_the_resolved_design(tmp_path):
    out = tmp_path / "x"
    assert main(["build", "spn", "--out", str(out), "--set", "chambers.count=6", "--no-fem",
                 "--quiet"]) == 0
    text = (out / "design.toml").read_text()
    assert "count = 6" in text and 'kind = "spn"' in text


@pytest.mark.parametrize(("override", "field"), INVALID, ids=[f for _, f in INVALID])
def test_invalid_design_exits_2_naming_the_field(override, field, tmp_path, capsys):
    out = tmp_path / "never"
    assert main(["build", "--out", str(out), "--set", override, "--no-fem", "--quiet"]) == 2
    assert field in capsys.readouterr().err
    assert not out.exists()


def test_ctrl_c_turned_into_another_error_by_a_library_still_exits_130(monkeypatch, capsys):
    """A worker pool or a solver's C code may catch the interrupt and raise an error of its own; the run
    still ends as interrupted (130), not as a bug (70). Without an interrupt the same error is a bug."""
    import os
    import signal
    import time

    from pnmold.cli import templates

    before = signal.getsignal(signal.SIGINT)

    def interrupted_then_broken(args):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        except KeyboardInterrupt:
            raise RuntimeError("the worker pool broke") from None
        return 0

    monkeypatch.setattr(templates, "run", interrupted_then_broken)
    assert main(["templates"]) == 130
    assert "interrupted" in capsys.readouterr().err

    def broken(args):
        raise RuntimeError("the worker pool broke")

    monkeypatch.setattr(templates, "run", broken)
    assert main(["templates"]) == 70
    assert signal.getsignal(signal.SIGINT) is before  # the handler is put back as it was


def test_ctrl_c_during_an_import_is_kept_for_later_not_raised_inside_it(tmp_path, monkeypatch, capsys):
    """An interrupt raised inside an import can be swallowed (trimesh imports its extras under
    ``except BaseException``) or leave a C extension half set up; it is noted there, the import
    finishes, and the run still ends as interrupted."""
    import importlib
    import sys

    from pnmold.cli import templates

    (tmp_path / "slow_extra.py").write_text(
        "import os, signal, time\nos.kill(os.getpid(), signal.SIGINT)\ntime.sleep(0.2)\nFINISHED = True\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    loaded = {}

    def importing(args):
        loaded["module"] = importlib.import_module("slow_extra")
        return 0

    monkeypatch.setattr(templates, "run", importing)
    try:
        assert main(["templates"]) == 130
    finally:
        sys.modules.pop("slow_extra", None)
    assert loaded["module"].FINISHED  # the import ran to its end
    assert "interrupted" in capsys.readouterr().err


def test_a_users_text_is_printed_as_written_not_as_an_emoji(capsys):
    """Rich reads ``:b:`` as an emoji code; a design named ``nosuch:b:step`` (or a mix ratio, a path with
    colons) must come back in the error as the user wrote it."""
    assert main(["simulate", "nosuch:b:step"]) == 2
    err = capsys.readouterr().err
    assert "'nosuch:b:step'" in err and "\U0001f171" not in err


def test_a_failed_build_leaves_the_earlier_build_untouched(tmp_path, monkeypatch):
    out = tmp_path / "fpn"
    assert main(["build", "--out", str(out), "--no-fem", "--quiet"]) == 0
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}

    from pnmold.report import build_report as report

    def broken(*args, **kwargs):
        raise GeometryError("measure", "simulated failure after export")

    monkeypatch.setattr(report, "measure_parts", broken)
    assert main(["build", "--out", str(out), "--no-fem", "--quiet"]) == 3
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before
    assert [p.name for p in tmp_path.iterdir()] == ["fpn"]  # no temporary folder left


def test_templates_lists_each_template(capsys):
    assert main(["templates"]) == 0
    out = capsys.readouterr().out
    for name in ("fpn", "spn", "fig-s2a-h5", "fig-s2b-n7", "fig-s2c-w2"):
        assert name in out


@pytest.mark.parametrize("verb", list(VERBS))
def test_help_on_every_verb(verb, capsys):
    assert main([verb, "--help"]) == 0
    assert "usage" in capsys.readouterr().out


def test_bad_usage_exits_2():
    assert main(["build", "--no-such-option"]) == 2
    assert main([]) == 2


def test_material_fit_writes_the_constants_by_name(tmp_path, capsys):
    out = tmp_path / "fit.json"
    assert main(["material", "fit", "tests/data/ecoflex0030_uniaxial_tension.csv", "--json", str(out)]) == 0
    fit = json.loads(out.read_text())
    assert {"c10_mpa", "c20_mpa", "c30_mpa", "r2", "strain_range"} <= set(fit)
    assert fit["r2"] >= 0.99 and fit["strain_range"][1] > fit["strain_range"][0]
    assert (tmp_path / "fit.png").stat().st_size > 1000
    assert "holds over strain" in capsys.readouterr().out


@pytest.mark.parametrize("text", ["", "a,b\n1,2\n", "eng_strain,eng_stress_mpa\n0.1,x\n0.2,0.1\n0.3,0.2\n0.4,0.3\n",
                                  "eng_strain,eng_stress_mpa\n-0.1,0\n0.2,0.1\n0.3,0.2\n0.4,0.3\n"],
                         ids=["empty", "wrong-columns", "non-number", "negative-strain"])
def test_material_fit_refuses_damaged_files_with_file_and_line(text, tmp_path, capsys):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    json_out = tmp_path / "fit.json"
    assert main(["material", "fit", str(path), "--json", str(json_out)]) == 2
    err = capsys.readouterr().err
    assert "bad.csv" in err and "line" in err
    assert not json_out.exists()


def test_version_and_the_output_flags_on_either_side_of_the_verb(capsys):
    assert main(["--version"]) == 0
    assert "pnmold 0." in capsys.readouterr().out
    for argv in (["-q", "effects"], ["effects", "-q"], ["effects", "--quiet", "-v"], ["material", "list", "-q"]):
        assert main(argv) == 0


@pytest.mark.parametrize(("raised", "code"), [(RuntimeError("a bug"), 70), (KeyboardInterrupt(), 130)],
                         ids=["unexpected", "interrupted"])
def test_unexpected_errors_and_ctrl_c_have_their_own_exit_codes(raised, code, monkeypatch, capsys):
    from pnmold.cli import templates

    def boom(args):
        raise raised

    monkeypatch.setattr(templates, "run", boom)
    assert main(["templates"]) == code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if code == 70:
        assert "unexpected error (RuntimeError): a bug" in err and "-v" in err
        assert main(["templates", "-v"]) == 70
        assert "Traceback" in capsys.readouterr().err


# -- --json -: the JSON alone on standard output ------------------------------------------------
@pytest.mark.parametrize("argv", [["effects", "--json"], ["effects", "--json", "-"], ["effects", "-q", "--json", "-"]],
                         ids=["flag", "dash", "quiet"])
def test_effects_json_goes_to_stdout(argv, capsys):
    assert main(argv) == 0
    catalogue = json.loads(capsys.readouterr().out)
    assert [e["name"] for e in catalogue][:2] == ["gravity", "strain_stiffening"]


def test_effects_json_into_a_file(tmp_path, capsys):
    assert main(["effects", "--json", str(tmp_path / "e.json")]) == 0
    assert len(json.loads((tmp_path / "e.json").read_text())) == 8
    assert "wrote" in capsys.readouterr().out


def test_simulate_json_dash_puts_only_the_document_on_stdout(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "fpn", "--model", "rom", "--pressures", "0:20:10", "--json", "-"]) == 0
    out, err = capsys.readouterr()
    doc = json.loads(out)  # nothing else on stdout
    assert doc["schema"] == "pnmold.simulation/1" and len(doc["steps"]) == 3
    assert "full bend" in err  # what a person reads went to stderr
    assert not list(tmp_path.iterdir())  # and no file named "-"


def test_material_fit_json_dash_puts_only_the_fit_on_stdout(tmp_path, monkeypatch, capsys):
    data = Path("tests/data/ecoflex0030_uniaxial_tension.csv").resolve()
    monkeypatch.chdir(tmp_path)
    assert main(["material", "fit", str(data), "--json", "-"]) == 0
    out, err = capsys.readouterr()
    fit = json.loads(out)
    assert fit["c10_mpa"] > 0 and "R2" in err
    assert (tmp_path / "out" / "material-fit" / f"{data.stem}.png").is_file() and not (tmp_path / "-").exists()


@pytest.mark.parametrize("argv", [["diagnose", "fpn", "rec.csv"],
                                  ["simulate", "fpn", "--dynamic", "--supply-kpa", "50"]], ids=["diagnose", "dynamic"])
def test_diagnose_and_dynamic_json_dash_reach_stdout(argv, monkeypatch, capsys):
    """The verbs hand the library no file for ``-`` and print its document themselves (the
    library calls are stand-ins here: their own tests run them)."""
    import pnmold.diagnose.run
    import pnmold.simulate.dynamic

    seen = {}

    def fake(*args, json_path=None, **kwargs):
        seen["json_path"] = json_path
        doc = {"schema": "stand-in", "summary": "s", "mismatch": [], "recordings": []}
        return SimpleNamespace(doc=doc, document=doc, summary=["one line"], written=[])

    monkeypatch.setattr(pnmold.diagnose.run, "diagnose_recordings", fake)
    monkeypatch.setattr(pnmold.simulate.dynamic, "run_step_study", fake)
    assert main([*argv, "--json", "-"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["schema"] == "stand-in" and seen == {"json_path": None}
