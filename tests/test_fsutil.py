"""Atomic writes keep the permissions a plain write would give (the umask's), not mkstemp's 0600."""

import os
import stat

from pnmold.fsutil import _UMASK, staged_dir, write_text


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_written_files_and_staged_folders_follow_the_umask(tmp_path):
    out = write_text(tmp_path / "a" / "report.json", "{}")
    assert out.read_text() == "{}"
    assert mode(out) == 0o666 & ~_UMASK
    with staged_dir(tmp_path / "build") as tmp:
        write_text(tmp / "x.txt", "x")
    assert mode(tmp_path / "build") == 0o777 & ~_UMASK
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # nothing half-written left
