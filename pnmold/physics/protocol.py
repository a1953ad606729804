"""What the reduced model is asked to reproduce: a pressure sequence and its history.

A :class:`Protocol` is the test a recording came from (docs/recording-format.md): the kind of
measurement, the pressures in time order, the orientation, and where known the time,
cycle and phase of each row. History effects (``mullins``, ``viscoelasticity``) read the
order, the cycles and the time; without ``time_s`` the time is the pressure travelled
divided by ``rate_kpa_per_s`` (no rate: quasi-static).

A P-V test whose rig sets the volume (a piston or syringe pump) over one loading ramp is *read by
its volume* (:func:`read_by_volume`): the rig sets the volume exactly and the pressure is what it
measures, so the model is asked for the pressure at each recorded volume (its ``volume_ml``), not
the volume at each recorded pressure. Near a pressure plateau (a limit point, a snap) a step of
volume moves the pressure little; read by pressure, the same rows would be a wall of volume the
model could only place by the pressure's own scatter. A recording with cycles stays read by
pressure: the history effects follow its time order.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pnmold.conventions import NO_GRAVITY, ORIENTATIONS, QUASI_STATIC_KINDS
from pnmold.errors import DesignError
from pnmold.recording.measurement import Measurement


@dataclass(frozen=True, eq=False)
class Protocol:
    """A pressure sequence (kPa, in time order) with its kind, orientation and history."""

    kind: str
    pressure_kpa: np.ndarray
    orientation: str = "chambers_up"
    time_s: np.ndarray | None = None
    cycle: np.ndarray | None = None
    phase: np.ndarray | None = None
    rate_kpa_per_s: float | None = None
    measurement: Measurement = Measurement()  # how the recording reads the model (pnmold.recording.measurement)
    volume_ml: np.ndarray | None = None  # the recorded volumes of a test read by its volume (read_by_volume)

    def __post_init__(self) -> None:
        if self.kind not in QUASI_STATIC_KINDS:
            raise DesignError("protocol.kind", f"one of {', '.join(QUASI_STATIC_KINDS)}, got {self.kind!r}")
        if self.orientation not in (*ORIENTATIONS, NO_GRAVITY):
            raise DesignError("protocol.orientation", f"one of {', '.join((*ORIENTATIONS, NO_GRAVITY))}, "
                              f"got {self.orientation!r}")
        p = np.asarray(self.pressure_kpa, float)
        if p.ndim != 1 or p.size == 0 or not np.all(np.isfinite(p)):
            raise DesignError("protocol.pressure_kpa", "needs a 1-D sequence of finite pressures")
        object.__setattr__(self, "pressure_kpa", p)
        for name in ("time_s", "cycle", "phase", "volume_ml"):
            value = getattr(self, name)
            if value is not None and len(value) != p.size:
                raise DesignError(f"protocol.{name}", f"has {len(value)} rows, the pressures {p.size}")
        if self.rate_kpa_per_s is not None and not (self.rate_kpa_per_s > 0 and math.isfinite(self.rate_kpa_per_s)):
            raise DesignError("protocol.rate_kpa_per_s", f"must be > 0, got {self.rate_kpa_per_s}")

    def __len__(self) -> int:
        return int(self.pressure_kpa.size)

    @property
    def by_volume(self) -> bool:
        """The model is read at the recorded volumes (``volume_ml``), the pressure its prediction."""
        return self.volume_ml is not None

    @classmethod
    def from_pressures(cls, kind: str, pressures_kpa: Sequence[float], cycles: int = 1,
                       rate_kpa_per_s: float | None = None, orientation: str = "chambers_up") -> Protocol:
        """One inflation through ``pressures_kpa``; with ``cycles`` > 1, N inflations and deflations
        (the FE's ``pnmold simulate`` rows: each deflation retraces the inflation's pressures)."""
        up = np.asarray(pressures_kpa, float)
        if cycles < 1:
            raise DesignError("protocol.cycles", f"must be at least 1, got {cycles}")
        parts, cyc, phase = [], [], []
        for c in range(1, cycles + 1):
            parts.append(up)
            cyc += [c] * up.size
            phase += ["inflate"] * up.size
            if cycles > 1:
                down = up[-2::-1]
                parts.append(down)
                cyc += [c] * down.size
                phase += ["deflate"] * down.size
        p = np.concatenate(parts)
        time = None
        if rate_kpa_per_s:
            time = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(p)))]) / rate_kpa_per_s
        return cls(kind, p, orientation, time, np.array(cyc, int), np.array(phase, dtype=object), rate_kpa_per_s)

    @classmethod
    def ramp(cls, kind: str, p_max_kpa: float, step_kpa: float, cycles: int = 1,
             rate_kpa_per_s: float | None = None, orientation: str = "chambers_up") -> Protocol:
        """0, step, ..., p_max (kPa), then as :meth:`from_pressures`."""
        if not (p_max_kpa > 0 and step_kpa > 0):
            raise DesignError("protocol.p_max_kpa", f"need p_max > 0 and step > 0, got {p_max_kpa}, {step_kpa}")
        n = int(math.floor(p_max_kpa / step_kpa + 1e-9))
        p = [i * step_kpa for i in range(n + 1)]
        if p[-1] < p_max_kpa - 1e-9:
            p.append(p_max_kpa)
        return cls.from_pressures(kind, p, cycles, rate_kpa_per_s, orientation)

    @classmethod
    def from_recording(cls, recording) -> Protocol:
        """The protocol of a :class:`pnmold.recording.Recording` (kinds bending, pv, force)."""
        cols = recording.columns
        get = cols.get
        return cls(recording.kind, np.asarray(cols["pressure_kpa"], float), recording.orientation,
                   None if get("time_s") is None else np.asarray(get("time_s"), float),
                   None if get("cycle") is None else np.asarray(get("cycle"), int),
                   get("phase"), recording.rate_kpa_per_s, recording.measurement,
                   np.asarray(cols["volume_ml"], float) if read_by_volume(recording) else None)

    def times_s(self) -> np.ndarray | None:
        """Time of each row: ``time_s``, else pressure travelled / rate, else None (quasi-static)."""
        if self.time_s is not None:
            return np.asarray(self.time_s, float)
        if self.rate_kpa_per_s:
            p = self.pressure_kpa
            return np.concatenate([[0.0], np.cumsum(np.abs(np.diff(p)))]) / self.rate_kpa_per_s
        return None


def read_by_volume(recording) -> bool:
    """A P-V recording whose rig sets the volume (metadata ``rig: volume``, the default) over one loading
    ramp: no deflation, no second cycle, the volume never falling. Its model is read at the recorded
    volumes (see the module docstring)."""
    cols = recording.columns
    if recording.kind != "pv" or recording.measurement.rig != "volume" or "volume_ml" not in cols:
        return False
    cycle, phase = cols.get("cycle"), cols.get("phase")
    if cycle is not None and len(set(np.asarray(cycle, int).tolist())) > 1:
        return False
    if phase is not None and any(str(ph) != "inflate" for ph in phase):
        return False
    return bool(np.all(np.diff(np.asarray(cols["volume_ml"], float)) >= 0))
