"""``pnmold simulate DESIGN --dynamic`` as library functions: the bench from the options
(:func:`rig_for`), and the study that runs the step model and writes the JSON (schema
``pnmold.simulation/1``, ``model: dynamic``), the ``step`` recording (docs/recording-format.md) and the
figure (:func:`run_step_study`). Bad values raise :class:`~pnmold.errors.UsageError` naming
the command-line option.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pnmold.conventions import default_out_dir
from pnmold.effects import check_effects
from pnmold.errors import DesignError, UsageError
from pnmold.pneumatics.dynamics import OUTPUT_STEP_S, StepResponse, simulate_step
from pnmold.pneumatics.effects import with_effects
from pnmold.pneumatics.gas import Orifice
from pnmold.pneumatics.mechanics import BendingDynamics
from pnmold.pneumatics.model import MAX_SUPPLY_KPA
from pnmold.pneumatics.network import (
    GAS_LAW,
    ISOTHERMAL_WHY,
    TUBING_LENGTH_MM,
    VALVE_CRITICAL_RATIO,
    VALVE_ORIFICE_MM,
    ActuatorLine,
    Rig,
)

log = logging.getLogger(__name__)

MAX_DURATION_S = 60.0
STEP_COLUMNS = ("time_s", "supply_kpa", "pressure_kpa", "flow_slpm", "bend_angle_deg", "tip_x_mm", "tip_z_mm")


def _positive(option: str, value: float | None, hi: float = math.inf) -> None:
    if value is not None and not (math.isfinite(value) and 0 < value <= hi):
        limit = f" and at most {hi:g}" if math.isfinite(hi) else ""
        raise UsageError(f"{option} must be a positive number{limit}, got {value:g}")


def rig_for(design, *, supply_kpa: float | None, valve_orifice_mm: float | None = None,
            valve_sonic_conductance: float | None = None, valve_critical_ratio: float | None = None,
            tubing_length_mm: float | None = None, tubing_id_mm: float | None = None,
            vent_at_s: float | None = None, effects: Mapping[str, float] | None = None) -> Rig:
    """The bench of ``simulate --dynamic``'s options (None: the default) with the dynamic
    effects on; UsageError names the option. ``vent_at_s`` is rounded to the output step."""
    if supply_kpa is None:
        raise UsageError("--supply-kpa is required with --dynamic (regulated supply, gauge kPa)")
    _positive("--supply-kpa", supply_kpa, MAX_SUPPLY_KPA)
    _positive("--valve-orifice-mm", valve_orifice_mm, 20.0)
    _positive("--valve-sonic-conductance", valve_sonic_conductance, 100.0)
    tubing_mm = tubing_length_mm if tubing_length_mm is not None else TUBING_LENGTH_MM
    _positive("--tubing-length-mm", tubing_mm, 100_000.0)
    _positive("--tubing-id-mm", tubing_id_mm, 50.0)
    _positive("--vent-at-s", vent_at_s, MAX_DURATION_S)
    if valve_orifice_mm is not None and valve_sonic_conductance is not None:
        raise UsageError("--valve-orifice-mm and --valve-sonic-conductance: give one of them, not both")
    b = valve_critical_ratio if valve_critical_ratio is not None else VALVE_CRITICAL_RATIO
    if not (math.isfinite(b) and 0 <= b < 0.999):
        raise UsageError(f"--valve-critical-ratio must be in [0, 0.999), got {b:g}")
    if valve_sonic_conductance is not None:
        valve = Orifice.from_l_per_s_bar(valve_sonic_conductance, b)
    else:
        valve = Orifice.from_diameter_mm(valve_orifice_mm or VALVE_ORIFICE_MM, b)
    vent = None
    if vent_at_s is not None:
        vent = round(vent_at_s / OUTPUT_STEP_S) * OUTPUT_STEP_S
        if vent < OUTPUT_STEP_S:
            raise UsageError(f"--vent-at-s must be at least {OUTPUT_STEP_S:g} s, got {vent_at_s:g}")
    rig = Rig(supply_kpa, valve, valve, tubing_mm, tubing_id_mm if tubing_id_mm is not None
              else design.inlet.tubing_id_mm, vent_at_s=vent)
    return with_effects(rig, dynamic_effects(effects))


def dynamic_effects(effects: Mapping[str, float] | None) -> dict[str, float]:
    """The effects of ``--effects`` the step model carries, checked (UsageError names ``--effects``)."""
    try:
        return check_effects(dict(effects or {}), model="dynamic")
    except DesignError as err:
        raise UsageError(f"--effects: {err}") from None


def check_gas_law(gas_law: str) -> None:
    """Refuse ``--gas-law`` other than ``isothermal``, saying why."""
    if gas_law != GAS_LAW:
        raise UsageError(f"--gas-law {gas_law}: {ISOTHERMAL_WHY}; use --gas-law isothermal")


@dataclass(frozen=True, eq=False)
class StepStudy:
    """What :func:`run_step_study` computed and wrote, and the summary a person reads."""

    response: StepResponse
    document: dict[str, Any]
    written: list[Path]
    summary: list[str]

    def __repr__(self) -> str:
        return f"<StepStudy {self.document['design']['name']}: {self.summary[0]}>"

    def _repr_html_(self) -> str:
        from pnmold.frames import summary_html

        rows = {"design": self.document["design"]["name"], "files": ", ".join(str(p) for p in self.written)}
        return summary_html("pnmold simulate --dynamic", rows, self.summary)


def run_step_study(design, rig: Rig, *, duration_s: float = 0.5, gas_law: str = GAS_LAW,
                   effects: Mapping[str, float] | None = None, json_path: str | Path | None = None,
                   recording_path: str | Path | None = None, plot_path: str | Path | None = None,
                   progress: Callable[[str], None] | None = None) -> StepStudy:
    """The design's step response on ``rig``: the chamber law (the FE's free-bending curve),
    the compiled step model, then the JSON, the recording and the figure (each written
    atomically, after everything is computed; the figure beside the JSON or the recording
    unless ``plot_path``, else ``out/<design>/step_response.png``). ``effects``: as given on
    the command line, for the document (default: those set on ``rig``)."""
    from pnmold.pneumatics import law as laws
    from pnmold.pneumatics.plot import plot_step

    _positive("--duration-s", duration_s, MAX_DURATION_S)
    check_gas_law(gas_law)
    effects = dynamic_effects(effects if effects is not None else _rig_effects(rig))
    say = progress or log.info
    say(f"{design.name}: chamber law (FE free-bending curve)")
    law = laws.chamber_law_for(design, up_to_kpa=rig.supply_kpa, progress=progress)
    say(f"step response: {duration_s:g} s at {rig.supply_kpa:g} kPa ({gas_law})")
    response = simulate_step(law, ActuatorLine.from_design(design), BendingDynamics.from_design(design), rig,
                             duration_s=duration_s)
    doc = simulation_doc(design, rig, response, effects)
    written = []
    if json_path:
        from pnmold.fsutil import write_json

        written.append(write_json(json_path, doc))
    if recording_path:
        from pnmold.recording import write_recording

        written.append(write_recording(recording_path, "step", response.recording_columns(),
                                       recording_metadata(design, rig, effects)))
    figure = _plot_path(design, plot_path, json_path, recording_path)
    plot_step(response, _title(design, rig, response), figure)
    written.append(figure)
    return StepStudy(response, doc, written, _summary(response))


def _rig_effects(rig: Rig) -> dict[str, float]:
    return {k: v for k, v in (("dead_volume", rig.dead_volume_ml), ("flow_restriction", rig.flow_restriction)) if v}


def recording_metadata(design, rig: Rig, effects: Mapping[str, float]) -> dict[str, str]:
    """The ``step`` recording's metadata: the design, the bench (all that
    :meth:`~pnmold.pneumatics.protocol.StepProtocol.from_recording` reads back) and the effects."""
    meta = {"design": design.name, "orientation": "horizontal", "model": "dynamic",
            "supply_kpa": f"{rig.supply_kpa:g}", "tubing_length_mm": f"{rig.tubing_length_mm:g}",
            "tubing_id_mm": f"{rig.tubing_id_mm:g}", "gas_law": GAS_LAW,
            "valve_sonic_conductance": f"{rig.supply_valve.conductance_l_per_s_bar:.12g}",
            "valve_critical_ratio": f"{rig.supply_valve.critical_ratio:g}",
            "valve_volume_ml": f"{rig.valve_volume_ml:g}", "atmosphere_kpa": f"{rig.atmosphere_kpa:g}",
            "temperature_k": f"{rig.temperature_k:g}"}
    if effects:
        meta["effects"] = ",".join(f"{k}={v:g}" for k, v in effects.items())
    return meta


def simulation_doc(design, rig: Rig, response: StepResponse, effects: Mapping[str, float]) -> dict[str, Any]:
    """The ``pnmold.simulation/1`` document of a step response."""
    from pnmold.design import digest
    from pnmold.simulate import SCHEMA

    s = response.series
    series = {k: [round(float(v), 6) for v in s[k]] for k in s}
    step_keys = ("time_s", "supply_kpa", "pressure_kpa", "flow_slpm", "bend_angle_deg", "tip_x_mm", "tip_z_mm",
                 "cavity_volume_ml")
    steps = [{k: series[k][i] for k in step_keys} for i in range(len(series["time_s"]))]
    info = {k: (round(v, 9) if isinstance(v, float) else v) for k, v in response.info.items()}
    return {
        "schema": SCHEMA, "design": {"name": design.name, "digest": digest(design)}, "model": "dynamic",
        "kind": "step", "effects": dict(effects),
        "inputs": {"supply_kpa": rig.supply_kpa, "tubing_length_mm": rig.tubing_length_mm,
                   "tubing_id_mm": rig.tubing_id_mm, "valve_sonic_conductance_l_per_s_bar":
                   round(rig.supply_valve.conductance_l_per_s_bar, 6),
                   "valve_critical_ratio": rig.supply_valve.critical_ratio, "valve_volume_ml": rig.valve_volume_ml,
                   "vent_at_s": rig.vent_at_s, "dead_volume_ml": rig.dead_volume_ml,
                   "flow_restriction": rig.flow_restriction, "atmosphere_kpa": rig.atmosphere_kpa,
                   "temperature_k": rig.temperature_k},
        "time_to_full_bend_s": None if response.time_to_full_bend_s is None
        else round(response.time_to_full_bend_s, 9),
        "reason": response.reason,
        "full_bend_pressure_kpa": None if response.info["full_bend_pressure_kpa"] is None
        else round(response.info["full_bend_pressure_kpa"], 6),
        "model_info": info,
        "series": series,
        "chamber_pressure_kpa": np.round(response.chamber_pressure_kpa, 6).tolist(),
        "steps": steps,
    }


def _plot_path(design, plot_path, json_path, recording_path) -> Path:
    if plot_path:
        return Path(plot_path)
    for given in (json_path, recording_path):
        if given:
            return Path(given).with_suffix(".png")
    return default_out_dir(design.name) / "step_response.png"


def _title(design, rig: Rig, response: StepResponse) -> str:
    tfb = response.time_to_full_bend_s
    head = f"{design.name}: {rig.supply_kpa:g} kPa supply, tubing {rig.tubing_length_mm:g} mm x {rig.tubing_id_mm:g} mm"
    info, end = response.info, response.info["law_end"]
    if tfb is not None:
        return head + f"; full bend at {tfb * 1000:.1f} ms"
    if info.get("stopped_at_law_end_s") is not None:  # the reason in full is in the summary and the JSON
        return head + (f"; no full bend: ends at {info['stopped_at_law_end_s'] * 1000:.1f} ms where the FE's law "
                       f"ends ({end['pressure_kpa']:.4g} kPa, {end['stop'].replace('_', ' ')})")
    if info["full_bend_pressure_kpa"] is None:
        return head + (f"; full bend not within the FE's solved range (ends at {end['pressure_kpa']:.4g} kPa, "
                       f"{end['bend_angle_deg']:.1f} deg, {end['stop'].replace('_', ' ')})")
    return head + f"; {response.reason}"


def _summary(response: StepResponse) -> list[str]:
    s, info = response.series, response.info
    tfb, end = response.time_to_full_bend_s, info["law_end"]
    if info["full_bend_pressure_kpa"] is not None:
        quasi = (f"quasi-static full bend at {info['full_bend_pressure_kpa']:.1f} kPa "
                 f"({info['volume_change_at_full_bend_ml']:.2f} mL)")
    else:
        quasi = (f"quasi-static full bend: not reached within the FE's solved range (ends at "
                 f"{end['pressure_kpa']:.4g} kPa, {end['bend_angle_deg']:.1f} deg: {end['reason']})")
    stopped = info.get("stopped_by")
    after = f"; then at {info['stopped_at_law_end_s'] * 1000:.1f} ms {stopped}" if stopped and tfb is not None else ""
    return [f"time to full bend: {tfb * 1000:.1f} ms{after}" if tfb is not None
            else f"time to full bend: never ({response.reason})",
            f"peak flow {np.max(s['flow_slpm']):.2f} SLPM; at {s['time_s'][-1]:g} s"
            + (" (the end of the law: the run stops there)" if stopped else "") + f": inlet "
            f"{s['pressure_kpa'][-1]:.1f} kPa, far chamber {s['pressure_far_kpa'][-1]:.1f} kPa, "
            f"volume change {s['volume_ml'][-1]:.2f} mL, bend {s['bend_angle_deg'][-1]:.0f} deg",
            f"{quasi}; bending mode {info['natural_frequency_hz']:.1f} Hz, damping ratio "
            f"{info['damping_ratio']:g} (assumed)"]
