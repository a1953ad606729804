"""Slice an exported STL with PrusaSlicer: the real-slicer check of printable output.

PrusaSlicer (Debian package ``prusa-slicer``) runs headless from its command line. Two
calls per part, both plain ``subprocess.run`` with a timeout::

    prusa-slicer --loglevel 2 --info PART.stl
    prusa-slicer --loglevel 2 --datadir TMP/datadir --load PROFILE.ini --export-gcode
                 --center CX,CY --output TMP/PART.gcode PART.stl

The first reports mesh health (manifold, open edges, parts, size); the second slices with
the project's ABS profile and writes G-code whose trailer comments carry the estimated
printing time and the filament used. Slicing repairs the mesh in PrusaSlicer's memory, so
mesh health is judged from ``--info`` alone and a defective part is not sliced; nothing
here repairs or rewrites the STL. Like every check, this reports rather than raises.
"""

from __future__ import annotations

import functools
import logging
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from pnmold.errors import ExportError, UsageError

logger = logging.getLogger(__name__)

#: The project's ABS print profile (PrusaSlicer .ini).
DEFAULT_PROFILE = Path(str(resources.files("pnmold") / "data" / "prusaslicer_abs.ini"))
SLICER_ENV = "PNMOLD_SLICER"
NOT_FOUND = "PrusaSlicer not found (install the Debian package prusa-slicer)"

_LOG_PREFIX = re.compile(r"^\[[^\]]*\] \[[^\]]*\] \[(\w+)\]\s*")  # [time] [thread] [level]
_DURATION = re.compile(r"(\d+)([dhms])")
_SECONDS = {"d": 86400, "h": 3600, "m": 60, "s": 1}


@dataclass(frozen=True)
class SliceResult:
    """What slicing one STL found; ``verdict`` is "ok", "failed" or "skipped"."""

    available: bool
    verdict: str
    reason: str
    print_time_s: float | None = None
    filament_mm: float | None = None
    filament_g: float | None = None
    manifold: bool | None = None
    open_edges: int | None = None
    slicer_version: str | None = None
    warnings: tuple[str, ...] = ()


def find_slicer() -> str | None:
    """Path of the PrusaSlicer executable: ``$PNMOLD_SLICER`` if set, else on PATH."""
    override = os.environ.get(SLICER_ENV)  # set but naming no executable: None, no fallback
    return shutil.which(override) if override else shutil.which("prusa-slicer")


def parse_duration(text: str) -> float | None:
    """Seconds in a PrusaSlicer duration such as ``"1d 2h 19m 37s"``; None if none."""
    parts = _DURATION.findall(text)
    if not parts:
        return None
    return float(sum(int(n) * _SECONDS[unit] for n, unit in parts))


def parse_gcode_trailer(text: str) -> dict[str, float | None]:
    """``print_time_s`` (normal mode), ``filament_mm``, ``filament_g`` from G-code comments.

    None where a line is missing; per-extruder values are summed.
    """
    keys = {"estimated printing time (normal mode)": "print_time_s",
            "filament used [mm]": "filament_mm", "filament used [g]": "filament_g"}
    found: dict[str, float | None] = dict.fromkeys(keys.values())
    for line in text.splitlines():
        name, sep, value = line.lstrip("; ").partition(" = ")
        if not sep or name not in keys:
            continue
        if keys[name] == "print_time_s":
            found["print_time_s"] = parse_duration(value)
        else:
            try:
                found[keys[name]] = sum(float(v) for v in value.split(","))
            except ValueError:
                logger.warning("unreadable G-code trailer line %r", line)
    return found


def parse_info(text: str) -> dict[str, str]:
    """The ``key = value`` lines of ``prusa-slicer --info`` output."""
    info = {}
    for line in text.splitlines():
        name, sep, value = line.partition(" = ")
        if sep and not line.startswith(("[", ";", "#")):
            info[name.strip()] = value.strip()
    return info


def read_profile(path: Path) -> dict[str, str]:
    """The ``key = value`` settings of a PrusaSlicer .ini (whole-line comments skipped)."""
    return parse_info(Path(path).read_text(encoding="utf-8"))


def bed_size_mm(profile: dict[str, str]) -> tuple[float, float, float]:
    """Width, depth (bounding box of ``bed_shape``) and ``max_print_height`` in mm."""
    points = [tuple(float(c) for c in p.split("x")) for p in profile["bed_shape"].split(",")]
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    return max(xs) - min(xs), max(ys) - min(ys), float(profile["max_print_height"])


@functools.lru_cache(maxsize=8)
def slicer_version(exe: str) -> str | None:
    """The version PrusaSlicer prints at the top of ``--help`` (e.g. ``"2.5.0"``)."""
    try:
        out = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    match = re.search(r"PrusaSlicer-(\d+(?:\.\d+)+)", out.stdout + out.stderr)
    return match.group(1) if match else None


