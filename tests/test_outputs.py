"""Output folders: pnmold replaces only what it wrote, locks what it writes, cleans what a killed run
left, and names the user's path when a file cannot be written."""

import json
import re
import sqlite3

import pytest
from filelock import FileLock

from pnmold.cli import main
from pnmold.errors import EXIT_IO, FileAccessError, OutputError, UsageError
from pnmold.fsutil import MARKER, claim_store, foreign_files, read_json, staged_dir, write_json, write_text
from pnmold.sweep.store import SweepStore


def lab_folder(path):
    """A folder of a lab's own files (and a sub-folder), with their bytes for comparison."""
    (path / "raw").mkdir(parents=True)
    files = {path / "r.csv": b"pressure_kpa,tip_x_mm,tip_z_mm\n0,100,0\n", path / "raw" / "cam.bin": bytes(range(256))}
    for p, data in files.items():
        p.write_bytes(data)
    return files


def unchanged(files) -> bool:
    return all(p.read_bytes() == data for p, data in files.items())


def stage(folder, **files):
    with staged_dir(folder, "test") as tmp:
        for name, text in files.items():
            write_text(tmp / name, text)
    return folder


def test_a_staged_folder_carries_a_marker_listing_every_file_it_holds(tmp_path):
    out = tmp_path / "b"
    with staged_dir(out, "test") as tmp:
        write_text(tmp / "a.txt", "a")
        write_text(tmp / "fem" / "step_1.vtu", "v")
    doc = json.loads((out / MARKER).read_text())
    assert doc["what"] == "test" and doc["files"] == ["a.txt", "fem/step_1.vtu"]
    assert foreign_files(out) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b"]  # no lock, no temporary folder left


@pytest.mark.parametrize("where", ["lab", "working folder", "file"])
def test_a_folder_of_the_labs_files_is_refused_and_kept_byte_for_byte(tmp_path, monkeypatch, where):
    lab = tmp_path / "lab"
    files = lab_folder(lab)
    target = {"lab": lab, "working folder": lab / "raw", "file": lab / "r.csv"}[where]
    monkeypatch.chdir(lab / "raw")
    with pytest.raises(OutputError, match=re.escape(str(target))):
        stage(target, **{"x.txt": "x"})
    assert unchanged(files)
    assert sorted(p.name for p in lab.iterdir()) == ["r.csv", "raw"]


def test_an_empty_folder_and_pnmolds_own_are_replaced_and_a_file_put_in_one_stops_it(tmp_path):
    out = tmp_path / "b"
    out.mkdir()
    stage(out, **{"a.txt": "1"})
    stage(out, **{"b.txt": "2"})
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "b.txt"]
    (out / "notes.txt").write_text("the lab's")
    with pytest.raises(OutputError, match="notes.txt"):
        stage(out, **{"c.txt": "3"})
    assert (out / "notes.txt").read_text() == "the lab's" and (out / "b.txt").read_text() == "2"


def test_a_sub_folder_pnmold_wrote_answers_for_itself(tmp_path):
    out = stage(tmp_path / "b", **{"a.txt": "1"})
    stage(out / "abaqus", **{"deck.inp": "*"})
    assert foreign_files(out) == []
    (out / "abaqus" / "mine.inp").write_text("lab")
    assert foreign_files(out) == [out / "abaqus" / "mine.inp"]


def test_a_killed_runs_temporary_folders_are_removed_but_never_one_holding_other_files(tmp_path):
    out = stage(tmp_path / "b", **{"a.txt": "1"})
    killed = tmp_path / ".b.tmp-killed"
    killed.mkdir()
    (killed / MARKER).write_text(json.dumps({"files": None}))  # as staged_dir marks it when it starts
    (killed / "half.stl").write_text("solid")
    strange = tmp_path / ".b.old-strange"
    strange.mkdir()
    (strange / "lab.csv").write_text("1")
    stage(out, **{"a.txt": "2"})
    assert not killed.exists()
    assert (strange / "lab.csv").read_text() == "1"


def test_a_folder_another_run_is_writing_is_refused(tmp_path):
    out = tmp_path / "b"
    with FileLock(tmp_path / ".b.lock"):
        with pytest.raises(OutputError, match="another pnmold run"):
            stage(out, **{"a.txt": "1"})
    assert not out.exists()
    stage(out, **{"a.txt": "1"})
    assert (out / "a.txt").read_text() == "1"


def test_a_file_that_cannot_be_written_names_the_users_path(tmp_path):
    (tmp_path / "d").mkdir()
    with pytest.raises(FileAccessError, match=re.escape(f"{tmp_path / 'd'}: is a folder")):
        write_json(tmp_path / "d", {})
    (tmp_path / "f").write_text("x")
    with pytest.raises(FileAccessError) as err:
        write_json(tmp_path / "f" / "out.json", {})
    assert err.value.path == str(tmp_path / "f" / "out.json") and err.value.exit_code == EXIT_IO
    assert (tmp_path / "f").read_text() == "x"


def test_a_corrupt_report_is_named_with_its_line(tmp_path):
    (tmp_path / "report.json").write_text('{\n  "schema": "pnmold.build/1",\n  "fem": \n')
    with pytest.raises(UsageError, match=r"report.json, line 4: not a valid build report"):
        read_json(tmp_path / "report.json", "build report")


def test_the_fe_cache_adopts_its_own_files_refuses_a_labs_folder_and_drops_stale_temporaries(tmp_path):
    names = re.compile(r"[\w.+-]+-v\d+\.json")
    cache = tmp_path / "cache"
    cache.mkdir()
    (cache / "fpn-abc-m1x2x3h-p50-g1-v2.json").write_text("{}")
    stale = cache / ".fpn-abc.json.k2j3.json"
    stale.write_text("{")
    import os

    os.utime(stale, (0, 0))
    claim_store(cache, "FE cache", names)
    assert (cache / MARKER).is_file() and not stale.exists()
    lab = tmp_path / "lab"
    files = lab_folder(lab)
    with pytest.raises(OutputError, match="r.csv"):
        claim_store(lab, "FE cache", names)
    assert unchanged(files) and not (lab / MARKER).exists()
    assert claim_store(tmp_path / "absent", "FE cache", names) == tmp_path / "absent"
    assert not (tmp_path / "absent").exists()  # reading makes no folder; the first write does


def test_a_sweep_store_refuses_a_database_it_did_not_write(tmp_path):
    db = tmp_path / "lab.sqlite"
    with sqlite3.connect(db) as con:
        con.execute("CREATE TABLE samples (id INTEGER)")
    before = db.read_bytes()
    with pytest.raises(UsageError, match="did not write"):
        SweepStore(db)
    assert db.read_bytes() == before


def test_the_command_line_refuses_a_labs_folder_with_exit_2_and_an_unwritable_file_with_its_code(tmp_path, capsys):
    lab = tmp_path / "lab"
    files = lab_folder(lab)
    assert main(["build", "--out", str(lab), "--no-fem", "--quiet"]) == 2
    assert unchanged(files) and "did not write" in capsys.readouterr().err
    assert main(["effects", "--json", str(lab)]) == EXIT_IO
    assert unchanged(files) and "is a folder" in capsys.readouterr().err
