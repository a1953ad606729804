"""The one layout reader of lab tables (pnmold.recording.csvlayout): the delimiter and decimal mark
found, the same rules for recordings (tests/test_recording.py) and tensile tests (here and
tests/test_materials.py)."""

from __future__ import annotations

import numpy as np
import pytest

from pnmold.errors import RecordingError
from pnmold.materials import read_tensile
from pnmold.recording.csvlayout import Layout, decode, find_layout

FOUND = {  # lines, (delimiter, decimal comma), as the layout says it
    "comma": (["a,b", "1.5,2", "3,4"], (",", False), "comma-separated"),
    "semicolon": (["a;b", "1.5;2", "3;4"], (";", False), "semicolon-separated"),
    "semicolon-decimal-comma": (["a;b", "1,5;2", "3;4"], (";", True), "semicolon-separated, decimal comma"),
    "tab": (["a\tb", "1.5\t2"], ("\t", False), "tab-separated"),
    "tab-decimal-comma": (["a\tb", "1,5\t2"], ("\t", True), "tab-separated, decimal comma"),
    # a metadata block with ';' above comma-separated data: the last rows decide
    "metadata-block-above": (["Specimen (mm);3", "Standard;D412", "a,b", "1.5,2", "3,4"], (",", False),
                             "comma-separated"),
    # '#' lines and blank lines do not count
    "comments": (["# note; with, both", "", "a;b", "1,5;2", "  "], (";", True), "semicolon-separated, decimal comma"),
    "empty": ([], (",", False), "comma-separated"),
}


@pytest.mark.parametrize("case", list(FOUND), ids=list(FOUND))
def test_the_layout_is_found_from_the_last_rows(case):
    lines, (delimiter, comma), said = FOUND[case]
    layout = find_layout(lines)
    assert (layout.delimiter, layout.decimal_comma) == (delimiter, comma)
    assert str(layout) == said


def test_a_decimal_comma_reads_only_where_the_comma_does_not_separate():
    assert Layout(";", True).number("-1,5e3", "f.csv", 2) == -1500.0
    assert Layout(";", True).number("2.5", "f.csv", 2) == 2.5  # a decimal point still reads
    with pytest.raises(RecordingError, match="looks like a decimal comma; save with ';' as the separator") as info:
        Layout().number("1,5", "f.csv", 7, "2 (force_n)")
    assert (info.value.path, info.value.line, info.value.column) == ("f.csv", 7, "2 (force_n)")
    with pytest.raises(RecordingError, match="use one decimal mark"):
        Layout(";").number("1,5", "f.csv", 7)
    with pytest.raises(RecordingError, match=r"not a number: 'abc'$"):  # the layout explains nothing here
        Layout(";", True).number("abc", "f.csv", 7)
    with pytest.raises(RecordingError, match="not a finite number"):
        Layout().number("inf", "f.csv", 7)


def test_decode_drops_the_byte_order_mark_and_names_the_line_of_a_bad_byte():
    assert decode("\ufeffa,b\n1,2\n".encode(), "f.csv") == "a,b\n1,2\n"
    with pytest.raises(RecordingError, match="not UTF-8") as info:
        decode(b"a,b\n1,2\n3,\xe94\n", "f.csv")
    assert info.value.line == 3


STRAIN = np.linspace(0.1, 1.2, 12)
STRESS = 0.2 * STRAIN + 0.03 * STRAIN**2  # MPa; any increasing curve


def _tensile(delimiter: str = ",", decimal: str = ".") -> str:
    rows = [f"{float(e)!r}{delimiter}{float(s)!r}".replace(".", decimal) for e, s in zip(STRAIN, STRESS, strict=True)]
    return "\n".join([f"eng_strain{delimiter}eng_stress_mpa", *rows]) + "\n"


TENSILE = {"comma": (_tensile(), "comma-separated, header on line 1"),
           "bom": ("\ufeff" + _tensile(), "comma-separated, header on line 1"),
           "semicolon-decimal-comma": (_tensile(";", ","), "semicolon-separated, header on line 1, decimal comma"),
           "tab": (_tensile("\t"), "tab-separated, header on line 1")}


@pytest.mark.parametrize("case", list(TENSILE), ids=list(TENSILE))
def test_a_tensile_file_reads_by_the_same_rules(case, tmp_path):
    text, said = TENSILE[case]
    path = tmp_path / "t.csv"
    path.write_bytes(text.encode("utf-8"))
    data = read_tensile(path)
    assert data.strain.tolist() == STRAIN.tolist() and data.stress_mpa.tolist() == STRESS.tolist()
    assert data.read["layout"] == said


def test_a_tensile_file_with_decimal_commas_between_commas_is_refused(tmp_path):
    """Read as commas, "0,1,0,02" would be a strain of 0 and a stress of 1 MPa: refused instead."""
    path = tmp_path / "t.csv"
    path.write_text(_tensile(",", ","))
    with pytest.raises(RecordingError, match="decimal commas, as in 1,5, save with ';' as the separator") as info:
        read_tensile(path)
    assert info.value.line == 2 and "4 values, the header has 2" in str(info.value)