def slice_part(stl_path: str | os.PathLike, *, profile: str | os.PathLike | None = None,
               workdir: str | os.PathLike | None = None, timeout_s: float = 300) -> SliceResult:
    """Check one STL with PrusaSlicer: mesh health, bed fit, then slice to G-code.

    Parameters
    ----------
    stl_path : the STL to check (never modified).
    profile : PrusaSlicer .ini to slice with; default the project's ABS profile.
    workdir : where to keep the G-code; default a temporary directory, removed after.
    timeout_s : time limit of each PrusaSlicer call, in seconds.

    Raises
    ------
    ExportError
        The STL does not exist.
    UsageError
        The profile does not exist.

    Returns
    -------
    SliceResult; "skipped" when PrusaSlicer is missing, "failed" with the reason in plain
    words for a defective mesh, a part that does not fit the bed, or a failed slice.
    """
    stl = Path(stl_path).resolve()
    if not stl.is_file():
        raise ExportError(str(stl_path), "STL file does not exist")
    profile = Path(profile or DEFAULT_PROFILE)
    if not profile.is_file():
        raise UsageError(f"{profile}: PrusaSlicer profile does not exist")
    exe = find_slicer()
    if exe is None:
        hint = os.environ.get(SLICER_ENV)
        notes = (f"{SLICER_ENV}={hint} is not an executable",) if hint else ()
        return SliceResult(available=False, verdict="skipped", reason=NOT_FOUND, warnings=notes)
    version = slicer_version(exe)
    try:
        return _check(exe, version, stl, profile, workdir, timeout_s)
    except subprocess.TimeoutExpired:
        return _failed(version, f"PrusaSlicer did not finish within {timeout_s:g} s")
    except OSError as err:
        return SliceResult(available=False, verdict="skipped", slicer_version=version,
                           reason=f"PrusaSlicer at {exe} could not be run: {err}")
    except (KeyError, ValueError) as err:
        return _failed(version, f"profile {profile} is unusable: {err}")


def _failed(version: str | None, reason: str, **found) -> SliceResult:
    return SliceResult(available=True, verdict="failed", reason=reason,
                       slicer_version=version, **found)


def _run(cmd: list[str], timeout_s: float) -> tuple[int, str, list[str]]:
    """Run PrusaSlicer; return exit code, output without log prefixes, and warnings."""
    logger.debug("running %s", " ".join(cmd))
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s,
                          stdin=subprocess.DEVNULL)
    lines, warnings = [], []
    for line in (proc.stdout + "\n" + proc.stderr).splitlines():
        level = _LOG_PREFIX.match(line)
        if level is None:
            lines.append(line)
        elif level.group(1) in ("warning", "error", "fatal"):
            warnings.append(line[level.end():].strip())
    return proc.returncode, "\n".join(lines), warnings


def _last_message(output: str) -> str:
    """The last non-progress line PrusaSlicer printed (its error message)."""
    lines = [s.strip() for s in output.splitlines()
             if s.strip() and not re.match(r"^\d+ => ", s.strip())]
    return lines[-1] if lines else "no message"


def _check(exe: str, version: str | None, stl: Path, profile: Path,
           workdir: str | os.PathLike | None, timeout_s: float) -> SliceResult:
    code, output, warnings = _run([exe, "--loglevel", "2", "--info", str(stl)], timeout_s)
    info = parse_info(output)
    if code != 0 or "manifold" not in info:
        return _failed(version, f"PrusaSlicer could not read the STL: {_last_message(output)}",
                       warnings=tuple(warnings))
    manifold = info["manifold"] == "yes"
    open_edges = int(info.get("open_edges", 0))
    found = {"manifold": manifold, "open_edges": open_edges}
    parts = int(info.get("number_of_parts", 1))
    if parts > 1:
        warnings.append(f"the STL holds {parts} separate parts")
    problems = []
    if open_edges:
        problems.append(f"the mesh has {open_edges} open edges (holes)")
    if not manifold:
        problems.append("the mesh is not manifold")
    config = read_profile(profile)
    size = [float(info[f"size_{axis}"]) for axis in "xyz"]
    bed = bed_size_mm(config)
    if any(s > b + 1e-6 for s, b in zip(size, bed, strict=True)):
        problems.append("the part ({:g} x {:g} x {:g} mm) does not fit the build volume "
                        "({:g} x {:g} x {:g} mm)".format(*size, *bed))
    if problems:
        return _failed(version, "; ".join(problems), warnings=tuple(warnings), **found)
    with tempfile.TemporaryDirectory(prefix="pnmold-slice-") as tmp:
        out_dir = Path(workdir) if workdir is not None else Path(tmp)
        out_dir.mkdir(parents=True, exist_ok=True)
        gcode = out_dir / f"{stl.stem}.gcode"
        cmd = [exe, "--loglevel", "2", "--datadir", str(Path(tmp) / "datadir"),
               "--load", str(profile), "--export-gcode",
               "--center", f"{bed[0] / 2:g},{bed[1] / 2:g}", "--output", str(gcode), str(stl)]
        code, output, slice_warnings = _run(cmd, timeout_s)
        warnings += slice_warnings
        if code != 0 or not gcode.is_file():
            return _failed(version, f"slicing failed: {_last_message(output)}",
                           warnings=tuple(warnings), **found)
        with gcode.open("rb") as fh:  # the trailer is in the last few kB
            fh.seek(max(0, gcode.stat().st_size - 256 * 1024))
            stats = parse_gcode_trailer(fh.read().decode("utf-8", errors="replace"))
    found.update(stats)
    if not stats["filament_mm"]:
        return _failed(version, "slicing produced no extrusion (empty G-code)",
                       warnings=tuple(warnings), **found)
    return SliceResult(available=True, verdict="ok", reason="sliced", slicer_version=version,
                       warnings=tuple(warnings), **found)
