"""``pnmold diagnose`` on the reduced model: damaged recordings refused before anything is
written; concealed effects named on a small fixed subset of the blind benchmark."""

from __future__ import annotations

import pytest

from pnmold.cli import main
from tests.test_recording import DAMAGED

GOOD_PV = "# kind: pv\nvolume_ml,pressure_kpa\n0,0\n0.5,10\n1.0,20\n"
WITH_COLUMN = sorted(name for name, (_, _, column) in DAMAGED.items() if column is not None)


def test_at_least_eight_kinds_of_damage_name_a_column():
    assert len(WITH_COLUMN) >= 8


@pytest.mark.parametrize("name", sorted(DAMAGED))
def test_damaged_recording_is_refused_and_nothing_is_written(name, tmp_path, capsys):
    text, line, column = DAMAGED[name]
    good = tmp_path / "good.csv"
    good.write_text(GOOD_PV)
    bad = tmp_path / f"{name}.csv"
    bad.write_text(text)
    out_json, report = tmp_path / "d.json", tmp_path / "report"
    code = main(["diagnose", "fpn", str(good), str(bad), "--json", str(out_json), "--report", str(report)])
    err = capsys.readouterr().err
    assert code == 2
    assert f"{name}.csv" in err and f"line {line}" in err
    if column is not None:
        assert str(column) in err
    assert not out_json.exists() and not report.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["good.csv", f"{name}.csv"])
