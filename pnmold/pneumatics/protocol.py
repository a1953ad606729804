"""What a step test did: output times, valve switches, the supply level and the bench.

A :class:`StepProtocol` comes from a ``step`` recording (:meth:`StepProtocol.from_recording`,
what ``pnmold diagnose`` replays) or from a :class:`~pnmold.pneumatics.network.Rig` and a
duration (:func:`valve_schedule`, what ``pnmold simulate --dynamic`` runs).

From a recording: the supply level is the median of ``supply_kpa`` while the supply valve is
open (rows at least half the peak); the valve opens at the first such row and every later
fall below half the level vents it (the vent valve opens), every rise opens the supply
again. The bench is read from the metadata when given (``tubing_length_mm``,
``tubing_id_mm``, ``valve_orifice_mm`` or ``valve_sonic_conductance``,
``valve_critical_ratio``, ``valve_volume_ml``, ``atmosphere_kpa``, ``temperature_k``:
``pnmold simulate --dynamic --recording`` writes them all), else the defaults of
``pnmold simulate --dynamic`` (the tubing's bore: the design's inlet tubing). The recording's
``effects`` metadata (the answer of a synthetic recording) is never read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from pnmold.errors import RecordingError, UsageError
from pnmold.pneumatics.gas import P_ATM_PA, T_REF_K, Orifice
from pnmold.pneumatics.network import (
    GAS_LAW,
    ISOTHERMAL_WHY,
    TUBING_LENGTH_MM,
    VALVE_CRITICAL_RATIO,
    VALVE_ORIFICE_MM,
    VALVE_VOLUME_ML,
    Rig,
)
from pnmold.recording.metadata import metadata_number

SUPPLY, VENT, CLOSED = 0, 1, -1  # valve phases of the compiled model


class Schedule(NamedTuple):
    """Output times, segment boundaries (the valve opens at ``switch_s[0]``, the last is the
    end) and each segment's valve phase (``SUPPLY`` or ``VENT``)."""

    time_s: np.ndarray
    switch_s: np.ndarray
    phases: np.ndarray

    def phase_rows(self) -> np.ndarray:
        """The valve phase at every output time (``CLOSED`` before the valve opens; a row at
        a switch belongs to the segment it starts)."""
        k = np.clip(np.searchsorted(self.switch_s, self.time_s, side="right") - 1, 0, self.phases.size - 1)
        return np.where(self.time_s < self.switch_s[0], CLOSED, self.phases[k]).astype(np.int64)


def valve_schedule(vent_at_s: float | None, duration_s: float, out_step_s: float) -> Schedule:
    """The supply valve opens at t = 0 and, with ``vent_at_s``, the vent valve then (a
    positive multiple of ``out_step_s``, to 1e-12 s); outputs every ``out_step_s`` to
    ``duration_s``. The valves switch at ``vent_at_s`` itself: the output row nearest it
    shows the supply open when it falls (by rounding) before it."""
    n = int(round(duration_s / out_step_s))
    t = np.linspace(0.0, n * out_step_s, n + 1)
    if vent_at_s is None or vent_at_s >= t[-1]:
        return Schedule(t, np.array([0.0, t[-1]]), np.array([SUPPLY], np.int64))
    k = int(round(vent_at_s / out_step_s))
    if not math.isclose(k * out_step_s, vent_at_s, rel_tol=0, abs_tol=1e-12) or k == 0:
        raise UsageError(f"vent_at_s ({vent_at_s}) must be a positive multiple of the output step {out_step_s} s")
    return Schedule(t, np.array([0.0, float(vent_at_s), t[-1]]), np.array([SUPPLY, VENT], np.int64))


def _default_valve() -> Orifice:
    return Orifice.from_diameter_mm(VALVE_ORIFICE_MM, VALVE_CRITICAL_RATIO)


