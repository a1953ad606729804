"""Doubts about a recording that reads well but cannot be what the lab meant: every pressure the
same, every pressure below the atmosphere, a zero offset of the pressure sensor.

:func:`doubts` lists them; a doubt marked ``refuse`` leaves the diagnosis nothing to fit (it is
raised as a :class:`~pnmold.errors.RecordingError` by :func:`check_usable`), the others are
warnings every verb that reads recordings prints. The reasons for users: docs/recording-format.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pnmold.errors import RecordingError
from pnmold.recording.format import Recording

#: assumed: a gauge-pressure sensor's zero offset and noise stay within this (kPa); rows further below
#: zero are not an offset
NEGATIVE_TOLERANCE_KPA = 1.0
#: assumed: pressures that differ by less than this (kPa) are one pressure for a pressure range
SAME_PRESSURE_KPA = 0.05


@dataclass(frozen=True)
class Doubt:
    refuse: bool
    column: str
    message: str


def doubts(rec: Recording) -> list[Doubt]:
    """What is doubtful in ``rec``'s pressures (the column the kind is driven by)."""
    column = "supply_kpa" if rec.kind == "step" else "pressure_kpa"
    if column not in rec.columns:
        return []
    p = np.asarray(rec.columns[column], dtype=float)
    found = []
    if np.all(p <= NEGATIVE_TOLERANCE_KPA) and np.any(p < -NEGATIVE_TOLERANCE_KPA):
        found.append(Doubt(True, column, f"every pressure is at or below 0 kPa (down to {p.min():.3g}): pnmold's "
                           "pressures are gauge (above the atmosphere) and its actuators inflate: a vacuum-driven "
                           "actuator is not modelled; check the sensor's sign (docs/recording-format.md)"))
    elif np.any(p < -NEGATIVE_TOLERANCE_KPA):
        n = int(np.sum(p < -NEGATIVE_TOLERANCE_KPA))
        found.append(Doubt(False, column, f"{n} row(s) below -{NEGATIVE_TOLERANCE_KPA:g} kPa (down to {p.min():.3g}): "
                           "more than a gauge sensor's zero offset; check the sensor's zero or the sign"))
    if np.ptp(p) < SAME_PRESSURE_KPA:
        found.append(Doubt(rec.kind != "step", column, f"all {len(p)} rows are at one pressure ({np.median(p):.4g} "
                           "kPa): a response needs a range of pressures to fit (a creep test at one pressure "
                           "needs time_s and a step recording)"))
    return found


def check_usable(rec: Recording) -> list[Doubt]:
    """Raise the first refusing doubt as a RecordingError naming the file and column; return the warnings."""
    found = doubts(rec)
    for d in found:
        if d.refuse:
            raise RecordingError(rec.path, None, d.message, column=d.column)
    return found
