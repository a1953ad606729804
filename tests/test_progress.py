"""The build's progress display: every stage with its time, a failed stage named, --quiet silent."""

from __future__ import annotations

import io
import re

import pytest
from rich.console import Console

from pnmold.cli import main
from pnmold.cli.progress import STAGE_LABELS, stage_progress


def console() -> tuple[Console, io.StringIO]:
    buf = io.StringIO()
    return Console(file=buf, width=100, color_system=None), buf


def test_each_stage_shows_with_its_elapsed_time():
    con, buf = console()
    with stage_progress(con, title="build fpn") as say:
        say("cad")
        say("checks")
        say("a stage without a label")
    lines = buf.getvalue().splitlines()
    assert [ln.split()[0] for ln in lines] == ["✓"] * 4
    assert "build fpn" in lines[0]
    assert STAGE_LABELS["cad"] in lines[1] and STAGE_LABELS["checks"] in lines[2]
    assert "a stage without a label" in lines[3]
    assert all(re.search(r"\d:\d\d:\d\d$", ln.rstrip()) for ln in lines)


def test_a_failed_stage_is_named_and_the_error_goes_on():
    con, buf = console()
    with pytest.raises(KeyError), stage_progress(con) as say:
        say("fem")
        raise KeyError("boom")
    assert f"failed: {STAGE_LABELS['fem']}" in buf.getvalue()


def test_quiet_shows_nothing():
    con, buf = console()
    with stage_progress(con, quiet=True) as say:
        say("cad")
    assert buf.getvalue() == ""


def test_build_shows_its_stages_on_stderr_unless_quiet(tmp_path, capsys):
    assert main(["build", "--out", str(tmp_path / "fpn"), "--no-fem", "--no-slicer"]) == 0
    err = capsys.readouterr().err
    for stage in ("cad", "export", "measure", "checks", "report"):
        assert STAGE_LABELS[stage] in err, stage
    assert STAGE_LABELS["fem"] not in err
    assert (tmp_path / "fpn" / "report.html").is_file()
