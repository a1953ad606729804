"""Atomic file and folder writes: a crash never leaves half a file or half a build."""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from pnmold.errors import FileAccessError, OutputError, UsageError


def _read_umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: read once at import: os.umask can only be read by setting it, which races with threads
_UMASK = _read_umask()


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to a temporary name beside ``path``, then rename it over ``path``."""
    return write_bytes(path, text.encode("utf-8"))


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix) for a writer that wants a file name; when the
    block ends without error it is renamed over ``path``, otherwise removed. The one way pnmold
    writes a file: a crash never leaves half of it. A path that cannot be written is a
    :class:`~pnmold.errors.FileAccessError` naming ``path``, not the temporary name."""
    path = Path(path)
    if path.is_dir():
        raise FileAccessError(path, "is a folder; give a file name")
    _check_parents(path)
    with _access(path, "cannot write"):
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
        os.close(fd)
    try:
        yield Path(tmp)
        with _access(path, "cannot write"):
            os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp's 0600 would hide results from the lab's group
            os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _check_parents(path: Path) -> None:
    """A file where a folder of ``path`` should be is named as such (mkdir would say only "File exists")."""
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise FileAccessError(path, f"{parent} is a file, not a folder")
            return


@contextmanager
def _access(path: Path, doing: str) -> Iterator[None]:
    """An OSError inside the block as a FileAccessError naming ``path`` (the user's, not a temporary one)."""
    try:
        yield
    except OSError as err:
        raise FileAccessError(path, f"{doing}: {err.strerror or err}") from err


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to a temporary name beside ``path``, then rename it over ``path``."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_json(path: str | Path, data: Any) -> Path:
    return write_text(path, json.dumps(data, indent=2, allow_nan=False) + "\n")


#: the file that marks a folder as pnmold's (JSON: which verb wrote it and the files it wrote)
MARKER = ".pnmold-output"


def staged_dir(final: str | Path, what: str = "output") -> Iterator[Path]:
    """Yield a fresh temporary folder; on success it replaces ``final`` as a whole.

    ``final`` may be absent, an empty folder or a folder pnmold wrote (its :data:`MARKER` lists
    every file in it); anything else is refused with an :class:`~pnmold.errors.OutputError`
    before any work starts, and again just before the swap. A lock beside ``final`` (filelock)
    keeps two runs out of the same folder; temporary folders of killed runs are removed. On any
    error the temporary folder is removed and ``final`` is left exactly as it was.
    """
    return _staged(Path(final), what)


@contextmanager
def _staged(final: Path, what: str) -> Iterator[Path]:
    check_replaceable(final)
    _check_parents(final)
    with _access(final, "cannot create"):
        final.parent.mkdir(parents=True, exist_ok=True)
    with _locked(final):
        _remove_stale(final)
        with _access(final, "cannot create a folder beside it"):
            tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.tmp-", dir=final.parent))
            os.chmod(tmp, 0o777 & ~_UMASK)  # as a plain mkdir would make it, not mkdtemp's 0700
            _write_marker(tmp, what, None)
        try:
            yield tmp
            _write_marker(tmp, what, sorted(_files(tmp)))
            check_replaceable(final)  # again: something may have been put there meanwhile
            _swap(tmp, final)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise


