"""Tests of pnmold.checks.slicer against the real PrusaSlicer (skipped only where it is missing)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from pnmold.checks.slicer import (
    DEFAULT_PROFILE,
    NOT_FOUND,
    bed_size_mm,
    find_slicer,
    parse_duration,
    parse_gcode_trailer,
    parse_info,
    read_profile,
    slice_part,
)
from pnmold.errors import ExportError, UsageError

needs_slicer = pytest.mark.skipif(
    find_slicer() is None,
    reason="PrusaSlicer not installed (apt-get install prusa-slicer; CI installs it)",
)

TRAILER = """\
G1 X10 Y10 E0.5
M84     ; disable motors
; filament used [mm] = 1531.63
; filament used [cm3] = 3.68
; filament used [g] = 3.83
; total filament used [g] = 3.83
; total filament cost = 0.00
; estimated printing time (normal mode) = 1h 19m 53s
; estimated first layer printing time (normal mode) = 1m 2s

; prusaslicer_config = begin
; layer_height = 0.2
; prusaslicer_config = end
"""

INFO = """\
[2026-11-22 04:58:49.428715] [0x00007f7be6524d80] [trace]   Initializing StaticPrintConfigs
[open.stl]
size_x = 20.000000
manifold = no
open_edges = 3
number_of_parts =  1
"""


def _box_stl(tmp_path, name, extents, drop_face=None):
    """Write a box STL into tmp_path, optionally with one triangle removed (no repair)."""
    mesh = trimesh.creation.box(extents=extents)
    if drop_face is not None:
        keep = np.ones(len(mesh.faces), dtype=bool)
        keep[drop_face] = False
        mesh = trimesh.Trimesh(mesh.vertices, mesh.faces[keep], process=False)
    path = tmp_path / name
    mesh.export(path)
    return path


def test_parse_gcode_trailer():
    stats = parse_gcode_trailer(TRAILER)
    assert stats["print_time_s"] == 3600 + 19 * 60 + 53
    assert stats["filament_mm"] == pytest.approx(1531.63)
    assert stats["filament_g"] == pytest.approx(3.83)


def test_parse_gcode_trailer_missing_lines():
    assert parse_gcode_trailer("G28\nG1 X0\n") == {
        "print_time_s": None, "filament_mm": None, "filament_g": None}


@pytest.mark.parametrize(("text", "seconds"), [
    ("45s", 45), ("19m 37s", 1177), ("2h 0m 5s", 7205), ("1d 1h 1m 1s", 90061), ("", None),
], ids=["s", "m-s", "h-m-s", "d-h-m-s", "empty"])
def test_parse_duration(text, seconds):
    assert parse_duration(text) == seconds


def test_parse_info_skips_log_and_header_lines():
    info = parse_info(INFO)
    assert info == {"size_x": "20.000000", "manifold": "no", "open_edges": "3",
                    "number_of_parts": "1"}


def test_profile_matches_build_volume():
    profile = read_profile(DEFAULT_PROFILE)
    assert bed_size_mm(profile) == (203.0, 203.0, 305.0)
    assert profile["nozzle_diameter"] == "0.4"
    assert profile["layer_height"] == "0.2"
    assert (profile["temperature"], profile["bed_temperature"]) == ("255", "100")
    assert profile["perimeters"] == "3"
    assert profile["fill_density"] == "20%"
    assert profile["support_material"] == "0"
    assert profile["filament_diameter"] == "1.75"
    assert profile["filament_density"] == "1.04"


def test_missing_slicer_is_skipped(tmp_path, monkeypatch):
    monkeypatch.setenv("PNMOLD_SLICER", str(tmp_path / "no-such-slicer"))
    assert find_slicer() is None
    result = slice_part(_box_stl(tmp_path, "cube.stl", (20, 20, 20)))
    assert (result.verdict, result.available) == ("skipped", False)
    assert result.reason == NOT_FOUND


def test_missing_stl_raises(tmp_path):
    with pytest.raises(ExportError, match="does not exist"):
        slice_part(tmp_path / "absent.stl")


def test_missing_profile_raises(tmp_path):
    stl = _box_stl(tmp_path, "cube.stl", (20, 20, 20))
    with pytest.raises(UsageError, match="profile does not exist"):
        slice_part(stl, profile=tmp_path / "absent.ini")


@needs_slicer
def test_cube_slices_ok(tmp_path):
    result = slice_part(_box_stl(tmp_path, "cube.stl", (20, 20, 20)), workdir=tmp_path / "out")
    assert result.verdict == "ok", result.reason
    assert result.available and result.manifold and result.open_edges == 0
    assert result.print_time_s > 0
    # 8 cm3 cube, 3 perimeters, 20 % infill: a few grams of ABS, not 8.3 g (solid)
    assert 0 < result.filament_g < 8.0
    assert result.filament_mm > 0
    assert result.slicer_version
    assert (tmp_path / "out" / "cube.gcode").is_file()


@needs_slicer
def test_open_mesh_fails(tmp_path):
    stl = _box_stl(tmp_path, "open.stl", (20, 20, 20), drop_face=0)
    before = stl.read_bytes()
    result = slice_part(stl)
    assert result.verdict == "failed"
    assert result.open_edges > 0 and result.manifold is False
    assert "open edges" in result.reason
    assert stl.read_bytes() == before  # never repaired


@needs_slicer
def test_part_larger_than_bed_fails(tmp_path):
    result = slice_part(_box_stl(tmp_path, "long.stl", (250, 20, 10)))
    assert result.verdict == "failed"
    assert "does not fit" in result.reason


@needs_slicer
def test_unreadable_stl_fails(tmp_path):
    stl = tmp_path / "junk.stl"
    stl.write_text("not an stl")
    result = slice_part(stl)
    assert result.verdict == "failed"
    assert "could not read" in result.reason


@needs_slicer
def test_too_thin_part_fails(tmp_path):
    result = slice_part(_box_stl(tmp_path, "flat.stl", (20, 20, 0.05)))
    assert result.verdict == "failed"
    assert "slicing failed" in result.reason
