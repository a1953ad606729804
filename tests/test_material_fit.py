"""``pnmold material fit``'s default range and weighting (where actuators work, relative error), the
whole test on request, and a percent strain column that reads as a ratio (refused)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.errors import RecordingError
from pnmold.materials import TensileData, fit_hyperelastic, read_tensile
from pnmold.materials.fit import ACTUATOR_MAX_STRAIN, TensileColumns, yeoh_stress
from pnmold.materials.tensile import MAX_RATIO_STRAIN

DATA = Path(__file__).parent / "data"
DRAGON_SKIN = DATA / "srmd-dragon-skin-30.csv"  # the Soft Robotics Materials Database's file, to 704 % strain


def _fit(tmp_path, capsys, *options: str, file: Path = DRAGON_SKIN) -> tuple[dict, str]:
    out = tmp_path / f"fit{len(list(tmp_path.glob('*.json')))}.json"
    assert main(["material", "fit", str(file), *options, "--json", str(out)]) == 0
    return json.loads(out.read_text()), capsys.readouterr().out


def test_the_default_fit_holds_where_actuators_work(tmp_path, capsys):
    """Dragon Skin 30 to break: the whole test gives a C10 that holds only past ~200 % strain; the
    default fits up to 150 % weighting the relative error, and lands within 10 % of the fit up to
    150 % (the library's), holding from the smallest strains up, and says which strains it held."""
    default, printed = _fit(tmp_path, capsys)
    upto, _ = _fit(tmp_path, capsys, "--max-strain", str(ACTUATOR_MAX_STRAIN))
    full, _ = _fit(tmp_path, capsys, "--max-strain", "full")
    assert default["c10_mpa"] == pytest.approx(upto["c10_mpa"], rel=0.10)
    assert abs(full["c10_mpa"] / upto["c10_mpa"] - 1) > 0.10  # what the default no longer gives
    data = read_tensile(DRAGON_SKIN)
    inside = data.strain[data.strain <= ACTUATOR_MAX_STRAIN]
    assert default["max_strain"] == ACTUATOR_MAX_STRAIN and default["weighting"] == "relative"
    assert default["fitted_strain_range"] == [inside.min(), inside.max()] and default["n_points"] == len(inside)
    assert default["n_above_max_strain"] == len(data.strain) - len(inside)
    lo, hi = default["strain_range"]
    assert lo <= upto["strain_range"][0] and hi == pytest.approx(inside.max())  # small strains held too
    assert f"holds over strain {lo:.3g} to {hi:.3g}" in printed
    fitted = f"fitted: strain {inside.min():.3g} to {inside.max():.3g}, {len(inside)} points, weighting the relative"
    assert fitted in printed


def test_the_full_range_reaches_the_files_last_point(tmp_path, capsys):
    full, printed = _fit(tmp_path, capsys, "--max-strain", "full")
    last = DRAGON_SKIN.read_text().splitlines()[-1].split(";")
    assert full["fitted_strain_range"][1] == float(last[3]) and full["max_strain"] is None
    assert full["weighting"] == "absolute" and full["n_above_max_strain"] == 0
    assert full["n_points"] + full["n_dropped_after_failure"] == len(read_tensile(DRAGON_SKIN).strain)
    assert "left out" not in printed


def test_the_weighting_can_be_chosen_with_any_range(tmp_path, capsys):
    default, _ = _fit(tmp_path, capsys)
    same, _ = _fit(tmp_path, capsys, "--max-strain", str(ACTUATOR_MAX_STRAIN), "--weighting", "relative")
    assert same["c10_mpa"] == default["c10_mpa"] and same["c20_mpa"] == default["c20_mpa"]
    absolute, _ = _fit(tmp_path, capsys, "--weighting", "absolute")
    assert absolute["c10_mpa"] != default["c10_mpa"] and absolute["max_strain"] == ACTUATOR_MAX_STRAIN


def test_a_test_that_stops_before_the_default_range_is_fitted_whole(tmp_path, capsys):
    strain = np.linspace(0.05, 0.6 * ACTUATOR_MAX_STRAIN, 12)
    path = tmp_path / "short.csv"
    path.write_text("eng_strain,eng_stress_mpa\n" + "".join(
        f"{e!r},{s!r}\n" for e, s in zip(strain.tolist(), yeoh_stress(strain, 0.1, 0.01).tolist(), strict=True)))
    doc, _ = _fit(tmp_path, capsys, file=path)
    assert doc["n_points"] == len(strain) and doc["n_above_max_strain"] == 0
    assert doc["c10_mpa"] == pytest.approx(0.1, rel=1e-6) and doc["c20_mpa"] == pytest.approx(0.01, rel=1e-5)


def test_relative_weighting_follows_the_small_strains_past_a_slack_start():
    """A specimen slack at first (no stress on its first two points): weighting the relative error, with
    the Cauchy loss, the constants come back closer than the stress error in MPa brings them."""
    strain = np.linspace(0.05, ACTUATOR_MAX_STRAIN, 30)
    stress = yeoh_stress(strain, 0.1, 0.01)
    stress[:2] = 0.0
    data = TensileData(strain, stress, ("tension",) * len(strain), "slack", tuple(range(2, len(strain) + 2)))
    error = {w: abs(fit_hyperelastic(data, "yeoh", weighting=w).constants["c10_mpa"] / 0.1 - 1)
             for w in ("relative", "absolute")}
    assert error["relative"] < error["absolute"]
    assert fit_hyperelastic(data, "yeoh", weighting="relative").strain_range == pytest.approx((strain[2], strain[-1]))


@pytest.mark.parametrize("value", ["x", "nan"], ids=["word", "nan"])
def test_a_bad_max_strain_is_refused(value, tmp_path, capsys):
    assert main(["material", "fit", str(DRAGON_SKIN), "--max-strain", value, "--json", str(tmp_path / "f.json")]) == 2
    assert "--max-strain" in capsys.readouterr().err and not (tmp_path / "f.json").exists()


# -- a percent strain column read as a ratio ----------------------------------------------------------

STRAIN = np.linspace(0.1, 3.0, 30)
STRESS = yeoh_stress(STRAIN, 0.1, 0.01)


def _percent_file(tmp_path, header: str = "Strain,Stress (MPa)") -> Path:
    path = tmp_path / "percent.csv"
    path.write_text(header + "\n" + "".join(f"{100 * e!r},{s!r}\n"
                                            for e, s in zip(STRAIN.tolist(), STRESS.tolist(), strict=True)))
    return path


@pytest.mark.parametrize("header", ["Strain,Stress (MPa)", "Strain (mm/mm),Stress (MPa)", "True Strain,Stress (MPa)"],
                         ids=["no-unit", "ratio-unit", "true-strain"])
def test_percent_values_in_a_ratio_column_are_refused(header, tmp_path):
    path = _percent_file(tmp_path, header)
    with pytest.raises(RecordingError) as info:
        read_tensile(path)
    first = 2 + int(np.argmax(100 * STRAIN > (np.log1p(MAX_RATIO_STRAIN) if "True" in header else MAX_RATIO_STRAIN)))
    assert info.value.path == str(path) and info.value.line == first
    assert info.value.column == header.split(",")[0] and "--strain-unit %" in str(info.value)


def test_a_percent_column_reads_with_its_unit_and_a_real_ratio_with_insistence(tmp_path, capsys):
    path = _percent_file(tmp_path)
    np.testing.assert_allclose(read_tensile(path, TensileColumns(strain_unit="%")).strain, STRAIN, rtol=1e-12)
    np.testing.assert_allclose(read_tensile(path, TensileColumns(strain_unit="ratio")).strain, 100 * STRAIN)
    assert main(["material", "fit", str(path), "--json", str(tmp_path / "f.json")]) == 2
    assert "percent.csv, line" in capsys.readouterr().err
    doc, _ = _fit(tmp_path, capsys, "--strain-unit", "%", file=path)
    assert doc["c10_mpa"] == pytest.approx(0.1, rel=1e-6)