def _swap(tmp: Path, final: Path) -> None:
    old = None
    with _access(final, "cannot replace"):
        if final.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{final.name}.old-", dir=final.parent))
            os.rmdir(old)
            os.replace(final, old)
        os.replace(tmp, final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def check_replaceable(final: str | Path) -> None:
    """Refuse (OutputError, exit 2) unless ``final`` is absent, an empty folder or a folder whose
    every file pnmold wrote (listed in its marker, or in a sub-folder's own marker)."""
    final = Path(final)
    if not final.exists() and not final.is_symlink():
        return
    if final.is_symlink() or not final.is_dir():
        raise OutputError(final, "is a file, not a folder; give a new folder's name")
    here = Path.cwd().resolve()
    if final.resolve() in (here, *here.parents):
        raise OutputError(final, "is the working folder or holds it; give a new folder's name")
    foreign = foreign_files(final)
    if foreign:
        shown = ", ".join(str(p.relative_to(final)) for p in foreign[:3])
        more = f" and {len(foreign) - 3} more" if len(foreign) > 3 else ""
        raise OutputError(final, f"holds files pnmold did not write ({shown}{more}); pnmold replaces only a "
                          "folder it wrote itself or an empty one: give a new folder's name, or move those files")


def foreign_files(folder: Path) -> list[Path]:
    """Files under ``folder`` that its marker does not list (all of them when there is no marker);
    a sub-folder with a marker of its own answers for itself."""
    listed = _listed(folder)
    if listed == "*":
        return []
    found = []
    for root, dirs, files in os.walk(folder):
        root = Path(root)
        for d in list(dirs):
            sub = root / d
            if sub.is_symlink():
                dirs.remove(d)
                files.append(d)
            elif (sub / MARKER).is_file():
                dirs.remove(d)
                found += foreign_files(sub)
        for f in files:
            rel = (root / f).relative_to(folder).as_posix()
            if rel != MARKER and (listed is None or rel not in listed):
                found.append(root / f)
    return sorted(found)


def _listed(folder: Path) -> set[str] | str | None:
    """The files the marker lists; "*" for a folder still being written; None without a (readable) marker."""
    try:
        doc = json.loads((folder / MARKER).read_text(encoding="utf-8"))
        files = doc["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if files is None:
        return "*"
    return {str(f) for f in files} if isinstance(files, list) else None


def _files(folder: Path) -> list[str]:
    paths = (p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file() or p.is_symlink())
    return [rel for rel in paths if rel != MARKER]


def _write_marker(folder: Path, what: str, files: list[str] | None) -> None:
    from pnmold.version import __version__

    doc = {"schema": "pnmold.output/1", "written_by": f"pnmold {__version__}", "what": what, "files": files}
    write_json(folder / MARKER, doc)


@contextmanager
def _locked(final: Path) -> Iterator[None]:
    """Hold ``.NAME.lock`` beside ``final`` (filelock: flock on Unix, LockFileEx on Windows)."""
    from filelock import FileLock, Timeout

    lock = FileLock(final.parent / f".{final.name}.lock")
    try:
        lock.acquire(timeout=0)
    except Timeout:  # before OSError: filelock's Timeout is a TimeoutError
        raise OutputError(final, "another pnmold run is writing this folder; wait for it to finish or "
                          "give another folder") from None
    except OSError as err:
        raise FileAccessError(final, f"cannot lock: {err.strerror or err}") from err
    try:
        yield
    finally:  # removed while held, as the sweep store does: filelock drops a lock taken on an unlinked file
        if os.name == "posix":
            Path(lock.lock_file).unlink(missing_ok=True)
        lock.release()


def _remove_stale(final: Path) -> None:
    """Remove ``.NAME.tmp-*`` and ``.NAME.old-*`` beside ``final``: folders of runs killed mid-way
    (the lock is held, so no live run owns them), and only when every file in them is pnmold's."""
    for pattern in (f".{final.name}.tmp-*", f".{final.name}.old-*"):
        for stale in final.parent.glob(pattern):
            if stale.is_dir() and not stale.is_symlink() and not foreign_files(stale):
                shutil.rmtree(stale, ignore_errors=True)


#: a temporary file of :func:`atomic_path` this old was left by a killed run (a write takes milliseconds)
STALE_TEMP_S = 3600.0


def claim_store(folder: str | Path, what: str, ours: re.Pattern[str]) -> Path:
    """A folder pnmold keeps adding files to (the FE cache). One without a marker is adopted (marked)
    only when every file in it is a name pnmold writes there (``ours``), else refused with an
    OutputError; an absent one is left absent (reading makes no folder: the first write makes it).
    Temporary files of killed writes are removed."""
    folder = Path(folder)
    if not folder.is_dir():
        check_replaceable(folder)  # a file in the way is refused
        return folder
    if _listed(folder) is None:
        foreign = [p.name for p in folder.iterdir() if not ours.fullmatch(p.name) and not _temp(p.name)]
        if foreign:
            raise OutputError(folder, f"the {what} here holds files pnmold did not write ({', '.join(foreign[:3])}"
                              f"{' ...' if len(foreign) > 3 else ''}); give it a folder of its own")
        with _access(folder, f"cannot write the {what}"):
            _write_marker(folder, what, None)
    now = time.time()
    for p in folder.iterdir():
        if _temp(p.name) and p.is_file() and now - p.stat().st_mtime > STALE_TEMP_S:
            p.unlink(missing_ok=True)
    return folder


def _temp(name: str) -> bool:
    """A temporary name of :func:`atomic_path` (``.NAME.xxxxxxxx.suffix``)."""
    return name.startswith(".") and name != MARKER and name.count(".") >= 2


def read_json(path: str | Path, what: str = "JSON file") -> Any:
    """Read a JSON file pnmold wrote (a report, a cache entry); a missing, unreadable or corrupt one is
    a :class:`~pnmold.errors.UsageError` or FileAccessError naming the file and line."""
    path = Path(path)
    with _access(path, f"cannot read the {what}"):
        text = path.read_text(encoding="utf-8")
    try:
        return json.loads(text)
    except ValueError as err:
        where = f", line {err.lineno}" if hasattr(err, "lineno") else ""
        raise UsageError(f"{path}{where}: not a valid {what} ({getattr(err, 'msg', err)}); "
                         "write it again with the pnmold verb that made it") from err