@dataclass(frozen=True)
class StepProtocol:
    """What a step recording did (module docstring): its schedule and its bench."""

    time_s: np.ndarray
    switch_s: np.ndarray  # segment boundaries: valve opens at switch_s[0], the last is the end
    phases: np.ndarray  # SUPPLY or VENT per segment
    supply_kpa: float
    tubing_length_mm: float = TUBING_LENGTH_MM
    tubing_id_mm: float | None = None  # None: the design's inlet tubing
    supply_valve: Orifice = field(default_factory=_default_valve)
    vent_valve: Orifice | None = None  # None: as the supply valve
    valve_volume_ml: float = VALVE_VOLUME_ML
    atmosphere_kpa: float = P_ATM_PA / 1000
    temperature_k: float = T_REF_K

    @property
    def schedule(self) -> Schedule:
        return Schedule(np.asarray(self.time_s, float), np.asarray(self.switch_s, float),
                        np.asarray(self.phases, np.int64))

    def rig(self, tubing_id_mm: float, *, dead_volume_ml: float = 0.0, flow_restriction: float = 0.0) -> Rig:
        """The bench of the recording (``tubing_id_mm``: when the recording does not say)."""
        return Rig(self.supply_kpa, self.supply_valve, self.vent_valve or self.supply_valve, self.tubing_length_mm,
                   self.tubing_id_mm if self.tubing_id_mm is not None else tubing_id_mm, self.valve_volume_ml,
                   None, dead_volume_ml, flow_restriction, self.atmosphere_kpa, self.temperature_k)

    @classmethod
    def from_recording(cls, rec) -> StepProtocol:
        """The protocol of a ``step`` recording (module docstring); RecordingError names the file."""
        t = np.asarray(rec.columns["time_s"], float)
        supply = np.asarray(rec.columns["supply_kpa"], float)
        if not np.all(np.isfinite(t)) or not np.all(np.isfinite(supply)):
            raise RecordingError(rec.path, None, "time_s and supply_kpa must be finite", column="supply_kpa")
        peak = float(np.max(supply))
        if not peak > 0:
            raise RecordingError(rec.path, None, "the supply never opens (supply_kpa is never above 0)",
                                 column="supply_kpa")
        on = supply >= 0.5 * peak
        level = float(np.median(supply[on]))
        first = int(np.argmax(on))
        switch, phases = [float(t[first])], [SUPPLY]
        for i in range(first + 1, len(t)):
            if on[i] != on[i - 1]:
                switch.append(float(t[i]))
                phases.append(SUPPLY if on[i] else VENT)
        end = float(t[-1])
        if end > switch[-1]:
            switch.append(end)
        else:  # the last switch is the last row: nothing to integrate after it
            phases.pop()
            if not phases:
                raise RecordingError(rec.path, None, "the supply opens only at the last row", column="supply_kpa")
        gas_law = rec.metadata.get("gas_law", GAS_LAW)
        if gas_law != GAS_LAW:
            raise RecordingError(rec.path, 1, f"gas_law {gas_law!r}: {ISOTHERMAL_WHY} (pnmold simulate --dynamic "
                                 "--gas-law isothermal)")
        protocol = cls(t, np.array(switch), np.array(phases, np.int64), level)
        return replace(protocol, **_bench(rec))


def _bench(rec) -> dict:
    """The bench fields the recording's metadata gives (RecordingError names a bad one)."""

    def number(key: str, low: float = 0.0, high: float = math.inf, closed: bool = False) -> float | None:
        return metadata_number(rec.metadata, key, rec.path, low=low, high=high, closed=closed)

    b = number("valve_critical_ratio", 0.0, 0.999, closed=True)
    b = VALVE_CRITICAL_RATIO if b is None else b
    conductance = number("valve_sonic_conductance")
    if conductance is not None:
        valve = Orifice.from_l_per_s_bar(conductance, b)
    else:
        valve = Orifice.from_diameter_mm(number("valve_orifice_mm") or VALVE_ORIFICE_MM, b)
    bench = {"supply_valve": valve, "tubing_id_mm": number("tubing_id_mm")}
    for key in ("tubing_length_mm", "valve_volume_ml", "atmosphere_kpa", "temperature_k"):
        value = number(key)
        if value is not None:
            bench[key] = value
    return bench
