"""Recordings (CONTRACTS.md §4): read, write, and refuse damaged files with file, line, column."""

from __future__ import annotations

import numpy as np
import pytest

from pnmold.errors import RecordingError
from pnmold.recording import read_recording, write_recording

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
    "wrong-unit": ("# kind: force\npressure_psi,force_n\n1,2\n3,4\n", 2, "1 (pressure_psi)"),
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
