"""Recordings (docs/recording-format.md): read, write, refuse damaged files with file, line, column; units
converted at reading (a psi recording diagnoses like its kPa twin); templates."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.errors import RecordingError
from pnmold.recording import COLUMNS, METADATA_KEYS, read_recording, recording_template, write_recording
from pnmold.recording.units import PRESSURE_UNITS, PSI_KPA, VOLUME_UNITS

GOOD = """# pnmold-recording: 1
# kind: bending
# design: fpn
# orientation: chambers_up
# camera: nikon d5100
pressure_kpa,tip_x_mm,tip_z_mm,cycle,phase,extra_column
0,111,0,1,inflate,a
10,108.5,-12.3,1,inflate,b
20,99.0,-30.1,1,inflate,c
10,107.9,-13.0,1,deflate,d
"""


def test_reads_a_good_file_keeping_unknown_metadata_and_columns(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(GOOD)
    rec = read_recording(path)
    assert rec.kind == "bending" and rec.orientation == "chambers_up" and rec.design == "fpn"
    assert len(rec) == 4
    np.testing.assert_allclose(rec["tip_z_mm"], [0, -12.3, -30.1, -13.0])
    assert list(rec["phase"]) == ["inflate", "inflate", "inflate", "deflate"]
    assert rec["cycle"].dtype.kind == "i"
    assert rec.metadata["camera"] == "nikon" or rec.metadata["camera"].startswith("nikon")
    assert "extra_column" not in rec.columns


def test_round_trip(tmp_path):
    cols = {"volume_ml": np.array([0.0, 0.5, 1.0]), "pressure_kpa": np.array([0.0, 20.0, 35.5]),
            "cycle": np.array([1, 1, 1]), "phase": np.array(["inflate"] * 3, dtype=object)}
    path = write_recording(tmp_path / "pv.csv", "pv", cols, {"orientation": "submerged"})
    rec = read_recording(path)
    assert rec.kind == "pv" and rec.orientation == "submerged"
    np.testing.assert_allclose(rec["pressure_kpa"], cols["pressure_kpa"])


DAMAGED = {
    "empty": ("", 1, None),
    "unknown-kind": ("# kind: twist\npressure_kpa,force_n\n1,2\n3,4\n", 1, None),
    "missing-column": ("# kind: force\npressure_kpa,torque_nmm\n1,2\n3,4\n", 2, "force_n"),
    "wrong-unit": ("# kind: force\npressure_atm,force_n\n1,2\n3,4\n", 2, "1 (pressure_atm)"),
    "fixed-unit": ("# kind: force\npressure_psi,force_kn\n1,2\n3,4\n", 2, "2 (force_kn)"),
    "absolute-pressure": ("# kind: pv\nvolume_ml,pressure_psia\n1,2\n3,4\n", 2, "2 (pressure_psia)"),
    "two-pressure-columns": ("# kind: force\npressure_kpa,force_n,pressure_psi\n1,2,3\n3,4,5\n", 2,
                             "3 (pressure_psi)"),
    "psi-not-a-number": ("# kind: force\npressure_psi,force_n\n1,2\n3x,4\n", 4, "1 (pressure_psi)"),
    "not-a-number": ("# kind: force\npressure_kpa,force_n\n1,2\n3,abc\n", 4, "2 (force_n)"),
    "nan": ("# kind: force\npressure_kpa,force_n\n1,2\nnan,3\n", 4, "1 (pressure_kpa)"),
    "ragged-row": ("# kind: force\npressure_kpa,force_n\n1,2\n3\n", 4, "2 (force_n)"),
    "time-goes-back": ("# kind: pv\nvolume_ml,pressure_kpa,time_s\n0,0,0\n0.1,1,1\n\n0.2,2,0.5\n", 6, "3 (time_s)"),
    "bad-phase": ("# kind: force\npressure_kpa,force_n,phase\n1,2,inflate\n3,4,sideways\n", 4, "3 (phase)"),
    "bad-cycle": ("# kind: force\npressure_kpa,force_n,cycle\n1,2,1\n3,4,0\n", 4, "3 (cycle)"),
    "one-row": ("# kind: force\npressure_kpa,force_n\n1,2\n", 3, None),
    "bad-orientation": ("# kind: force\n# orientation: sideways\npressure_kpa,force_n\n1,2\n3,4\n", 1, None),
    "bad-metadata": ("# kind force\npressure_kpa,force_n\n1,2\n3,4\n", 1, None),
    "duplicate-column": ("# kind: force\npressure_kpa,force_n,force_n\n1,2,2\n3,4,4\n", 2, "3 (force_n)"),
    "wrong-version": ("# pnmold-recording: 2\n# kind: force\npressure_kpa,force_n\n1,2\n3,4\n", 1, None),
}


@pytest.mark.parametrize("name", sorted(DAMAGED))
def test_damaged_file_is_refused_with_file_line_and_column(name, tmp_path):
    text, line, column = DAMAGED[name]
    path = tmp_path / f"{name}.csv"
    path.write_text(text)
    with pytest.raises(RecordingError) as info:
        read_recording(path)
    err = info.value
    assert err.path == str(path) and f"{name}.csv" in str(err)
    assert err.line == line
    if column is not None:
        assert err.column == column and str(column) in str(err)


def test_non_utf8_is_refused_with_its_line(tmp_path):
    path = tmp_path / "latin1.csv"
    path.write_bytes(b"# kind: force\npressure_kpa,force_n\n1,2\n3,\xe94\n")
    with pytest.raises(RecordingError) as info:
        read_recording(path)
    assert info.value.line == 4


def test_missing_file(tmp_path):
    with pytest.raises(RecordingError, match="cannot read"):
        read_recording(tmp_path / "nope.csv")


# -- layouts: what a spreadsheet saves reads to the same numbers (pnmold.recording.csvlayout) --------

def _table(text: str, delimiter: str, decimal: str = ".") -> str:
    """``text`` (a comma-separated recording) with another delimiter and decimal mark in its table."""
    return "".join(line if line.startswith("#") else line.replace(",", delimiter).replace(".", decimal)
                   for line in text.splitlines(keepends=True))


LAYOUTS = {  # the file's text, the layout pnmold reports
    "semicolon-decimal-comma": (_table(GOOD, ";", ","), "semicolon-separated, decimal comma"),
    "semicolon-decimal-point": (_table(GOOD, ";"), "semicolon-separated"),
    "tab": (_table(GOOD, "\t"), "tab-separated"),
    "tab-decimal-comma": (_table(GOOD, "\t", ","), "tab-separated, decimal comma"),
    "utf8-bom": ("\ufeff" + GOOD, "comma-separated"),
    "spreadsheet": ("\ufeff" + "".join(line + ";;;;;\r\n" if line.startswith("#") else line + "\r\n"
                                       for line in _table(GOOD, ";", ",").splitlines()),
                    "semicolon-separated, decimal comma"),
}


@pytest.mark.parametrize("layout", list(LAYOUTS), ids=list(LAYOUTS))
def test_a_spreadsheets_layout_reads_to_the_same_numbers(layout, tmp_path):
    comma, other = tmp_path / "comma.csv", tmp_path / f"{layout}.csv"
    comma.write_text(GOOD, encoding="utf-8")
    text, found = LAYOUTS[layout]
    other.write_bytes(text.encode("utf-8"))
    assert other.read_bytes() != comma.read_bytes()
    a, b = read_recording(comma), read_recording(other)
    assert b.layout == found and a.layout == "comma-separated"
    assert (b.kind, b.metadata) == (a.kind, a.metadata)
    assert set(b.columns) == set(a.columns)
    for name, values in a.columns.items():
        assert b[name].tolist() == values.tolist(), name


def test_a_decimal_comma_ramp_rate_in_a_semicolon_file(tmp_path):
    path = tmp_path / "ramp.csv"
    path.write_text("# kind: pv\n# rate_kpa_per_s: 2,5\nvolume_ml;pressure_kpa\n0;0\n1,5;2,25\n")
    rec = read_recording(path)
    assert rec.rate_kpa_per_s == 2.5 and rec["volume_ml"].tolist() == [0.0, 1.5]


MISREAD = {  # text, line, column, words: a decimal comma where the comma separates cells, and mixed rows
    "quoted-decimal-comma": ('# kind: force\npressure_kpa,force_n\n1,2\n"1,5",4\n', 4, "1 (pressure_kpa)",
                             "not a number: '1,5' (read as comma-separated: 1,5 looks like a decimal comma; "
                             "save with ';' as the separator or a decimal point)"),
    "decimal-comma-splits-numbers": ("# kind: force\npressure_kpa,force_n\n1,5,2,5\n3,5,4,5\n", 3, 3,
                                     "4 fields, the header has 2 (read as comma-separated: if the numbers have "
                                     "decimal commas, as in 1,5, save with ';' as the separator"),
    "one-decimal-mark": ("# kind: force\npressure_kpa;force_n\n1;2\n1,5;4\n" + "2.5;3\n" * 20, 4,
                         "1 (pressure_kpa)", "1,5 looks like a decimal comma, but the file's last rows have "
                         "decimal points"),
    "one-row-not-semicolons": ("# kind: force\npressure_kpa;force_n\n1;2\n3,4\n", 2, "pressure_kpa",
                               "(read as comma-separated: this row has semicolons)"),
}


@pytest.mark.parametrize("name", list(MISREAD), ids=list(MISREAD))
def test_a_misread_layout_is_refused_saying_the_layout(name, tmp_path):
    text, line, column, words = MISREAD[name]
    path = tmp_path / f"{name}.csv"
    path.write_text(text)
    with pytest.raises(RecordingError) as info:
        read_recording(path)
    assert (info.value.line, info.value.column) == (line, column)
    assert words in str(info.value)


# -- units: converted once at reading, the conversion stated ---------------------------------------

UNIT_CASES = {  # column as written, value, canonical column, value in its unit, factor as stated
    "psi": ("pressure_psi", "2", "pressure_kpa", 2 * 0.45359237 * 9.80665 / 0.0254**2 / 1000, "6.894757"),
    "psig": ("Pressure_PSIG", "1", "pressure_kpa", 0.45359237 * 9.80665 / 0.0254**2 / 1000, "6.894757"),
    "bar": ("pressure_bar", "0.25", "pressure_kpa", 25.0, "100"),
    "mbar": ("pressure_mbar", "50", "pressure_kpa", 5.0, "0.1"),
    "pa": ("pressure_pa", "1500", "pressure_kpa", 1.5, "0.001"),
    "mpa": ("pressure_mpa", "0.01", "pressure_kpa", 10.0, "1000"),
    "ul": ("volume_ul", "250", "volume_ml", 0.25, "0.001"),
    "micro-sign": ("volume_\u00b5L", "250", "volume_ml", 0.25, "0.001"),
    "cc": ("volume_cc", "1.5", "volume_ml", 1.5, "1"),
    "l": ("volume_l", "0.002", "volume_ml", 2.0, "1000"),
}


@pytest.mark.parametrize("case", list(UNIT_CASES), ids=list(UNIT_CASES))
def test_pressure_and_volume_units_are_converted_at_reading(case, tmp_path):
    column, value, canonical, expected, factor = UNIT_CASES[case]
    other = "pressure_kpa" if canonical == "volume_ml" else "volume_ml"
    path = tmp_path / "pv.csv"
    path.write_text(f"# kind: pv\n{column},{other}\n0,0\n{value},1\n", encoding="utf-8")
    rec = read_recording(path)
    assert canonical in rec.columns and column.lower() not in rec.columns
    assert rec[canonical][1] == pytest.approx(expected, rel=1e-15) and rec[canonical][0] == 0
    assert rec[other].tolist() == [0.0, 1.0]
    assert rec.conversions == {canonical: f"from {column} (x {factor})"}


def test_psi_is_the_nist_value():
    """NIST SP 811 (2008) App. B.8: 1 psi = 6.894 757 kPa (rounded); the exact value from the
    pound, standard gravity and the inch rounds to it."""
    assert PSI_KPA == pytest.approx(6.894757, abs=5e-7)
    assert PRESSURE_UNITS["bar"] == 100.0 and VOLUME_UNITS["cc"] == VOLUME_UNITS["ml"] == 1.0


def test_step_columns_and_a_rate_in_psi(tmp_path):
    path = tmp_path / "step.csv"
    path.write_text("# kind: step\ntime_s,supply_bar,pressure_psi,pressure_far_psi\n0,0,0,0\n0.1,1,2,1\n")
    rec = read_recording(path)
    assert rec["supply_kpa"].tolist() == [0.0, 100.0]
    assert rec["pressure_far_kpa"][1] == pytest.approx(PSI_KPA)
    assert set(rec.conversions) == {"supply_kpa", "pressure_kpa", "pressure_far_kpa"}
    ramp = tmp_path / "ramp.csv"
    ramp.write_text("# kind: pv\n# rate_psi_per_s: 0.5\nvolume_ml,pressure_kpa\n0,0\n1,2\n")
    rec = read_recording(ramp)
    assert rec.rate_kpa_per_s == pytest.approx(0.5 * PSI_KPA)
    assert rec.conversions == {"rate_kpa_per_s": "from rate_psi_per_s (x 6.894757)"}
    both = tmp_path / "both.csv"
    both.write_text("# kind: pv\n# rate_psi_per_s: 0.5\n# rate_kpa_per_s: 3\nvolume_ml,pressure_kpa\n0,0\n1,2\n")
    with pytest.raises(RecordingError, match="two ramp rates"):
        read_recording(both)


def test_double_hash_lines_are_comments(tmp_path):
    path = tmp_path / "c.csv"
    path.write_text("## a note without a colon\n# kind: force\n##\n## kind: pv (a comment, not metadata)\n"
                    "pressure_kpa,force_n\n1,2\n3,4\n")
    rec = read_recording(path)
    assert rec.kind == "force" and rec.metadata == {"kind": "force"}


# -- templates ---------------------------------------------------------------------------------------

def _filled_row(name: str, i: int) -> str:
    return {"phase": "inflate", "cycle": "1"}.get(name, str(float(i + 1)))


@pytest.mark.parametrize("kind", list(COLUMNS))
def test_a_filled_in_template_reads_back(kind, tmp_path):
    path = tmp_path / f"{kind}.csv"
    assert main(["-q", "recording", "template", kind, "--out", str(path)]) == 0
    text = path.read_text()
    for key, (kinds, _) in METADATA_KEYS.items():
        assert (f"## {key}: " in text) == (kind in kinds), key
    header = text.splitlines()[-1].split(",")
    assert header == [*COLUMNS[kind][0], *COLUMNS[kind][1]]
    with pytest.raises(RecordingError, match="at least 2 rows") as info:  # empty: the header is read
        read_recording(path)
    assert info.value.line == len(text.splitlines()) + 1
    rows = [",".join(_filled_row(c, i) for c in header) for i in range(2)]
    path.write_text(text + "\n".join(rows) + "\n")
    rec = read_recording(path)
    assert rec.kind == kind and len(rec) == 2 and set(rec.columns) == set(header)
    assert rec.metadata == {"pnmold-recording": "1", "kind": kind, "orientation": "chambers_up"}
    assert rec.conversions == {}


def test_template_goes_to_stdout_and_never_overwrites(tmp_path, capsys):
    assert main(["recording", "template", "pv"]) == 0
    assert capsys.readouterr().out == recording_template("pv")
    path = tmp_path / "lab.csv"
    path.write_text("precious")
    assert main(["recording", "template", "pv", "--out", str(path)]) == 2
    assert path.read_text() == "precious" and "--force" in capsys.readouterr().err
    assert main(["-q", "recording", "template", "pv", "--out", str(path), "--force"]) == 0
    assert path.read_text() == recording_template("pv")


def test_the_step_defaults_the_template_states_are_the_step_models():
    from pnmold.pneumatics import network
    from pnmold.pneumatics.gas import P_ATM_PA, T_REF_K

    stated = {"tubing_length_mm": network.TUBING_LENGTH_MM, "valve_orifice_mm": network.VALVE_ORIFICE_MM,
              "valve_critical_ratio": network.VALVE_CRITICAL_RATIO, "valve_volume_ml": network.VALVE_VOLUME_ML,
              "atmosphere_kpa": P_ATM_PA / 1000, "temperature_k": T_REF_K}
    for key, value in stated.items():
        assert f"default {value:g}" in METADATA_KEYS[key][1].replace("1.0 mm", "1 mm"), key
    assert network.GAS_LAW in METADATA_KEYS["gas_law"][1]


def test_recording_check_states_the_conversions(tmp_path, capsys):
    path = tmp_path / "bench.csv"
    path.write_text("# kind: bending\npressure_psi,tip_x_mm,tip_z_mm\n0,100,0\n1,90,-20\n")
    assert main(["recording", "check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "bending, 2 rows" in out and "pressure_kpa from pressure_psi (x 6.894757)" in out


# -- a psi recording diagnoses to the same answer as its kPa twin ------------------------------------

def _to_psi(src, dst, volume_in_ul: bool = False) -> None:
    """The same recording with its pressure columns in psi (and its volume in uL), full precision."""
    lines = src.read_text().splitlines()
    n = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    header = lines[n].split(",")
    scale = {"pressure_kpa": ("pressure_psi", 1 / PSI_KPA), "volume_ml": ("volume_ul", 1000.0)}
    if not volume_in_ul:
        scale.pop("volume_ml")
    out = lines[:n] + [",".join(scale.get(h, (h,))[0] for h in header)]
    for line in lines[n + 1:]:
        cells = line.split(",")
        out.append(",".join(repr(float(c) * scale[h][1]) if h in scale else c
                            for h, c in zip(header, cells, strict=True)))
    dst.write_text("\n".join(out) + "\n")


@pytest.mark.slow
def test_a_psi_recording_diagnoses_like_its_kpa_twin(tmp_path):
    design = "fig-s2a-h5"  # its characterisation ships with pnmold: no FE here
    kpa = {"bending": tmp_path / "bending.csv", "pv": tmp_path / "pv.csv"}
    for kind, noise in (("bending", ["--noise-mm", "0.3"]), ("pv", ["--noise-ml", "0.01"])):
        # a weight other than the declared (a tip resting on a support): something to name in both units
        assert main(["-q", "simulate", design, "--model", "rom", "--kind", kind, "--pressures", "0:40:5", *noise,
                     "--effects", "gravity=0.3", "--seed", "3", "--recording", str(kpa[kind])]) == 0
    psi = {k: tmp_path / f"{k}-psi.csv" for k in kpa}
    _to_psi(kpa["bending"], psi["bending"])
    _to_psi(kpa["pv"], psi["pv"], volume_in_ul=True)
    assert "pressure_psi" in psi["pv"].read_text() and "pressure_kpa" not in psi["pv"].read_text()
    docs = {}
    for unit, files in (("kpa", kpa), ("psi", psi)):
        out = tmp_path / f"{unit}.json"
        assert main(["-q", "diagnose", design, str(files["bending"]), str(files["pv"]), "--json", str(out)]) == 0
        docs[unit] = json.loads(out.read_text())
    a, b = docs["kpa"], docs["psi"]
    assert [m["effect"] for m in a["missing_physics"]] == [m["effect"] for m in b["missing_physics"]] != []
    for key in ("rmse_before", "rmse_after", "heldout_rmse_before", "heldout_rmse_after"):
        assert b["fit"][key] == pytest.approx(a["fit"][key], rel=1e-9), key
    for key in ("rmse", "heldout_rmse"):  # unrounded in the JSON
        assert b["baseline"][key] == pytest.approx(a["baseline"][key], rel=1e-9), key
    assert b["baseline"]["calibrated"] == pytest.approx(a["baseline"]["calibrated"], rel=1e-9)
    assert b["noise"] == pytest.approx(a["noise"], rel=1e-9)
    for ma, mb in zip(a["missing_physics"], b["missing_physics"], strict=True):
        assert mb["parameters"] == pytest.approx(ma["parameters"], rel=1e-9)
    assert [r["conversions"] for r in a["recordings"]] == [{}, {}]
    assert b["recordings"][0]["conversions"] == {"pressure_kpa": "from pressure_psi (x 6.894757)"}
    assert b["recordings"][1]["conversions"] == {"volume_ml": "from volume_ul (x 0.001)",
                                                 "pressure_kpa": "from pressure_psi (x 6.894757)"}


@pytest.mark.parametrize("pressures, refused, words", [
    ("10,10,10", True, "one pressure"),
    ("-5,-10,-20", True, "at or below 0 kPa"),
    ("0,-3,10,20", False, "below -1 kPa"),
    ("0,-0.4,10,20", None, ""),
])
def test_doubtful_pressures_are_refused_or_warned_with_the_reason(tmp_path, pressures, refused, words):
    from pnmold.recording.sanity import check_usable, doubts

    rows = "".join(f"{p},{100 - i},{-i}\n" for i, p in enumerate(pressures.split(",")))
    path = tmp_path / "r.csv"
    path.write_text("pressure_kpa,tip_x_mm,tip_z_mm\n" + rows)
    rec = read_recording(path)
    if refused is None:
        assert doubts(rec) == [] and check_usable(rec) == []
    elif refused:
        with pytest.raises(RecordingError, match=words) as err:
            check_usable(rec)
        assert str(path) in str(err.value) and "pressure_kpa" in str(err.value)
    else:
        warned = check_usable(rec)
        assert len(warned) == 1 and words in warned[0].message and not warned[0].refuse


def test_diagnose_refuses_one_pressure_before_any_work_and_recording_check_warns(tmp_path, capsys):
    flat = tmp_path / "flat.csv"
    flat.write_text("pressure_kpa,tip_x_mm,tip_z_mm\n10,90,-5\n10,90.2,-5.1\n10,89.9,-4.9\n")
    assert main(["diagnose", "fpn", str(flat), "--json", str(tmp_path / "d.json")]) == 2
    assert "one pressure" in capsys.readouterr().err and not (tmp_path / "d.json").exists()
    offset = tmp_path / "offset.csv"
    offset.write_text("pressure_kpa,tip_x_mm,tip_z_mm\n0,100,0\n-3,100,0\n10,90,-5\n20,80,-10\n")
    assert main(["recording", "check", str(offset)]) == 0
    assert "below -1 kPa" in capsys.readouterr().err
    european = tmp_path / "eu.csv"
    european.write_text("pressure_kpa;tip_x_mm;tip_z_mm\n0;100,5;0\n10,5;90,2;-5\n")
    assert main(["recording", "check", str(european)]) == 0
    assert "read as semicolon-separated, decimal comma" in capsys.readouterr().out
