"""The one reader of a recording's metadata: the ``# key: value`` lines before the header, and
their values as numbers or choices, each refused with a :class:`~pnmold.errors.RecordingError`
that names the file, line 1 and the key (docs/recording-format.md).

:mod:`.format` reads the lines and the format's own keys (kind, orientation, ramp rate),
:mod:`.measurement` what they say of the camera and the rig, and the step model its bench
(:meth:`pnmold.pneumatics.protocol.StepProtocol.from_recording`): all through these functions.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from pnmold.errors import RecordingError
from pnmold.recording.units import PRESSURE_UNITS


def read_metadata(lines: list[str], path: str) -> tuple[dict[str, str], int]:
    """The metadata of a recording's leading ``#`` lines (keys lower case, the first word of each
    value; ``##`` lines and blank ``#`` lines are comments; the empty cells a spreadsheet adds at
    the end of a line, ``;;`` or ``,,``, are dropped) and the line number of the header."""
    meta, n = {}, 0
    for n, line in enumerate(lines, 1):
        if not line.startswith("#"):
            return meta, n
        body = line[1:].strip().rstrip(",;\t").strip()  # a spreadsheet pads the line with empty cells
        if not body or body.startswith("#"):  # blank, or a "##" comment
            continue
        if ":" not in body:
            raise RecordingError(path, n, f"metadata must read '# key: value', got {line.strip()!r}")
        key, value = (s.strip() for s in body.split(":", 1))
        meta[key.lower()] = value.split()[0] if value else ""
    return meta, n + 1


def metadata_number(meta: Mapping[str, str], key: str, path: str, *, low: float = 0.0, high: float = math.inf,
                    closed: bool = False) -> float | None:
    """``meta[key]`` as a number in ``(low, high)`` (``[low, high)`` when ``closed``), None when the
    key is absent; RecordingError names the key and the bounds."""
    if key not in meta:
        return None
    try:
        value = float(meta[key])
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and (low <= value if closed else low < value) and value < high):
        bounds = (f"{'>=' if closed else '>'} {low:g}" if high == math.inf
                  else f"in {'[' if closed else '('}{low:g}, {high:g})")
        raise RecordingError(path, 1, f"metadata {key} must be a number {bounds}, got {meta[key]!r}")
    return value


def metadata_choice(meta: Mapping[str, str], key: str, options: tuple[str, ...], default: str, path: str) -> str:
    """``meta[key]`` (lower case) if it is one of ``options``, ``default`` when absent."""
    value = meta.get(key, default).lower()
    if value not in options:
        raise RecordingError(path, 1, f"metadata {key} must be one of {', '.join(options)}, got {value!r}")
    return value


def conversion(source: str, factor: float) -> str:
    """How a column or key was converted at reading, as :attr:`Recording.conversions` says it."""
    return f"from {source} (x {factor:.7g})"


def rate_in_kpa(meta: dict[str, str], path: str) -> dict[str, str]:
    """``rate_<pressure unit>_per_s`` as ``rate_kpa_per_s`` (added to ``meta``); the conversion."""
    given = [k for k in meta if k != "rate_kpa_per_s" and k.startswith("rate_") and k.endswith("_per_s")
             and k[5:-6] in PRESSURE_UNITS]
    if not given:
        return {}
    if len(given) > 1 or "rate_kpa_per_s" in meta:
        both = sorted({*given, "rate_kpa_per_s"} & set(meta))
        raise RecordingError(path, 1, f"two ramp rates given ({', '.join(both)}); keep one")
    key, factor = given[0], PRESSURE_UNITS[given[0][5:-6]]
    try:
        meta["rate_kpa_per_s"] = repr(float(meta[key]) * factor)
    except ValueError:
        raise RecordingError(path, 1, f"{key} must be a positive number, got {meta[key]!r}") from None
    return {"rate_kpa_per_s": conversion(key, factor)}
